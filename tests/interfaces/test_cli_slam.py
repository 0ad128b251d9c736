"""CLI: ``navstack slam`` on a CARMEN excerpt, its errors, and ``bench slam`` without data."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from navstack.app import app

runner = CliRunner()
INTEL = Path(__file__).resolve().parents[1] / "data" / "carmen" / "intel_excerpt.log"
FILES = ("map.yaml", "map.pgm", "map.png", "trajectory.csv", "map.posegraph", "graph.g2o",
         "summary.json")


def test_slam_writes_files_and_json_metrics(tmp_path: Path) -> None:
    out, js = tmp_path / "out", tmp_path / "s.json"
    res = runner.invoke(app, ["slam", str(INTEL), "--out", str(out), "--json", str(js)])
    assert res.exit_code == 0, res.output
    assert all((out / name).is_file() for name in FILES)
    lines = res.stdout.splitlines()
    assert lines[0] == "6 scans processed (6 nodes), 0 loop closures, 0 match failures"
    assert lines[1].startswith("RPE over 5 consecutive pairs vs the corrected poses: trans ")
    assert lines[2].startswith("global: ATE ") and lines[2].endswith(
        "no loop relations (the reference never comes back)")
    assert lines[3] == ("odometry: 0 gaps in the log, 0 scans with missing or implausible "
                        "odometry, 0 placed by the wide search")
    assert "ms/scan (median)" in lines[4] and "speedup" in lines[4]
    assert lines[5] == f"wrote {', '.join(FILES)} to {out}"
    report = json.loads(js.read_text())
    assert set(report["metrics"]) == {"scans", "nodes", "loop_closures", "odometry_events",
                                      "recovered_scans", "ambiguous_scans", "trans_err_m",
                                      "trans_err_std_m",
                                      "rot_err_deg", "rot_err_std_deg", "ate_m",
                                      "odometry_ate_m", "ms_per_scan", "speedup"}
    assert f"ATE {report['metrics']['ate_m']:.4f} m aligned" in lines[2]
    assert report["scores"]["loop_relations"] is None
    assert report["scores"]["ate_m"] < report["odometry_scores"]["ate_m"]
    assert report == json.loads((out / "summary.json").read_text())
    assert report["metrics"]["scans"] == 6
    assert report["metrics"]["trans_err_m"] < report["odometry_rpe"]["trans_mean_m"]
    shown = f"trans {report['rpe']['trans_mean_m']:.4f} ± {report['rpe']['trans_std_m']:.4f} m"
    assert shown in lines[1]


def test_missing_log_is_one_line(tmp_path: Path) -> None:
    missing = tmp_path / "nope.log"
    res = runner.invoke(app, ["slam", str(missing), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [
        f"error: CARMEN log not found: {missing} (check the path; logs may be plain text "
        "or .gz)"]
    assert not (tmp_path / "o").exists()


def test_bad_params_key_is_one_line(tmp_path: Path) -> None:
    params = tmp_path / "slam.yaml"
    params.write_text("slam_toolbox:\n  ros__parameters:\n    minimum_travel_distanc: 0.2\n")
    res = runner.invoke(app, ["slam", str(INTEL), "--out", str(tmp_path / "o"),
                              "--params", str(params)])
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [
        f"error: {params}: slam_toolbox.ros__parameters.minimum_travel_distanc: unknown key "
        "(did you mean 'minimum_travel_distance'?)"]


def test_params_file_applies_over_log_profile(tmp_path: Path) -> None:
    params = tmp_path / "slam.yaml"
    params.write_text("slam_toolbox:\n  ros__parameters:\n    use_scan_matching: false\n"
                      "    resolution: 0.1\n")
    out = tmp_path / "o"
    res = runner.invoke(app, ["slam", str(INTEL), "--out", str(out),
                              "--params", str(params), "--max-scans", "4"])
    assert res.exit_code == 0, res.output
    assert res.stdout.splitlines()[0].startswith("4 scans processed (4 nodes)")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["params"] == {"minimum_travel_distance": 0.3, "minimum_travel_heading": 0.3,
                                 "minimum_time_interval": 0.0, "match_skipped_scans": True,
                                 "loop_search_node_interval": 2, "dynamic_point_margin": 0.0,
                                 "loop_match_minimum_response_ratio": 0.0,
                                 "loop_match_confirmation_distinct_submaps": False,
                                 "loop_match_maximum_seen_through_ratio": 0.0,
                                 "odometry_scale_correction": True,
                                 "odometry_edge_weak_directions": True,
                                 "use_scan_matching": False, "resolution": 0.1}
    assert "resolution: 0.1" in (out / "map.yaml").read_text()


def test_skipped_lines_print_a_warning(tmp_path: Path) -> None:
    lines = INTEL.read_text().splitlines()
    lines.insert(189, "ODOM 0.5 0.1 x!x 0 0 0 37.0 pippo 37.0")
    log = tmp_path / "bad.log"
    log.write_text("\n".join(lines) + "\n")
    res = runner.invoke(app, ["slam", str(log), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert ("warning: 1 log line(s) skipped (line 190: field 3 'x!x' is not a number)"
            in res.output.splitlines())


def test_slam_progress_one_line_per_stage_and_old_spelling(tmp_path: Path) -> None:
    # not a terminal: one line per stage on stderr; --carmen still works, with a warning
    res = runner.invoke(app, ["slam", "--carmen", str(INTEL), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    stages = [ln.split(" in ")[0] for ln in res.stderr.splitlines() if ln.startswith("slam: ")]
    assert stages == ["slam: read log", "slam: mapping 6/6", "slam: optimise",
                      "slam: write outputs"]
    assert "warning: --carmen is deprecated; use the LOG argument" in res.stderr
    assert res.stdout.splitlines()[0].startswith("6 scans processed")


def test_bench_slam_with_a_missing_data_dir_names_the_option(tmp_path: Path) -> None:
    res = runner.invoke(app, ["bench", "slam", "--data-dir", str(tmp_path / "nope")])
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [
        f"error: --data-dir {tmp_path / 'nope'}: no such folder (it should hold carmen/, "
        "g2o/ or movingai/ like navstack/data)"]


def test_bench_slam_without_data_names_the_file_and_every_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Without the shipped copy, an empty --data-dir names what is missing and where
    each place searched was, and where to download the log."""
    from navstack.benchmarks import common

    empty = tmp_path / "shipped"
    empty.mkdir()
    monkeypatch.setattr(common, "SHIPPED_DATA", empty)
    monkeypatch.setattr(common, "shared_data_dir", lambda: None)
    monkeypatch.delenv("NAVSTACK_DATA", raising=False)
    res = runner.invoke(app, ["bench", "slam", "--data-dir", str(tmp_path)])
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [
        f"error: benchmark data file carmen/intel-corrected.log.gz not found; searched "
        f"{tmp_path} (--data-dir), {empty} (shipped). Download it from the Radish robotics "
        "data set repository (radish.sourceforge.net), 'corrected' CARMEN logs of the "
        "Freiburg SLAM benchmark, save it as DIR/carmen/intel-corrected.log.gz and pass "
        "--data-dir DIR or set NAVSTACK_DATA=DIR"]
