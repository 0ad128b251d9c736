"""CARMEN log reader: exact parsing, the anchored-odometry rule, bad lines, gz, beam geometry."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest

from navstack.benchmarks.common import SHIPPED_DATA
from navstack.core.geometry import normalize_angle, se2_between, se2_compose
from navstack.mapping.carmen import CarmenLogNotFound, SkippedLine, read_carmen

DATA = Path(__file__).resolve().parents[1] / "data" / "carmen"
SHIPPED = SHIPPED_DATA / "carmen"


def _write(tmp_path: Path, lines: list[str], name: str = "t.log") -> Path:
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


def test_handcrafted_lines_parse_exactly(tmp_path: Path) -> None:
    path = _write(tmp_path, [
        "# a comment",
        "PARAM robot_front_laser_max 8.0 nohost 0",
        "ODOM 0 0 0 0 0 0 1.0 host 1.0",
        "FLASER 4 1.0 2.0 8.0 9.5 0.5 0.25 0.1 0.5 0.25 0.1 1.5 host 1.5",
        "ODOM 0.5 0.25 0.1 0 0 0 0 host 0",
        "NEFF 10",
        "RLASER 2 1.0 2.0 0.5 0.25 0.1 0.5 0.25 0.1 1.6 host 1.6",
        "ROBOTLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 5 1 2 3 4 20 0 "
        "1.1 2.2 0.3 1.0 2.0 0.3 0 0 0 0 0 2.5 host 2.5",
    ])
    log = read_carmen(path)
    assert log.params == {"robot_front_laser_max": "8.0"}
    assert log.ignored == {"#": 1, "NEFF": 1, "RLASER": 1}
    assert log.skipped == []
    assert [s.kind for s in log.scans] == ["FLASER", "ROBOTLASER1"]
    f, r = log.scans
    assert f.line_no == 4 and f.timestamp == 1.5
    np.testing.assert_array_equal(f.ranges, [1.0, 2.0, 8.0, 9.5])
    assert f.angle_min == -math.pi / 2 and f.angle_increment == math.pi / 4  # even n: pi/n
    assert f.range_max == 8.0                                  # from the PARAM line
    np.testing.assert_array_equal(f.valid, [True, True, False, False])
    np.testing.assert_array_equal(f.reference, [0.5, 0.25, 0.1])
    np.testing.assert_array_equal(f.laser_offset, [0.0, 0.0, 0.0])
    scan = f.to_laser_scan("laser")
    assert scan.header.frame_id == "laser" and scan.header.stamp == 1.5
    np.testing.assert_array_equal(scan.ranges, np.array([1, 2, np.inf, np.inf], np.float32))
    assert scan.angle_max == pytest.approx(math.pi / 4)
    assert r.line_no == 8 and r.timestamp == 2.5
    assert (r.angle_min, r.angle_increment, r.range_max) == (-1.5, 0.75, 20.0)
    np.testing.assert_array_equal(r.ranges, [1, 2, 3, 4, 20])
    np.testing.assert_array_equal(r.valid, [True, True, True, True, False])
    np.testing.assert_array_equal(r.reference, [1.0, 2.0, 0.3])    # robot pose
    c, s = math.cos(0.3), math.sin(0.3)                             # laser in robot frame
    np.testing.assert_allclose(r.laser_offset, [c * 0.1 + s * 0.2, -s * 0.1 + c * 0.2, 0.0],
                               atol=1e-15)
    # anchored log: scan 1's odometry = odom_0 * (anchor_0^-1 * last ODOM before scan 1)
    assert log.anchored
    np.testing.assert_array_equal(log.odometry_poses()[0], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(log.odometry_poses()[1], [0.0, 0.0, 0.0], atol=1e-15)


def _text(p: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in p)


def _odom(p: np.ndarray, t: str = "7.0") -> str:
    return f"ODOM {_text(p)} 0 0 0 {t} host {t}"


def _flaser(ref: np.ndarray, t: float) -> str:
    pose = _text(ref)
    return f"FLASER 3 1.0 2.0 3.0 {pose} {pose} {t} host {t}"


def test_anchor_rule_recovers_the_raw_odometry(tmp_path: Path) -> None:
    """Reference poses and raw odometry increments are known; the log re-anchors the ODOM
    stream on each scan (timestamps 0 and 6.1e-62 as in the real logs) except after
    scan 2, where the stream simply continues."""
    ref = np.array([[0.0, 0.0, 0.0], [0.9, 0.1, 0.4], [1.5, 0.8, 1.2], [1.2, 1.9, 2.5]])
    d = np.array([[1.0, 0.0, 0.5], [0.5, 0.5, -0.25], [0.75, -0.1, 1.0]])  # raw increments
    o_pre = np.array([0.25, -0.5, 0.125])
    half = np.array([0.5, 0.0, 0.25])
    lines = ["ODOM 0 0 0 0 0 0 0.5 host 0.5", _odom(o_pre), _flaser(ref[0], 1.0),
             _odom(ref[0], "0"), _odom(se2_compose(ref[0], half)),
             _odom(se2_compose(ref[0], d[0])), "NEFF 3",
             _flaser(ref[1], 2.0), _odom(ref[1], "6.1e-62"), _odom(se2_compose(ref[1], d[1])),
             _flaser(ref[2], 3.0)]
    last = se2_compose(ref[1], d[1])         # scan 2 is not re-anchored: the stream goes on
    lines += [_odom(se2_compose(last, half)), _odom(se2_compose(last, d[2])),
              _flaser(ref[3], 4.0)]
    log = read_carmen(_write(tmp_path, lines))
    assert log.anchored and log.skipped == []
    expected = [o_pre]
    for k in range(3):
        expected.append(se2_compose(expected[-1], d[k]))
    np.testing.assert_allclose(log.odometry_poses(), np.array(expected), atol=1e-12)
    np.testing.assert_array_equal(log.reference_poses(), ref)
    np.testing.assert_array_equal(log.timestamps(), [1.0, 2.0, 3.0, 4.0])


def test_log_without_anchors_uses_the_last_odom_before_each_scan(tmp_path: Path) -> None:
    lines = [
        "FLASER 3 1 1 1 5 5 0.5 0.125 0.25 0.5 1.0 host 1.0",     # before any ODOM
        "ODOM 0.5 0.0 0.1 0 0 0 1.1 host 1.1",
        "ODOM 0.75 0.0 0.2 0 0 0 1.2 host 1.2",
        "FLASER 3 1 1 1 5 5 0.5 0.75 0.0 0.2 2.0 host 2.0",
        "ODOM 1.0 0.5 0.3 0 0 0 2.1 host 2.1",
        "FLASER 3 1 1 1 6 6 0.75 1.0 0.5 0.3 3.0 host 3.0",
    ]
    log = read_carmen(_write(tmp_path, lines))
    assert not log.anchored
    np.testing.assert_array_equal(log.odometry_poses(),
                                  [[0.125, 0.25, 0.5], [0.75, 0.0, 0.2], [1.0, 0.5, 0.3]])


def test_bad_lines_are_skipped_with_line_number_and_reason(tmp_path: Path) -> None:
    good = "FLASER 4 1 2 3 4 0.5 0.25 0.1 0.5 0.25 0.1 1.5 host 1.5"
    lines = [
        "PARAM robot_front_laser_max 8.0 nohost 0",
        good,
        "ODOM 0.5 0.25 0.1 0 0 0 0 host 0",
        "FLASER 4 1 2 3 4 0.5 0.25",                              # truncated
        "FLASER 4 1 2.o 3 4 0.5 0.25 0.1 0.5 0.25 0.1 1.5 host 1.5",  # garbled number
        "ODOM nan 0.25 0.1 0 0 0 0 host 0",
        "FLASER abc 1 2 3",
        "ODOM 1 2",
        "PARAM lonely",
        "ROBOTLASER1 0 -1.5 3.0 0.75 20.0 0.01 0 5 1 2 3 4 20 0 1.1 2.2 0.3",
        good.replace("1.5 host 1.5", "2.5 host 2.5"),
    ]
    log = read_carmen(_write(tmp_path, lines))
    assert log.skipped == [
        SkippedLine(4, "expected 15 fields for FLASER with 4 readings, got 8"),
        SkippedLine(5, "field 3 '2.o' is not a number"),
        SkippedLine(6, "non-finite pose"),
        SkippedLine(7, "reading count 'abc' is not a non-negative integer"),
        SkippedLine(8, "expected 10 fields for ODOM, got 3"),
        SkippedLine(9, "expected at least 3 fields for PARAM, got 2"),
        SkippedLine(10, "expected 29 fields for ROBOTLASER1 with 5 readings and 0 "
                        "remissions, got 18"),
    ]
    assert [s.line_no for s in log.scans] == [2, 11]
    assert [s.timestamp for s in log.scans] == [1.5, 2.5]


def test_missing_file_is_a_typed_error(tmp_path: Path) -> None:
    missing = tmp_path / "nope.log.gz"
    with pytest.raises(CarmenLogNotFound) as info:
        read_carmen(missing)
    assert str(info.value) == (f"CARMEN log not found: {missing} (check the path; logs may "
                               "be plain text or .gz)")
    assert isinstance(info.value, FileNotFoundError)


def test_plain_gz_and_truncated_gz_read_the_same(tmp_path: Path) -> None:
    plain = read_carmen(DATA / "intel_excerpt.log")
    raw = (DATA / "intel_excerpt.log").read_bytes()
    gz = tmp_path / "intel.log.gz"
    gz.write_bytes(gzip.compress(raw))
    zipped = read_carmen(gz)
    assert len(plain.scans) == len(zipped.scans) == 6
    for a, b in zip(plain.scans, zipped.scans, strict=True):
        np.testing.assert_array_equal(a.ranges, b.ranges)
        assert a.line_no == b.line_no
    np.testing.assert_array_equal(plain.odometry_poses(), zipped.odometry_poses())
    cut = tmp_path / "cut.log.gz"               # a download that stopped half way
    cut.write_bytes(gzip.compress(raw)[: len(gzip.compress(raw)) // 2])
    part = read_carmen(cut)
    assert 0 < len(part.scans) < 6
    assert part.skipped[-1].reason == ("gzip stream ends early (truncated file); "
                                       "read up to here")


def test_intel_excerpt_fields_and_odometry() -> None:
    log = read_carmen(DATA / "intel_excerpt.log")
    assert log.ignored == {"#": 2, "NEFF": 6} and log.skipped == [] and log.anchored
    s0 = log.scans[0]
    assert s0.line_no == 175 and s0.timestamp == 32.9068 and s0.ranges.size == 180
    np.testing.assert_array_equal(s0.ranges[:4], [1.09, 1.08, 1.08, 1.07])
    np.testing.assert_array_equal(s0.reference, [0.600266, -0.0320327, -0.354665])
    # 180 beams: -90 .. +89 degrees (CARMEN's pi/n for even n)
    assert s0.angle_increment == math.pi / 180
    assert s0.angles()[-1] == pytest.approx(math.radians(89.0), abs=1e-12)
    assert s0.range_max == 50.0                     # CARMEN default, no PARAM in this log
    assert not s0.valid[s0.ranges >= 50.0].any()
    # odom_0 = last ODOM before scan 0 (line 174); odom_1 = odom_0 * anchor(176)^-1 * 186
    odom0 = np.array([0.698035, -0.0132843, -0.460915])
    delta0 = se2_between([0.600266, -0.0320327, -0.354665], [0.60258, -0.034798, -0.920053])
    np.testing.assert_array_equal(log.odometry_poses()[0], odom0)
    np.testing.assert_allclose(log.odometry_poses()[1], se2_compose(odom0, delta0),
                               atol=1e-12)


def test_361_beams_cover_both_ends_and_param_max_range() -> None:
    log = read_carmen(DATA / "csail_excerpt.log")
    assert len(log.scans) == 3 and log.params["robot_front_laser_max"] == "50"
    s = log.scans[0]
    assert s.ranges.size == 361
    assert s.angle_min == -math.pi / 2 and s.angle_increment == math.pi / 360
    assert s.angles()[-1] == pytest.approx(math.pi / 2, abs=1e-12)
    assert s.range_max == 50.0
    line = (DATA / "csail_excerpt.log").read_text().splitlines()[s.line_no - 1]
    assert int((~s.valid).sum()) == line.split()[2:363].count("81.91")


def _rpe(ref: np.ndarray, est: np.ndarray) -> tuple[float, float]:
    """Mean consecutive-pair relative pose error (Kümmerle et al. 2009): metres, degrees."""
    dr = se2_between(ref[:-1], ref[1:])
    de = se2_between(est[:-1], est[1:])
    et = np.hypot(de[:, 0] - dr[:, 0], de[:, 1] - dr[:, 1])
    ea = np.degrees(np.abs(normalize_angle(de[:, 2] - dr[:, 2])))
    return float(et.mean()), float(ea.mean())


@pytest.mark.parametrize(("name", "scans", "trans", "rot"), [
    ("intel", 910, 0.0585, 2.74), ("aces", 440, 0.0591, 1.56), ("csail", 406, 0.1017, 5.71)])
def test_odometry_baseline_on_the_benchmark_logs(name: str, scans: int, trans: float,
                                                 rot: float) -> None:
    log = read_carmen(SHIPPED / f"{name}-corrected.log.gz")
    assert len(log.scans) == scans and log.skipped == [] and log.anchored
    et, ea = _rpe(log.reference_poses(), log.odometry_poses())
    assert et == pytest.approx(trans, abs=5e-5)
    assert ea == pytest.approx(rot, abs=5e-3)
    if name == "intel":       # the excerpt is the same log's beginning
        excerpt = read_carmen(DATA / "intel_excerpt.log")
        np.testing.assert_array_equal(excerpt.odometry_poses(), log.odometry_poses()[:6])
