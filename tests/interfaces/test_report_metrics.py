"""Report metrics with closed-form answers, and the whole report on a synthetic bag: a
robot on a circle (R = 2 m, v = 0.5 m/s), constant latency, a wall at a known distance."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from navstack.core.msgs import (
    Header,
    LaserScan,
    MapMetaData,
    Marker,
    MarkerArray,
    OccupancyGrid,
    Odometry,
    Point,
    Pose2D,
    PoseStamped,
    PoseWithCovariance,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from navstack.interfaces.report import ReportParams, write_report
from navstack.interfaces.report_metrics import (
    clearance_at,
    clearance_field,
    curvature,
    forward_free_distance,
    grid_path,
    grid_times,
    path_length,
    safe_speed,
    scan_to_cmd_latency,
    stats,
)
from navstack.runtime.recording import BagWriter, GoalInfo, GoalStatusArray, GoalStatusEntry


def test_safe_speed_closed_form() -> None:
    # v L + v^2 / (2 a) = d with a = 2, L = 0.5, d = 3: v = -1 + sqrt(13)
    v = float(safe_speed(2.0, 0.5, 3.0))
    assert v == pytest.approx(-1.0 + math.sqrt(13.0), abs=1e-12)
    assert v * 0.5 + v * v / 4.0 == pytest.approx(3.0, abs=1e-12)
    assert float(safe_speed(2.0, 0.0, 4.0)) == pytest.approx(4.0)  # sqrt(2 a d)
    assert float(safe_speed(2.0, 0.3, -1.0)) == 0.0


def test_stats_latency_curvature_and_free_distance() -> None:
    s = stats(np.arange(1.0, 101.0))
    assert s == {"mean": 50.5, "median": 50.5, "p95": pytest.approx(95.05), "max": 100.0}
    lat = scan_to_cmd_latency(np.array([0.0, 0.1, 0.2, 0.4, 3.0]),
                              np.array([-0.01, 0.09, 0.2, 0.4, 2.9]),
                              np.array([-0.5, 0.05, 0.1, 0.3, 3.5]))
    # the command at 0.1 does not follow the scan logged at 0.1; the scans at 0.4 and 3.0
    # fall in 3.2 s without commands (idle between goals): no latency to measure
    assert lat.tolist() == pytest.approx([0.06, 0.21, 0.1])
    assert curvature(np.array([0.5, 0.01, -1.0]), np.array([0.25, 1.0, -0.5])).tolist() == \
        [0.5, 0.5]
    angles = np.radians([-40.0, -10.0, 0.0, 10.0, 40.0])
    ranges = np.array([0.5, 3.0, np.inf, 2.5, 0.4], np.float32)
    assert forward_free_distance(ranges, angles, 0.1, 10.0, math.radians(15)) == 2.5
    assert forward_free_distance(ranges, angles, 0.1, 10.0, math.radians(5)) == 10.0


def test_grid_path_on_a_circle_is_the_chord_sum() -> None:
    t = np.arange(0, 501) * 0.02
    phi = 0.25 * t
    xy = np.column_stack((2 * np.cos(phi), 2 * np.sin(phi)))
    assert grid_times(0.0, 1.0, 0.1).tolist() == pytest.approx([0.1 * k for k in range(11)])
    samples = grid_path(t, xy, 0.0, 10.0, 0.1)
    assert len(samples) == 101
    assert path_length(samples) == pytest.approx(100 * 4 * math.sin(0.0125), abs=1e-9)


def test_clearance_field_is_the_distance_to_the_nearest_occupied_cell() -> None:
    data = np.zeros((20, 30), np.int8)
    data[5, 20] = 100
    grid = OccupancyGrid(Header(0.0, "map"), MapMetaData(0.0, 0.1, 30, 20,
                                                         Pose2D(-1.0, 0.0, 0.0).to_pose()), data)
    field = clearance_field(grid)
    pts = np.array([[0.05, 0.55], [-0.95, 1.85], [5.0, 5.0]])  # cells (5, 10), (18, 0), outside
    got = clearance_at(grid, field, pts)
    assert got[0] == pytest.approx(1.0)
    assert got[1] == pytest.approx(0.1 * math.hypot(13, 20))
    assert math.isnan(got[2])


R, V, W = 2.0, 0.5, 0.25


def _pose_at(t: float) -> Pose2D:
    phi = W * t - math.pi / 2
    return Pose2D(R * math.cos(phi), R * math.sin(phi), phi + math.pi / 2)


def _synthetic_bag(path: Path, with_truth: bool = True,
                   extra: Callable[[BagWriter], None] | None = None) -> Path:
    w = BagWriter(path)
    if extra is not None:
        extra(w)
    data = np.zeros((100, 100), np.int8)
    data[:, 80] = 100  # a wall: cell centres at x = 3.05
    w.write("/map", OccupancyGrid(Header(0.0, "map"), MapMetaData(
        0.0, 0.1, 100, 100, Pose2D(-5.0, -5.0, 0.0).to_pose()), data), 0.0, latched=True)
    for k in range(501):
        t = k * 0.02
        twist = TwistWithCovariance(Twist.planar(V, 0.0, W))
        w.write("/ground_truth" if with_truth else "/odom", Odometry(
            Header(t, "map"), "base_link", PoseWithCovariance(_pose_at(t).to_pose()), twist), t)
        if k % 5 == 0:  # 10 Hz: scan stamped 20 ms before it is logged, command 50 ms after
            ranges = np.full(9, 5.0, np.float32)
            ranges[4] = 3.0
            w.write("/scan", LaserScan(Header(t - 0.02, "base_link"), -1.0, 1.0, 0.25, 0.0, 0.1,
                                       0.1, 10.0, ranges), t)
            w.write("/cmd_vel", Twist.planar(V, 0.0, W), t + 0.05)
    goal = GoalInfo(bytes(16), 2.0)
    w.write("/goal_pose", PoseStamped.from_pose2d(_pose_at(6.0), "map", 2.0), 2.0)
    w.write("/navigate_to_pose/_action/status", GoalStatusArray((GoalStatusEntry(goal, 2),)), 2.0)
    w.write("/navigate_to_pose/_action/status", GoalStatusArray((GoalStatusEntry(goal, 4),)), 6.0)
    w.close()
    return path


def test_report_of_a_synthetic_circle(tmp_path: Path) -> None:
    rep = write_report(_synthetic_bag(tmp_path / "bag"), tmp_path / "out")
    chord = 4 * math.sin(W * 0.1 / 2)
    traj = rep["trajectory"]
    assert (traj["topic"], traj["frame"], traj["messages"]) == ("/ground_truth", "map", 501)
    assert traj["path_length_m"] == pytest.approx(100 * chord, abs=1e-4)  # 0 .. 10.05 s
    assert rep["speed_m_s"] == {"mean": V, "median": V, "p95": V, "max": V}
    assert rep["angular_speed_rad_s"]["max"] == W
    assert rep["curvature_1_m"]["median"] == 1 / R
    assert rep["cmd_vel"]["vx_m_s"]["mean"] == V
    [goal] = rep["goals"]
    assert (goal["status"], goal["time_s"]) == ("SUCCEEDED", 4.0)
    assert goal["path_length_m"] == pytest.approx(40 * chord, abs=1e-4)
    assert goal["min_goal_dist_m"] == pytest.approx(0.0, abs=1e-4)
    # closest sample (t = 6.3 s) at x just under 2; the wall's cells start at x = 3.0
    assert rep["min_clearance_m"] == pytest.approx(1.0, abs=1e-4)
    assert rep["min_clearance_static_m"] == rep["min_clearance_m"]
    assert rep["min_clearance_moving_m"] is None
    assert rep["notes"] == ["no /sim/footprint in the bag: clearance is measured from a "
                            "circle of robot_radius 0 m"]
    s = rep["safety"]
    assert s["latency_s"] == pytest.approx(0.07) and s["latency_source"].startswith("measured")
    assert (s["d_free_p5_m"], s["d_free_median_m"]) == (3.0, 3.0)
    v_max = -2.5 * 0.07 + math.sqrt((2.5 * 0.07) ** 2 + 2 * 2.5 * 3.0)
    assert s["v_max_p5_m_s"] == pytest.approx(v_max, abs=1e-4)
    assert s["cmd_over_bound_fraction"] == 0.0
    assert s["cmd_over_bound_max_ratio"] == pytest.approx(V / v_max, abs=1e-4)
    md = (tmp_path / "out" / "report.md").read_text()
    assert "- trajectory source: `/ground_truth` (frame `map`, 501 messages" in md
    assert all((tmp_path / "out" / f).stat().st_size > 1000
               for f in ("speed.png", "angular_speed.png", "trajectory.png"))


def test_report_falls_back_to_odometry_and_takes_a_given_latency(tmp_path: Path) -> None:
    params = ReportParams(latency=0.5, braking_decel=2.0, robot_radius=0.5)
    rep = write_report(_synthetic_bag(tmp_path / "bag", with_truth=False), tmp_path / "out",
                       params)
    assert rep["trajectory"]["topic"] == "/odom"
    s = rep["safety"]
    assert (s["latency_s"], s["latency_source"]) == (0.5, "given (--latency)")
    assert s["d_free_p5_m"] == 2.5  # 3.0 m minus the robot radius
    assert s["v_max_p5_m_s"] == pytest.approx(-1.0 + math.sqrt(1.0 + 10.0), abs=1e-4)
    assert rep["min_clearance_m"] == pytest.approx(1.0 - 0.5, abs=1e-4)


def test_report_clearance_uses_the_recorded_footprint_and_walkers(tmp_path: Path) -> None:
    # a 0.4 m square body; a round walker (r 0.3) standing at (0, -1) and a box far away
    bag = _synthetic_bag(tmp_path / "bag", extra=_footprint_and_walkers)
    rep = write_report(bag, tmp_path / "out", ReportParams(robot_radius=5.0))
    # t = 0: body at (0, -2) facing +x, its top edge y = -1.8; the walker's edge y = -1.3
    assert rep["min_clearance_moving_m"] == pytest.approx(0.5, abs=1e-4)
    # the wall's cells start at x = 3.0; the square's rightmost point at sample k is
    # R cos(phi) + 0.2 (|sin phi| + |cos phi|) (heading phi + pi/2): largest near phi 0.09
    phi = W * 0.1 * np.arange(101) - math.pi / 2
    reach = R * np.cos(phi) + 0.2 * (np.abs(np.sin(phi)) + np.abs(np.cos(phi)))
    assert rep["min_clearance_static_m"] == pytest.approx(3.0 - reach.max(), abs=1e-4)
    assert rep["min_clearance_m"] == rep["min_clearance_moving_m"]
    [goal] = rep["goals"]  # 2 s .. 6 s (samples 20..60): the walker is behind the robot
    assert goal["min_clearance_moving_m"] > 0.5
    assert goal["min_clearance_static_m"] == pytest.approx(3.0 - reach[20:61].max(), abs=1e-4)
    md = (tmp_path / "out" / "report.md").read_text()
    assert ("- minimum clearance (footprint to obstacle): to static obstacles "
            f"{rep['min_clearance_static_m']:.3f} m, to walkers 0.500 m") in md


def _footprint_and_walkers(w: BagWriter) -> None:
    square = [Point(x, y, 0.0) for x, y in ((0.2, 0.2), (-0.2, 0.2), (-0.2, -0.2),
                                            (0.2, -0.2), (0.2, 0.2))]
    w.write("/sim/footprint", Marker(Header(0.0, "base_link"), "footprint", 0,
                                     Marker.LINE_STRIP, points=tuple(square)), 0.0, latched=True)
    walkers = MarkerArray((
        Marker(Header(0.0, "map"), "walker", 0, Marker.CYLINDER,
               pose=Pose2D(0.0, -1.0, 0.0).to_pose(), scale=Vector3(0.6, 0.6, 1.7)),
        Marker(Header(0.0, "map"), "cart", 1, Marker.CUBE,
               pose=Pose2D(0.0, 4.0, 0.3).to_pose(), scale=Vector3(1.0, 0.5, 1.0))))
    w.write("/sim/obstacles", walkers, 0.0)
