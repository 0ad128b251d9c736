"""The rover's behaviour tree in the simulator (issue 20, parts 5 and 7): a post found by
the spiral search and reached, a gate passed through its back / middle / front points, the
mission services (go to x, y / GPS with post ids, stop mission, e-stop pulse, resume), and
a joystick takeover that pauses the mission and cancels its goal until a mission command
resumes it.  Small pad world (40 m x 30 m) with the rover's camera in corners mode."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml
from py_trees.common import Status

from navstack.core.msgs import Joy, Pose2D, String, Twist
from navstack.interfaces.rover import RoverRun, rover_run
from navstack.missions.rover_behaviours import segment_crossing
from navstack.missions.rover_context import PostEstimate, RoverTask, TaskStatus
from navstack.missions.rover_tree import GoToGpsRequest, GoToRequest
from navstack.nodes.teleop import TeleopNode, TeleopNodeParams
from navstack.runtime.bus import LATCHED
from navstack.sim.course import course_world, load_course, world_to_ll

SPAWN = Pose2D(4.0, 15.0, 0.0)


def _course(tmp: Path) -> Path:
    world = tmp / "rover_pad.yaml"
    world.write_text(yaml.safe_dump({
        "name": "rover_pad", "resolution": 0.1, "size": [40.0, 30.0], "boundary": True,
        "circles": [{"center": [17.0, 10.0], "radius": 0.8}],
        "spawn": {"x": SPAWN.x, "y": SPAWN.y, "yaw": SPAWN.theta}}))
    course = tmp / "course.yaml"
    course.write_text(yaml.safe_dump({
        "world": str(world),
        "georeference": {"latitude": 38.406415, "longitude": -110.791924,
                         "altitude": 1380.0, "world_yaw": 0.35},
        "posts": [{"id": 7, "x": 24.0, "y": 22.0}, {"id": 8, "x": 30.0, "y": 13.0},
                  {"id": 9, "x": 30.0, "y": 17.0}],
        "gates": [{"name": "g", "posts": [8, 9]}]}))
    return course


def _odom(x: float, y: float) -> tuple[float, float]:
    """World -> odom (odometry starts at the spawn pose, heading 0)."""
    return x - SPAWN.x, y - SPAWN.y


def _run_task(run: RoverRun, limit: float) -> None:
    t0 = run.stack.now
    while run.mission.bb.status is TaskStatus.RUNNING:
        assert run.stack.now - t0 < limit, run.mission.mission_state()
        run.stack.run_for(0.5)


@pytest.fixture
def run(tmp_path: Path) -> RoverRun:
    r = rover_run(seed=3, spawn=SPAWN, course_file=_course(tmp_path))
    yield r
    r.close()


def test_course_posts_carry_a_marker_on_every_face(tmp_path: Path) -> None:
    world = course_world(load_course(_course(tmp_path)))
    faces = [m for m in world.markers if m.id == 7]
    assert len(faces) == 4
    for m in faces:  # on the post's surface (0.15 m + 1 mm), facing out
        assert math.hypot(m.x - 24.0, m.y - 22.0) == pytest.approx(0.151)
        assert math.atan2(m.y - 22.0, m.x - 24.0) == pytest.approx(m.yaw, abs=1e-9)
        assert m.size == 0.2 and m.z == 0.8


def test_segment_crossing_and_post_estimate_weighting() -> None:
    assert segment_crossing((0.0, -1.0), (0.0, 1.0), (-1.0, 0.0), (1.0, 0.0))
    assert not segment_crossing((2.0, -1.0), (2.0, 1.0), (-1.0, 0.0), (1.0, 0.0))
    assert not segment_crossing((0.0, 0.5), (0.0, 1.0), (-1.0, 0.0), (1.0, 0.0))
    est = PostEstimate(1, [(0.0, 10.0, 0.0, 12.0), (1.0, 11.0, 0.0, 2.0)])
    x, _ = est.xy()  # the 2 m sighting outweighs the 12 m one by 6^4
    assert x == pytest.approx(11.0 - 1.0 / (1.0 + 6.0 ** 4), abs=1e-9)


def test_post_found_by_the_spiral_and_reached(run: RoverRun) -> None:
    """go_to (odom x, y) with a post id: the goal, the spiral, the approach."""
    stack, mission = run.stack, run.mission
    states: list[String] = []
    stack.runtime.bus.subscribe("/mission/state", String, states.append, LATCHED)
    answer = stack.runtime.bus.call("/rover/go_to", GoToRequest(*_odom(18.0, 16.0), (7,)))
    assert answer == {"accepted": True, "task": "leg_1", "kind": "post"}
    _run_task(run, 150.0)
    bb = mission.bb
    assert bb.status is TaskStatus.SUCCEEDED, bb.reason
    assert bb.reason == "post reached (7)"
    assert run.truth.true_distance(7) <= 2.0
    assert stack.sim.sim.collisions == 0
    assert bb.goal_reached_at is not None and bb.visited == {7}
    state = json.loads(states[-1].data)
    assert state["status"] == "succeeded" and state["visited"] == [7]
    assert state["task"] == "leg_1" and state["posts"]["7"][2] >= 3


def test_gate_passed_from_a_gps_goal(run: RoverRun) -> None:
    """go_to_gps (D,M,S-free decimal) with the gate's two ids: calibration drive, the
    gps_goal_fix leg, then back / middle / front through the gate."""
    stack, mission = run.stack, run.mission
    lat, lon = world_to_ll(run.course.georeference, 24.0, 15.0)
    answer = stack.runtime.bus.call("/rover/go_to_gps", GoToGpsRequest(lat, lon, (8, 9), "g1"))
    assert answer["accepted"] and answer["kind"] == "gate"
    _run_task(run, 150.0)
    bb = mission.bb
    assert bb.status is TaskStatus.SUCCEEDED, bb.reason
    assert bb.reason == "gate passed (8, 9)" and 1 <= bb.gate_tries <= 3
    crossings = [c for c in run.truth.crossings if c["gate"] == "g"]
    assert crossings and crossings[-1]["heading_off_normal_deg"] <= 45.0
    assert stack.sim.sim.collisions == 0


def test_mission_services_stop_estop_and_bad_input(run: RoverRun) -> None:
    stack, mission = run.stack, run.mission
    bus = stack.runtime.bus
    bad = bus.call("/rover/go_to_gps", GoToGpsRequest("38;24;23", -110.79, (7,)))
    assert not bad["accepted"] and "go_to_gps.latitude" in bad["reason"]
    assert bus.call("/rover/resume", None) == {"resumed": False,
                                               "reason": "no paused task (status idle)"}
    bus.call("/rover/go_to", GoToRequest(*_odom(18.0, 16.0), (7,)))
    stack.run_for(8.0)
    assert mission.bb.status is TaskStatus.RUNNING
    stops: list[Twist] = []
    bus.subscribe("/stop", Twist, stops.append)
    bus.call("/rover/estop", None)
    assert mission.bb.status is TaskStatus.PAUSED
    stack.run_for(1.5)
    assert len(stops) >= 10 and all(t.linear.x == 0.0 and t.angular.z == 0.0 for t in stops)
    # while paused the tree holds no navigation goal
    server = bus.action_servers["/navigate_to_pose"]
    assert not [h for h in getattr(server, "goals", []) if not h.done]
    assert bus.call("/rover/resume", None) == {"resumed": True}
    stack.run_for(3.0)
    assert mission.bb.status is TaskStatus.RUNNING
    assert bus.call("/rover/stop_mission", None) == {"stopped": True}
    assert mission.bb.status is TaskStatus.IDLE and mission.bb.task is None
    assert mission.bb.points == [] and mission.ctx.tracker.posts == {}
    assert mission.root.status is Status.INVALID


def test_joystick_takeover_pauses_and_a_mission_command_resumes(run: RoverRun) -> None:
    """twist_mux: joystick (100) over navigation (50).  The operator switches the joystick
    node to teleop and drives: the mission pauses, its goal is cancelled, the joystick
    moves the rover; after /rover/resume the leg finishes."""
    stack, mission = run.stack, run.mission
    rt = stack.runtime
    teleop = TeleopNode(rt, TeleopNodeParams(twist_topic="/joystick/twist", start_mode="auto"))
    rt.bring_up()
    joy = rt.bus.publisher("/joy", Joy)
    active: list[String] = []
    modes: list[String] = []
    rt.bus.subscribe("/twist_mux/active", String, active.append, LATCHED)
    rt.bus.subscribe("/rover/mode", String, modes.append, LATCHED)
    rt.bus.call("/rover/go_to", GoToRequest(*_odom(18.0, 16.0), (7,)))
    stack.run_for(6.0)
    assert mission.bb.status is TaskStatus.RUNNING
    server = rt.bus.action_servers["/navigate_to_pose"]
    assert [h for h in server.goals if not h.done]  # type: ignore[attr-defined]
    mode = [0] * 8
    mode[7] = 1
    joy.publish(Joy(axes=(0.0, 0.0), buttons=tuple(mode)))  # -> teleop
    stack.run_for(0.1)
    assert teleop.mode == "teleop" and mission.bb.status is TaskStatus.PAUSED
    assert not [h for h in server.goals if not h.done]  # type: ignore[attr-defined]
    before = stack.sim.sim.pose
    drive = (1,) + (0,) * 7
    for _ in range(30):  # 3 s of full left turn on the stick, enable held
        joy.publish(Joy(axes=(1.0, 0.0), buttons=drive))
        stack.run_for(0.1)
    assert active[-1].data == "joystick"
    after = stack.sim.sim.pose
    assert abs(math.remainder(after.theta - before.theta, 2 * math.pi)) > 0.5
    assert mission.bb.status is TaskStatus.PAUSED
    refused = rt.bus.call("/rover/resume", None)
    assert not refused["resumed"] and "joystick" in refused["reason"], refused
    joy.publish(Joy(axes=(0.0, 0.0), buttons=tuple(mode)))  # -> auto
    stack.run_for(1.0)  # the joystick input times out (0.5 s)
    assert teleop.mode == "auto"
    assert rt.bus.call("/rover/resume", None) == {"resumed": True}
    _run_task(run, 150.0)
    assert mission.bb.status is TaskStatus.SUCCEEDED, mission.bb.reason
    assert run.truth.true_distance(7) <= 2.0 and stack.sim.sim.collisions == 0
    assert mission.pauses == 1
    assert any("task paused" in e for _, e in mission.ctx.events)
    assert [m.data for m in modes][-1] == "success"
    assert "teleop" in [m.data for m in modes]


def test_one_gate_post_seen_circles_it_until_the_other_is_seen(run: RoverRun) -> None:
    """gate_control with only post 8 known (its sightings injected while both posts are
    beyond the camera's 16 m): rotate_gate drives towards the circle points round post 8
    until post 9 is seen, then pass_gate goes through."""
    stack, mission = run.stack, run.mission
    ox, oy = _odom(30.0, 13.0)
    now = stack.now
    mission.ctx.tracker.posts[8] = PostEstimate(8, [(now, ox, oy, 5.0)] * 3)
    assert not mission.ctx.tracker.seen(9)
    mission.bb.begin(RoverTask("g2", (8, 9), xy=_odom(4.0, 15.0)), now)
    mission.bb.goal_reached = True  # the search starts here, no spiral points
    _run_task(run, 120.0)
    bb = mission.bb
    assert bb.status is TaskStatus.SUCCEEDED, bb.reason
    events = [e for _, e in mission.ctx.events]
    assert "rotate_gate: gate post 8 seen, circling it for the other" in events
    assert not bb.gate_circled  # the other post showed up before the fourth point
    crossings = [c for c in run.truth.crossings if c["gate"] == "g"]
    assert crossings and crossings[-1]["heading_off_normal_deg"] <= 45.0
    assert stack.sim.sim.collisions == 0
