"""Goal checkers (``nav2_controller::SimpleGoalChecker`` / ``StoppedGoalChecker``).

``is_goal_reached(pose, goal, velocity) -> bool`` with pose and goal in the same frame.
The simple checker compares the position within ``xy_goal_tolerance`` and the heading
within ``yaw_goal_tolerance``; when ``stateful`` it latches the position check once
passed, so a robot rotating in place at the goal is not failed by small drifts out of
the xy window (``reset()`` clears the latch, e.g. on a new goal).  The stopped checker
additionally requires the robot to be (almost) at rest.
"""

from __future__ import annotations

import math

from pydantic import Field

from navstack.core.geometry import angle_diff, normalize_angle
from navstack.core.interfaces import GoalChecker
from navstack.core.msgs import Pose2D, Twist2D
from navstack.core.params import Params
from navstack.core.plugins import GOAL_CHECKERS, register_goal_checker


class SimpleGoalCheckerParams(Params):
    """Nav2 defaults: 0.25 m, 0.25 rad, stateful; ``symmetric_yaw_tolerance`` accepts goal+pi."""

    plugin: str = "nav2_controller::SimpleGoalChecker"
    xy_goal_tolerance: float = Field(0.25, ge=0.0)
    yaw_goal_tolerance: float = Field(0.25, ge=0.0)
    stateful: bool = True
    symmetric_yaw_tolerance: bool = False


class StoppedGoalCheckerParams(SimpleGoalCheckerParams):
    """Adds Nav2's ``trans_stopped_velocity`` [m/s] and ``rot_stopped_velocity`` [rad/s] (0.25)."""

    plugin: str = "nav2_controller::StoppedGoalChecker"
    trans_stopped_velocity: float = Field(0.25, ge=0.0)
    rot_stopped_velocity: float = Field(0.25, ge=0.0)


@register_goal_checker("SimpleGoalChecker", nav2=("nav2_controller::SimpleGoalChecker",
                                                  "dwb_plugins::SimpleGoalChecker"))
class SimpleGoalChecker(GoalChecker):
    """Position within ``xy_goal_tolerance`` (latched if ``stateful``), yaw within tolerance."""

    params_model = SimpleGoalCheckerParams
    params: SimpleGoalCheckerParams

    def __init__(self, params: SimpleGoalCheckerParams | None = None) -> None:
        super().__init__(params)
        self.check_xy = True

    def reset(self) -> None:
        """Re-arm the position check (new goal)."""
        self.check_xy = True

    def is_goal_reached(self, pose: Pose2D, goal: Pose2D, velocity: Twist2D) -> bool:
        p = self.params
        if self.check_xy:
            if math.hypot(pose.x - goal.x, pose.y - goal.y) > p.xy_goal_tolerance:
                return False
            if p.stateful:
                self.check_xy = False
        dyaw = abs(angle_diff(goal.theta, pose.theta))
        if p.symmetric_yaw_tolerance:
            back = abs(angle_diff(normalize_angle(goal.theta + math.pi), pose.theta))
            return min(dyaw, back) <= p.yaw_goal_tolerance
        return dyaw <= p.yaw_goal_tolerance


@register_goal_checker("StoppedGoalChecker", nav2=("nav2_controller::StoppedGoalChecker",
                                                   "dwb_plugins::StoppedGoalChecker"))
class StoppedGoalChecker(SimpleGoalChecker):
    """:class:`SimpleGoalChecker` plus ``|wz| <= rot_stopped_velocity`` and
    ``hypot(vx, vy) <= trans_stopped_velocity``."""

    params_model = StoppedGoalCheckerParams
    params: StoppedGoalCheckerParams

    def __init__(self, params: StoppedGoalCheckerParams | None = None) -> None:
        super().__init__(params or StoppedGoalCheckerParams())

    def is_goal_reached(self, pose: Pose2D, goal: Pose2D, velocity: Twist2D) -> bool:
        if not super().is_goal_reached(pose, goal, velocity):
            return False
        p = self.params
        return (abs(velocity.wz) <= p.rot_stopped_velocity
                and math.hypot(velocity.vx, velocity.vy) <= p.trans_stopped_velocity)


__all__ = ["GOAL_CHECKERS", "SimpleGoalChecker", "SimpleGoalCheckerParams", "StoppedGoalChecker",
           "StoppedGoalCheckerParams"]
