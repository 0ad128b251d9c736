"""Marker missions: goal geometry, search viewpoints, and the missions on a running stack
(corners-mode camera: the perception chain without rendering)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from navstack.app import app
from navstack.core.msgs import Pose2D, String
from navstack.core.rotations import rotation_angle, transform_to_matrix
from navstack.interfaces.perception import PerceptionOptions, attach_perception
from navstack.interfaces.stack import NavStack
from navstack.missions.marker_behaviours import ApproachMarker, MarkerContext, marker_goal
from navstack.missions.marker_missions import marker_frame_mission, package_retrieval_mission
from navstack.missions.mission import MissionRunner, MissionStatus
from navstack.missions.search_viewpoints import search_viewpoints
from navstack.sim.robot import load_robot
from navstack.sim.world_io import world_from_mapping


def test_marker_goal_faces_the_marker() -> None:
    g = marker_goal(2.0, 3.0, 0.5 * math.pi, 1.0)  # marker facing +y
    assert (round(g.x, 9), round(g.y, 9), round(g.theta, 9)) == (2.0, 4.0,
                                                                 round(-0.5 * math.pi, 9))
    g = marker_goal(0.0, 0.0, 0.0, 1.0, lateral=0.2)  # facing +x; right of it seen from +x
    assert math.isclose(g.x, 1.0) and math.isclose(g.y, -0.2) and math.isclose(g.theta,
                                                                               math.pi)


def test_viewpoints_see_every_free_cell() -> None:
    # two rooms joined by a door: the far room is seen only from a viewpoint in or at it
    world = world_from_mapping({
        "name": "two", "size": [6.0, 3.0], "resolution": 0.05,
        "walls": [{"from": [3.0, 0.0], "to": [3.0, 1.2], "thickness": 0.1},
                  {"from": [3.0, 2.0], "to": [3.0, 3.0], "thickness": 0.1}],
        "spawn": {"x": 1.0, "y": 1.5}})
    grid = world.to_occupancy_grid()
    vps = search_viewpoints(grid, world.spawn, view_range=2.5, coverage=0.97)
    assert 1 <= len(vps) <= 4
    assert any(v.x > 3.0 for v in vps)
    dist = world.distance_field()
    assert all(dist[world.world_to_cell(v.x, v.y)] >= 0.3 for v in vps)


def test_marker_frame_mission_in_the_office() -> None:
    # starting in room A (the lab's start is the corridor: navstack bench marker-frame)
    stack = NavStack("office", "diff_drive", spawn=Pose2D(3.5, 3.0, 0.0), seed=4)
    attach_perception(stack, PerceptionOptions(camera_mode="corners", camera_rate_hz=10.0,
                                               detector={"marker_size": 0.15}))
    ctx = MarkerContext(stack.runtime)
    modes: list[str] = []
    stack.runtime.bus.subscribe("/mode", String, lambda m: modes.append(m.data))
    world = stack.world
    home = Pose2D(3.5, 3.0, 0.0)
    mission = marker_frame_mission(ctx, 12, world.waypoints["Marker_View"])
    out = MissionRunner(stack.runtime, mission).run(300.0)
    assert out.status is MissionStatus.SUCCEEDED, out.reason
    assert out.data["marker_id"] == 12
    tf = transform_to_matrix(stack.runtime.tf.lookup("map", "aruco_marker_12").transform)
    truth = world.markers[0]
    assert np.linalg.norm(tf[:3, 3] - [truth.x, truth.y, truth.z]) < 0.05
    assert math.degrees(rotation_angle(tf[:3, :3], truth.rotation())) < 3.0
    pose = stack.sim.sim.pose
    assert math.hypot(pose.x - home.x, pose.y - home.y) < 0.3
    assert stack.sim.sim.collisions == 0
    assert modes[0] == "auto" and modes[-1] == "success"


def test_approach_goal_is_latched_once() -> None:
    stack = NavStack("office", "diff_drive", spawn=Pose2D(2.2, 5.0, math.pi), seed=4)
    attach_perception(stack, PerceptionOptions(camera_mode="corners", camera_rate_hz=10.0,
                                               detector={"marker_size": 0.15}))
    stack.run_for(1.0)
    ctx = MarkerContext(stack.runtime)
    stack.run_for(0.0)  # latched marker map delivered
    approach = ApproachMarker(ctx, 12, distance=2.2)
    approach.tick_once()
    first = approach.target
    assert first is not None and math.isclose(first.theta % (2 * math.pi), math.pi, abs_tol=0.05)
    ctx.markers.clear()  # the estimate disappears: the latched goal does not change
    stack.run_for(0.5)
    approach.tick_once()
    assert approach.target == first and approach.status.name == "RUNNING"


def test_package_retrieval_in_a_small_room() -> None:
    world = world_from_mapping({
        "name": "room", "size": [3.5, 3.0], "resolution": 0.05,
        "packages": [{"id": 3, "position": [2.4, 1.6], "yaw": 0.3},
                     {"id": 4, "position": [1.6, 0.6], "yaw": 1.0}],
        "spawn": {"x": 0.6, "y": 1.5, "yaw": 0.0}})
    from navstack.benchmarks.retrieval import nav2_params
    from navstack.interfaces.mission_catalog import GRIP_DISTANCE

    stack = NavStack(world, load_robot("turtlebot3_waffle_pi"), nav2_params(), seed=1)
    per = attach_perception(stack, PerceptionOptions(
        camera_mode="corners", camera_rate_hz=10.0, detector={"marker_size": 0.05},
        marker_map={"package_ids": [3, 4]}))
    ctx = MarkerContext(stack.runtime)
    grid = world.to_occupancy_grid()
    mission = package_retrieval_mission(ctx, 3, search_viewpoints(grid, world.spawn), grid,
                                        GRIP_DISTANCE, standoff=0.7)
    out = MissionRunner(stack.runtime, mission).run(300.0)
    assert out.status is MissionStatus.SUCCEEDED, out.reason
    sim = stack.sim.sim
    assert sim.packages.carried == 0 and sim.packages.total_collisions == 0
    assert math.hypot(sim.pose.x - 0.6, sim.pose.y - 1.5) < 0.3
    assert 4 in per.marker_map.package_centres()  # the other one stayed a virtual obstacle


def test_package_retrieval_command_in_the_arena(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["mission", "package-retrieval", "--world", "arena",
                                   "--seed", "0", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert res.output.splitlines()[-1].startswith("SUCCESS: SUCCEEDED")
    report = json.loads((out / "report.json").read_text())
    assert report["mission"] == "package-retrieval" and report["localization"] == "perfect"
    assert report["package_held"] is True and report["package_collisions"] == 0
    assert report["home_distance_m"] <= 0.3 and report["target_id"] == 3
    assert [p[0] for p in report["packages"]] == [3, 4]  # placed by the seed
    assert any(text.startswith("grip: holding package_3") for _, text in report["events"])


def test_marker_mission_commands_explain_bad_worlds_and_robots() -> None:
    runner = CliRunner()
    res = runner.invoke(app, ["mission", "marker-frame", "--world", "arena"])
    assert res.exit_code == 2
    assert "world 'arena' needs a marker (markers:) and a 'Marker_View' waypoint" in res.output
    assert "--world office" in res.output
    res = runner.invoke(app, ["mission", "package-retrieval", "--robot", "diff_drive"])
    assert res.exit_code == 2
    assert "robot 'diff_drive' has no gripper" in res.output
