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
    """A box that is not on the map is marked in the local costmap while the robot is
    still well ahead of it, and the robot drives around it.  Asserted on the outcome over
    the whole run, sampled every spin -- not at one instant, whose timing depends on the
    controller's and the collision monitor's speed choices."""
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
    box_x0, box_x1 = world.origin_x + c0 * world.resolution, world.origin_x + (c0 + 6) * 0.05
    box_y0, box_y1 = world.origin_y + r0 * world.resolution, world.origin_y + (r0 + 6) * 0.05
    assert nav.goToPose(_goal(sx + 4.5, sy))
    marked_at: float | None = None  # distance to the box face when first marked lethal
    clearance = math.inf  # body (0.22 m disc) to the box, every spin
    t0 = stack.now
    while not nav.isTaskComplete():
        assert stack.now - t0 < 90.0, "task did not end in time"
        p = nav.robot_pose()
        if marked_at is None:
            local = stack.local_costmap.costmap  # in odom: bring the box there
            to_odom = stack.runtime.tf.lookup_pose2d("odom", "map")
            corners = [to_odom.compose(Pose2D(x, y, 0.0)) for x in (box_x0, box_x1 - 0.01)
                       for y in (box_y0, box_y1 - 0.01)]
            cells = [local.world_to_map(c.x, c.y) for c in corners]
            if all(c is not None for c in cells):
                xs = [c[0] for c in cells if c is not None]
                ys = [c[1] for c in cells if c is not None]
                block = local.data[min(ys):max(ys) + 1, min(xs):max(xs) + 1]
                if block.max() == LETHAL_OBSTACLE:
                    assert block.min() >= INSCRIBED_INFLATED_OBSTACLE  # the box is inflated
                    marked_at = box_x0 - p.x
        dx = max(box_x0 - p.x, 0.0, p.x - box_x1)
        dy = max(box_y0 - p.y, 0.0, p.y - box_y1)
        clearance = min(clearance, math.hypot(dx, dy) - 0.22)
    assert nav.getResult() is TaskResult.SUCCEEDED
    assert stack.sim.sim.collisions == 0
    # seen from at least 1 m away (the lidar marks up to 2.5 m; the costmap runs at 10 Hz)
    assert marked_at is not None and marked_at >= 1.0
    # driven around it, never touching (the collision count) with a margin the padded
    # footprint and the inflation keep (measured 0.065 m, marked 1.18 m ahead; 5 cm cells)
    assert clearance >= 0.03, clearance


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
