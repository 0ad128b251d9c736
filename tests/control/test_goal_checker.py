"""SimpleGoalChecker / StoppedGoalChecker (Nav2 nav2_controller semantics)."""

from __future__ import annotations

import math

from navstack.control.goal_checker import (
    GOAL_CHECKERS,
    SimpleGoalChecker,
    SimpleGoalCheckerParams,
    StoppedGoalChecker,
    StoppedGoalCheckerParams,
)
from navstack.core.msgs import Pose2D, Twist2D

GOAL = Pose2D(2.0, 1.0, 0.5)
STILL = Twist2D()


def test_tolerances() -> None:
    gc = SimpleGoalChecker(SimpleGoalCheckerParams(stateful=False))
    assert gc.is_goal_reached(Pose2D(2.2, 1.1, 0.3), GOAL, STILL)       # 0.224 m, 0.2 rad
    assert not gc.is_goal_reached(Pose2D(2.2, 1.2, 0.5), GOAL, STILL)   # 0.283 m
    assert not gc.is_goal_reached(Pose2D(2.0, 1.0, 0.8), GOAL, STILL)   # 0.3 rad
    assert gc.is_goal_reached(Pose2D(2.0, 1.0, 0.75), GOAL, STILL)      # exactly 0.25 rad
    wrap = Pose2D(0.0, 0.0, math.pi - 0.1)
    assert gc.is_goal_reached(Pose2D(0.0, 0.0, -math.pi + 0.1), wrap, STILL)  # across +-pi


def test_stateful_latch_and_reset() -> None:
    gc = SimpleGoalChecker()
    assert not gc.is_goal_reached(Pose2D(2.1, 1.0, 2.0), GOAL, STILL)  # xy ok, yaw not
    # drifted out of the xy window while turning: still judged on yaw alone
    assert gc.is_goal_reached(Pose2D(2.4, 1.0, 0.5), GOAL, STILL)
    gc.reset()
    assert not gc.is_goal_reached(Pose2D(2.4, 1.0, 0.5), GOAL, STILL)
    stateless = SimpleGoalChecker(SimpleGoalCheckerParams(stateful=False))
    assert not stateless.is_goal_reached(Pose2D(2.1, 1.0, 2.0), GOAL, STILL)
    assert not stateless.is_goal_reached(Pose2D(2.4, 1.0, 0.5), GOAL, STILL)


def test_symmetric_yaw() -> None:
    gc = SimpleGoalChecker(SimpleGoalCheckerParams(symmetric_yaw_tolerance=True))
    assert gc.is_goal_reached(Pose2D(2.0, 1.0, 0.5 + math.pi - 0.1), GOAL, STILL)
    assert not gc.is_goal_reached(Pose2D(2.0, 1.0, 0.5 + math.pi / 2), GOAL, STILL)


def test_stopped_goal_checker() -> None:
    gc = StoppedGoalChecker(StoppedGoalCheckerParams(trans_stopped_velocity=0.1,
                                                     rot_stopped_velocity=0.2))
    at = Pose2D(2.0, 1.0, 0.5)
    assert not gc.is_goal_reached(at, GOAL, Twist2D(0.08, 0.08, 0.0))   # 0.113 m/s
    assert not gc.is_goal_reached(at, GOAL, Twist2D(0.0, 0.0, 0.25))
    assert gc.is_goal_reached(at, GOAL, Twist2D(0.06, 0.06, -0.2))
    assert not gc.is_goal_reached(Pose2D(3.0, 1.0, 0.5), Pose2D(0, 0, 0), STILL)


def test_registry_aliases() -> None:
    assert GOAL_CHECKERS.get("nav2_controller::StoppedGoalChecker") is StoppedGoalChecker
    assert GOAL_CHECKERS.get("dwb_plugins::SimpleGoalChecker") is SimpleGoalChecker
