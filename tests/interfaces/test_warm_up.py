"""The warm-up drive a live session makes on a twin of its stack before it serves."""

from __future__ import annotations

import math

import pytest

from navstack.interfaces.stack import NavStack
from navstack.interfaces.stack_description import LocalizationName
from navstack.interfaces.warm_up import STEP_M, _free_goal_near, warm_up_navigation


@pytest.mark.parametrize(("world", "robot", "localization"), [
    ("office", "diff_drive", "external"),  # nobody publishes map -> odom: the twin's is true
    ("arena", "turtlebot3_waffle_pi", "slam"),  # waits for SLAM's first map
    ("campus", "golf_cart", "perfect"),  # Ackermann: straight ahead
])
def test_the_twin_drives_and_the_live_stack_is_left_as_it_was(
        world: str, robot: str, localization: LocalizationName) -> None:
    stack = NavStack(world, robot, seed=1, localization=localization).start()
    pose = stack.sim.sim.pose
    result = warm_up_navigation(stack)
    assert result.reached and result.reason == ""
    assert stack.now == 0.0 and stack.sim.sim.pose == pose


def test_a_robot_facing_a_wall_warms_up_going_the_other_way() -> None:
    stack = NavStack("explore_facing_wall", "turtlebot3_waffle_pi", seed=1).start()
    stack.run_for(0.25)
    spawn = stack.description.spawn
    goal = _free_goal_near(stack, spawn)
    assert goal is not None
    assert math.hypot(goal.x - (spawn.x - STEP_M), goal.y - spawn.y) < 1e-9
    assert abs(abs(goal.theta - spawn.theta) - math.pi) < 1e-9
