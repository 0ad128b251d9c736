"""End-to-end: the real stack in the simulator (textbook acceptance checks, bad input)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from navstack.core.msgs import Header, Pose2D, PoseStamped
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.stack import NavStack
from navstack.navigation.messages import NavigatorErrorCode
from navstack.sim.worlds import load_world


def _goal(x: float, y: float, yaw: float = 0.0, frame: str = "map") -> PoseStamped:
    return PoseStamped.from_pose2d(Pose2D(x, y, yaw), frame)


def _run(nav: Navigator, limit_s: float) -> None:
    t0 = nav.stack.now
    while not nav.isTaskComplete():
        assert nav.stack.now - t0 < limit_s, "task did not end in time"


def test_goal_in_map_moves_robot_toward_it_and_reaches_it() -> None:
    nav = Navigator(NavStack("office", seed=0))
    start = nav.robot_pose()
    goal = _goal(start.x + 3.0, start.y)
    assert nav.goToPose(goal)
    nav.stack.run_for(2.0)
    p = nav.robot_pose()
    assert p.x - start.x > 0.2, "robot should move toward +x"
    assert abs(p.y - start.y) < 0.3
    _run(nav, 60.0)
    assert nav.getResult() is TaskResult.SUCCEEDED
    p = nav.robot_pose()
    assert math.hypot(p.x - goal.pose.position.x, p.y - goal.pose.position.y) <= 0.25
    assert nav.stack.sim.sim.collisions == 0


def test_new_obstacle_raises_local_cost_and_is_avoided() -> None:
    world = load_world("office")
    occ = world.occupied.copy()
    # a 0.3 m box in the corridor 2 m ahead of the spawn, not on the map
    sx, sy = world.spawn.x, world.spawn.y
    c0 = int((sx + 1.85 - world.origin_x) / world.resolution)
    r0 = int((sy - 0.15 - world.origin_y) / world.resolution)
    occ[r0:r0 + 6, c0:c0 + 6] = True
    sim_world = replace(world, occupied=occ)
    stack = NavStack(sim_world, seed=0, map_grid=world.to_occupancy_grid())
    nav = Navigator(stack)
    box_xy = (sx + 2.0, sy)
    assert nav.goToPose(_goal(sx + 4.5, sy))
    while math.hypot(nav.robot_pose().x - box_xy[0], nav.robot_pose().y - box_xy[1]) > 1.2:
        stack.run_for(0.2)
        assert stack.now < 30.0
    stack.run_for(0.3)  # one more local costmap update
    local = stack.local_costmap.costmap  # in odom: bring the box there
    box_odom = stack.runtime.tf.lookup_pose2d("odom", "map").compose(Pose2D(*box_xy, 0.0))
    cell = local.world_to_map(box_odom.x, box_odom.y)
    assert cell is not None
    mx, my = cell
    assert local.data[my - 3:my + 4, mx - 3:mx + 4].max() == LETHAL_OBSTACLE  # box marked
    assert local.data[my, mx] >= INSCRIBED_INFLATED_OBSTACLE
    _run(nav, 90.0)
    assert nav.getResult() is TaskResult.SUCCEEDED
    assert stack.sim.sim.collisions == 0


def test_blocked_corridor_recovers_and_succeeds_or_fails_with_reason() -> None:
    from navstack.benchmarks.navigation import run_scenario, scenarios

    blocked = next(s for s in scenarios(quick=True) if s.kind == "blocked")
    out = run_scenario(blocked)
    assert out.collisions == 0
    assert out.status in ("SUCCEEDED", "FAILED")
    if out.status == "FAILED":
        assert out.reason
    else:
        assert out.final_dist_m <= 0.3


@pytest.mark.parametrize(("goal", "code", "text"), [
    (_goal(40.0, 7.5), NavigatorErrorCode.GOAL_OUTSIDE_MAP, "outside"),
    # the centre of the office's largest obstacle: 0.6 m deep, beyond tolerance 0.5 m
    (_goal(6.875, 2.975), NavigatorErrorCode.GOAL_OCCUPIED, "obstacle"),
])
def test_bad_goals_fail_with_a_reason(goal: PoseStamped, code: NavigatorErrorCode,
                                      text: str) -> None:
    nav = Navigator(NavStack("office", seed=0))
    assert nav.goToPose(goal)
    _run(nav, 120.0)
    assert nav.getResult() is TaskResult.FAILED
    res = nav.getTaskResult()
    assert res is not None and text in res.error_msg
    assert res.error_code == int(code)
    assert nav.stack.sim.sim.collisions == 0


def test_goal_in_unknown_frame_fails_naming_the_frame() -> None:
    nav = Navigator(NavStack("office", seed=0))
    bad = PoseStamped(Header(0.0, "mapp"), _goal(3.0, 7.5).pose)
    assert nav.goToPose(bad)  # accepted, then validated against TF
    _run(nav, 5.0)
    assert nav.getResult() is TaskResult.FAILED
    res = nav.getTaskResult()
    assert res is not None and res.error_code == int(NavigatorErrorCode.TF_ERROR)
    assert "goal frame 'mapp' is not known to TF (did you mean 'map'?)" in res.error_msg


def test_nan_goal_is_refused() -> None:
    nav = Navigator(NavStack("office", seed=0))
    assert not nav.goToPose(_goal(float("nan"), 1.0))
    assert nav.last_error.startswith("goal pose contains NaN or inf")
    assert np.isfinite(nav.robot_pose().x)


def test_stack_file_builds_the_running_graph(tmp_path: Path) -> None:
    from navstack.core.errors import ConfigError

    folder = tmp_path
    stack_file = folder / "stack.yaml"
    stack_file.write_text("name: lab\nseed: 3\nrobot: turtlebot\n"
                          "world: {name: office, spawn: [2.0, 7.5, 0.0]}\n")
    stack = NavStack.from_stack_file(stack_file).start()
    assert stack.robot.name == "turtlebot"
    assert stack.sim.sim.pose == Pose2D(2.0, 7.5, 0.0)
    assert {"simulator", "planner_server", "controller_server", "bt_navigator"} <= set(
        stack.runtime.nodes)
    nav = Navigator(stack)
    assert nav.goToPose(_goal(3.5, 7.5))
    _run(nav, 60.0)
    assert nav.getResult() is TaskResult.SUCCEEDED
    bad = folder / "bad.yaml"
    bad.write_text("world: {name: office, spwan: [1, 1, 0]}\n")
    with pytest.raises(ConfigError) as e:
        NavStack.from_stack_file(bad)
    assert str(e.value) == f"{bad}: world.spwan: unknown key (did you mean 'spawn'?)"
