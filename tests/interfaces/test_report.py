"""Integration: ``navstack demo --record`` (a short two-goal mission) -> the bag read back
with rosbags -> ``navstack report`` reproduces the demo's path lengths -> SLAM on the bag."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from typer.testing import CliRunner

from navstack.app import app
from navstack.core.msgs import Pose2D
from navstack.interfaces.bag_slam import run_bag
from navstack.interfaces.report_metrics import clearance_at, clearance_field
from navstack.sim.worlds import load_world

runner = CliRunner()
WAYPOINTS = """\
waypoints:
  - name: East
    position: {x: 4.0, y: 7.5}
  - name: Back
    position: {x: 2.0, y: 7.0}
    orientation: {x: 0.0, y: 0.0, z: 1.0, w: 0.0}
"""


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("demo")
    (out / "waypoints.yaml").write_text(WAYPOINTS)
    res = runner.invoke(app, ["demo", "--record", "--out", str(out), "--waypoints",
                              str(out / "waypoints.yaml")])
    assert res.exit_code == 0, res.output
    assert f"messages to {out / 'bag'}" in res.output
    return out


def test_recorded_demo_reads_back_with_rosbags(demo_run: Path) -> None:
    live = json.loads((demo_run / "report.json").read_text())
    assert live["success"] and live["bag"]["path"] == str(demo_run / "bag")
    with AnyReader([demo_run / "bag"]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
        by_topic = {c.topic: c for c in reader.connections}
        scans = [(t * 1e-9, reader.deserialize(raw, c.msgtype)) for c, t, raw in
                 reader.messages([by_topic["/scan"]])]
        odom_t = np.array([t * 1e-9 for _, t, _ in reader.messages([by_topic["/odom"]])])
    assert {t: types[t] for t in ("/scan", "/tf", "/tf_static", "/odom", "/plan", "/cmd_vel",
                                  "/map", "/ground_truth", "/goal_pose")} == {
        "/scan": "sensor_msgs/msg/LaserScan", "/tf": "tf2_msgs/msg/TFMessage",
        "/tf_static": "tf2_msgs/msg/TFMessage", "/odom": "nav_msgs/msg/Odometry",
        "/plan": "nav_msgs/msg/Path", "/cmd_vel": "geometry_msgs/msg/Twist",
        "/map": "nav_msgs/msg/OccupancyGrid", "/ground_truth": "nav_msgs/msg/Odometry",
        "/goal_pose": "geometry_msgs/msg/PoseStamped"}
    # every scan (10 Hz from 0.1 s) and odometry message (50 Hz from 0.02 s) of the run is
    # there: no gap, and the last is within one period of the end of the run
    end = live["sim_time_s"]
    scan_t = np.array([t for t, _ in scans])
    assert scan_t[0] == pytest.approx(0.1) and np.allclose(np.diff(scan_t), 0.1, atol=1e-6)
    assert end - 0.1 - 1e-6 <= scan_t[-1] <= end + 1e-6
    assert odom_t[0] == pytest.approx(0.02) and np.allclose(np.diff(odom_t), 0.02, atol=1e-6)
    assert end - 0.02 - 1e-6 <= odom_t[-1] <= end + 1e-6
    assert all(s.header.stamp.sec + s.header.stamp.nanosec * 1e-9 == pytest.approx(t, abs=1e-9)
               for t, s in scans)
    assert counts["/odom"] == counts["/tf"] == counts["/ground_truth"]
    assert counts["/map"] == counts["/tf_static"] == 1
    assert counts["/goal_pose"] == 2 and counts["/navigate_to_pose/_action/status"] == 4
    assert counts["/plan"] >= 2 and counts["/cmd_vel"] > 5 * end
    assert scans[0][1].header.frame_id == "laser" and len(scans[0][1].ranges) > 100
    assert sum(counts.values()) == live["bag"]["messages"]


def test_report_reproduces_the_demo_path_lengths(demo_run: Path) -> None:
    out = demo_run / "bag_report"
    res = runner.invoke(app, ["report", str(demo_run / "bag"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    live = json.loads((demo_run / "report.json").read_text())
    rep = json.loads((out / "report.json").read_text())
    assert rep["trajectory"]["topic"] == "/ground_truth"
    assert [g["status"] for g in rep["goals"]] == ["SUCCEEDED", "SUCCEEDED"]
    for mine, theirs in zip(rep["goals"], live["goals"], strict=True):
        assert abs(mine["path_length_m"] - theirs["path_length_m"]) < 0.01
        assert abs(mine["min_goal_dist_m"] - theirs["min_goal_dist_m"]) < 0.01
        # the demo polls every 0.1 s (times rounded to 1 ms: allow the float error)
        assert 0.0 <= theirs["time_s"] - mine["time_s"] <= 0.1 + 1e-6
    total = sum(g["path_length_m"] for g in live["goals"])
    assert abs(rep["trajectory"]["path_length_m"] - total) < 0.01
    assert rep["goals"][0]["x"] == 4.0 and rep["goals"][1]["y"] == 7.0
    # one definition of clearance: the bag's footprint and walkers give the demo's numbers
    assert rep["notes"] == []
    for key in ("min_clearance_m", "min_clearance_static_m", "min_clearance_moving_m"):
        assert rep[key] == pytest.approx(live[key], abs=1e-3), key
    assert live["min_clearance_moving_m"] is not None  # the office has walkers
    assert (f"min clearance to static obstacles {rep['min_clearance_static_m']:.2f} m, to "
            f"walkers {rep['min_clearance_moving_m']:.2f} m") in res.output
    assert 0.0 < rep["safety"]["latency_s"] <= 0.1  # controller at 20 Hz
    assert rep["safety"]["v_max_p5_m_s"] > 0.0
    assert "path length" in res.output and "safe speed bound" in res.output
    assert (out / "report.md").read_text().count("![") == 3


def test_slam_runs_on_the_recorded_bag(demo_run: Path) -> None:
    result = run_bag(demo_run / "bag")
    assert len(result.mapper.nodes) >= 5 and result.rpe is not None
    assert result.rpe.trans_mean_m < 0.01 and result.rpe.rot_mean_deg < 0.2
    # the SLAM map, put into the world frame, lies on the world's true walls
    grid = result.mapper.build_map().to_occupancy_grid()
    rows, cols = np.nonzero(grid.data >= 65)
    o, res = grid.info.origin.position, grid.info.resolution
    cells = np.column_stack((o.x + (cols + 0.5) * res, o.y + (rows + 0.5) * res))
    assert result.reference is not None
    to_world = Pose2D(*result.reference[0]).compose(Pose2D(*result.odometry[0]).inverse())
    world = load_world("office").to_occupancy_grid()
    dist = clearance_at(world, clearance_field(world), to_world.transform_points(cells))
    assert len(cells) > 200 and np.nanmean(dist <= 0.1) > 0.95
