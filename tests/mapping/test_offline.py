"""Offline SLAM on the CARMEN excerpts: scoring, output files, and logs with bad lines."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.map_files import load_map
from navstack.mapping.carmen import read_carmen
from navstack.mapping.g2o import read_g2o
from navstack.mapping.map_metrics import relative_pose_error
from navstack.mapping.offline import (
    LOG_PROFILE,
    OfflineResult,
    OfflineSlamError,
    log_duration,
    run_carmen,
    write_outputs,
)
from navstack.mapping.slam_io import load_posegraph

DATA = Path(__file__).resolve().parents[1] / "data" / "carmen"
INTEL = DATA / "intel_excerpt.log"


@pytest.fixture(scope="module")
def intel() -> OfflineResult:
    return run_carmen(INTEL)


def test_one_pose_per_scan_and_slam_beats_odometry(intel: OfflineResult) -> None:
    log = read_carmen(INTEL)
    assert intel.trajectory.shape == (6, 3) and intel.stamps.shape == (6,)
    assert np.array_equal(intel.node_index, np.arange(6))  # log profile: every scan a node
    assert intel.reference is not None
    assert np.array_equal(intel.reference, log.reference_poses())
    assert np.array_equal(intel.stamps, log.timestamps())
    odometry = relative_pose_error(log.odometry_poses(), log.reference_poses())
    assert intel.rpe is not None and intel.rpe.pairs == 5
    assert intel.rpe.trans_mean_m < 0.6 * odometry.trans_mean_m  # 0.023 vs 0.051 m
    assert intel.rpe.rot_mean_deg < 0.6 * odometry.rot_mean_deg  # 0.31 vs 0.93 deg
    assert intel.odometry_rpe == odometry
    # FLASER stamps 32.9068 .. 42.1923 s
    assert intel.log_duration_s == pytest.approx(42.1923 - 32.9068, abs=1e-9)
    assert intel.speedup == pytest.approx(intel.log_duration_s / intel.wall_s)
    assert 0.0 < intel.ms_per_scan < 1e3 * intel.wall_s
    assert intel.skipped == [] and intel.scans_in_log == 6


def test_written_files_reload(intel: OfflineResult, tmp_path: Path) -> None:
    files = write_outputs(intel, tmp_path / "out")
    names = {Path(p).name for p in files.values()}
    assert names == {"map.yaml", "map.pgm", "map.png", "trajectory.csv", "map.posegraph",
                     "graph.g2o", "summary.json"}
    assert all(Path(p).is_file() for p in files.values())
    grid = intel.mapper.build_map()
    loaded = load_map(files["map_yaml"])
    assert loaded.info.resolution == pytest.approx(0.05)
    # the SLAM's own free threshold (map_free_scans: 2), with unknown kept on reload
    expected = grid.to_occupancy_grid(crop=True,
                                      free_thresh=intel.mapper.params.map_free_thresh)
    assert np.array_equal(loaded.data, expected.data)
    assert (loaded.data == 0).sum() > (grid.to_occupancy_grid(crop=True).data == 0).sum()
    assert loaded.info.origin.position == expected.info.origin.position
    assert (loaded.data == 100).sum() > 200  # walls seen by the 6 scans (305 cells)

    rows = Path(files["trajectory"]).read_text().splitlines()
    assert rows[0] == "stamp,x,y,theta,ref_x,ref_y,ref_theta" and len(rows) == 7
    table = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    assert np.array_equal(table[:, 1:4], intel.trajectory)  # repr floats round-trip
    assert intel.reference is not None and np.array_equal(table[:, 4:], intel.reference)

    graph = read_g2o(files["g2o"])
    assert graph.num_vertices == 6 and graph.num_edges == 5
    assert np.array_equal(graph.poses, intel.mapper.poses())
    reloaded = load_posegraph(files["posegraph"])
    assert len(reloaded.nodes) == 6
    assert np.allclose(reloaded.poses(), intel.mapper.poses(), atol=1e-12)

    summary = json.loads(Path(files["summary"]).read_text())
    assert intel.rpe is not None
    assert summary["rpe"]["trans_mean_m"] == intel.rpe.trans_mean_m
    assert summary["metrics"]["rot_err_deg"] == intel.rpe.rot_mean_deg
    assert summary["scans"] == 6 and summary["skipped_lines"] == {"count": 0, "first": []}
    assert summary["params"] == LOG_PROFILE


def _with_bad_lines(tmp_path: Path) -> Path:
    lines = INTEL.read_text().splitlines()
    assert lines[210].startswith("FLASER 180 3 3.14")  # line 211, the 4th scan
    lines[210] = " ".join(lines[210].split()[:100])  # truncated: 100 of 191 fields
    lines.insert(189, "ODOM 0.5 0.1 x!x 0 0 0 37.0 pippo 37.0")  # garbled, becomes line 190
    path = tmp_path / "bad.log"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_garbled_and_truncated_lines_are_reported_not_fatal(tmp_path: Path) -> None:
    result = run_carmen(_with_bad_lines(tmp_path))
    assert [(s.line_no, s.reason) for s in result.skipped] == [
        (190, "field 3 'x!x' is not a number"),
        (212, "expected 191 fields for FLASER with 180 readings, got 100")]
    assert result.scans == 5 and result.rpe is not None and result.rpe.pairs == 4
    files = write_outputs(result, tmp_path / "out")
    summary = json.loads(Path(files["summary"]).read_text())
    assert summary["skipped_lines"] == {"count": 2, "first": [
        {"line": 190, "reason": "field 3 'x!x' is not a number"},
        {"line": 212, "reason": "expected 191 fields for FLASER with 180 readings, got 100"}]}


def test_scan_with_other_laser_geometry_is_skipped(tmp_path: Path) -> None:
    lines = INTEL.read_text().splitlines()
    tok = lines[235].split()  # line 236, the last scan: make it 181 beams
    lines[235] = " ".join(["FLASER", "181", *tok[2:182], "1.0", *tok[182:]])
    path = tmp_path / "mixed.log"
    path.write_text("\n".join(lines) + "\n")
    result = run_carmen(path)
    assert result.scans == 5 and result.scans_in_log == 6
    assert [s.line_no for s in result.skipped] == [236]
    assert result.skipped[0].reason.startswith("FLASER with 181 beams")


def test_max_scans_and_profile_overrides() -> None:
    result = run_carmen(INTEL, {"use_scan_matching": False}, max_scans=3)
    assert result.trajectory.shape == (3, 3) and result.mapper.stats.match_failures == 0
    # without scan matching the graph is the odometry chain: poses = odometry
    assert np.allclose(result.trajectory, result.odometry, atol=1e-9)
    with pytest.raises(OfflineSlamError, match="max_scans must be at least 1, got 0"):
        run_carmen(INTEL, max_scans=0)


def test_bad_parameters_name_the_key() -> None:
    with pytest.raises(ConfigError) as err:
        run_carmen(INTEL, {"mode": "localization"}, params_file="p.yaml")
    assert str(err.value) == ("p.yaml: slam_toolbox.ros__parameters.mode: mode 'localization' "
                              "cannot build a map from a log (use mode: mapping for offline "
                              "SLAM)")
    with pytest.raises(ConfigError, match="did you mean 'scan_buffer_size'"):
        run_carmen(INTEL, {"scan_bufer_size": 5})


def test_log_without_anchors_has_no_reference(tmp_path: Path) -> None:
    lines = [ln for ln in INTEL.read_text().splitlines() if ln.startswith("FLASER")]
    path = tmp_path / "raw.log"
    path.write_text("\n".join(lines) + "\n")
    result = run_carmen(path)
    assert result.reference is None and result.rpe is None and result.scans == 6
    files = write_outputs(result, tmp_path / "out")
    rows = Path(files["trajectory"]).read_text().splitlines()
    assert all(r.endswith(",,,") for r in rows[1:])


def test_empty_log_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "empty.log"
    path.write_text("# nothing\nFLASER 3 1 2\n")
    with pytest.raises(OfflineSlamError) as err:
        run_carmen(path)
    assert str(err.value) == (f"{path}: no usable laser scans (FLASER / ROBOTLASER1 lines); "
                              "1 lines skipped as garbled")


def test_log_duration_rules() -> None:
    assert log_duration(np.array([10.0, 12.0, 11.5, 15.0])) == 5.0  # steps back: max - min
    coarse = np.array([1.13486e9] * 5 + [1.13487e9])  # CSAIL-style 6-digit stamps
    assert log_duration(coarse) is None
    assert log_duration(np.array([3.0])) is None
