"""Progress checkers with explicit times."""

from __future__ import annotations

import pytest

from navstack.control.progress_checker import (
    PROGRESS_CHECKERS,
    GoalProgressChecker,
    GoalProgressCheckerParams,
    PoseProgressChecker,
    SimpleProgressChecker,
    SimpleProgressCheckerParams,
)
from navstack.core.msgs import Pose2D


def test_simple_progress_checker_times_out_without_movement() -> None:
    pc = SimpleProgressChecker()
    assert pc.check(Pose2D(0, 0, 0), 0.0)
    assert pc.check(Pose2D(0.4, 0, 0), 9.0)        # 0.4 m < 0.5 m, within 10 s
    assert pc.check(Pose2D(0.4, 0.2, 0), 10.0)     # exactly the allowance: still fine
    assert not pc.check(Pose2D(0.45, 0, 3.0), 10.5)  # stuck for 10.5 s (turning doesn't count)
    assert pc.check(Pose2D(0.51, 0, 0), 11.0)       # moved 0.51 m: new baseline at t = 11
    assert pc.check(Pose2D(0.51, 0, 0), 21.0)
    assert not pc.check(Pose2D(0.51, 0, 0), 21.01)


def test_simple_progress_checker_reset_and_clock_jump() -> None:
    pc = SimpleProgressChecker(SimpleProgressCheckerParams(required_movement_radius=0.2,
                                                           movement_time_allowance=2.0))
    pc.check(Pose2D(), 0.0)
    assert not pc.check(Pose2D(), 3.0)
    pc.reset()
    assert pc.check(Pose2D(), 3.0) and pc.check(Pose2D(), 5.0)
    assert pc.check(Pose2D(), 1.0)  # clock went backwards (sim reset): new baseline
    assert not pc.check(Pose2D(), 3.5)


def test_pose_progress_checker_counts_rotation() -> None:
    pc = PoseProgressChecker()
    pc.check(Pose2D(0, 0, 0), 0.0)
    assert pc.check(Pose2D(0, 0, 0.6), 9.0)        # turned 0.6 rad > 0.5: progress
    assert pc.check(Pose2D(0, 0, 0.6), 19.0)
    assert not pc.check(Pose2D(0, 0, 0.9), 19.5)    # 0.3 rad since t = 9


def test_goal_progress_checker() -> None:
    pc = GoalProgressChecker(GoalProgressCheckerParams(progress_epsilon=0.1, dwell_time=5.0))
    goal = Pose2D(10.0, 0.0, 0.0)
    assert pc.check(Pose2D(0, 0, 0), 0.0, goal)
    assert pc.check(Pose2D(0.05, 3.0, 0), 4.0)      # moving, but not closer to the goal
    assert not pc.check(Pose2D(0.05, -3.0, 0), 5.5)  # circling for 5.5 s: no progress
    assert pc.check(Pose2D(0.2, 0.0, 0), 6.0)        # 9.8 m < 10 - 0.1: progress again
    assert pc.check(Pose2D(0.25, 0.0, 0), 11.0)
    assert not pc.check(Pose2D(0.25, 0.0, 0), 11.5)
    pc.set_goal(Pose2D(0.0, 0.0, 0.0))              # new goal restarts the baseline
    assert pc.check(Pose2D(0.25, 0.0, 0), 12.0)
    with pytest.raises(ValueError, match="needs a goal"):
        GoalProgressChecker().check(Pose2D(), 0.0)


def test_goal_progress_checker_in_the_server_loop() -> None:
    """The controller server passes the goal every cycle, re-transformed into the odom
    frame: a goal moving by less than progress_epsilon is the same goal (no reset), a
    goal moved farther is a new one."""
    pc = GoalProgressChecker(GoalProgressCheckerParams(progress_epsilon=0.1, dwell_time=5.0))
    assert pc.check(Pose2D(0, 0, 0), 0.0, Pose2D(10.0, 0.0, 0.0))
    assert pc.check(Pose2D(0, 1.0, 0), 3.0, Pose2D(10.03, 0.02, 0.0))
    assert not pc.check(Pose2D(0, -1.0, 0), 5.5, Pose2D(9.97, -0.02, 0.0))
    assert pc.check(Pose2D(0, -1.0, 0), 6.0, Pose2D(5.0, 0.0, 0.0))  # a new goal
    assert pc.failure_message() == ("the distance to the goal shrank by less than 0.10 m "
                                    "in 5.0 s")


def test_registry_aliases() -> None:
    assert PROGRESS_CHECKERS.get("nav2_controller::PoseProgressChecker") is PoseProgressChecker
    assert PROGRESS_CHECKERS.get("navstack::GoalProgressChecker") is GoalProgressChecker
