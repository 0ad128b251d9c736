"""Progress checkers: is the robot still getting somewhere? (``check(...) -> bool``).

* :class:`SimpleProgressChecker` (``nav2_controller::SimpleProgressChecker``): the robot
  must move more than ``required_movement_radius`` from a baseline pose within
  ``movement_time_allowance`` seconds; each time it does, the baseline moves to it.
* :class:`PoseProgressChecker` (``nav2_controller::PoseProgressChecker``): rotating by
  more than ``required_movement_angle`` also counts as progress (in-place turns).
* :class:`GoalProgressChecker` (navstack): the distance to the goal must drop by more
  than ``progress_epsilon`` within ``dwell_time`` seconds.  Wandering or circling near
  an obstacle moves the robot but does not bring it closer, which this catches and
  the movement-based checkers do not; the navigator uses it to trigger recoveries.

``False`` means "no progress for too long".  Time is the caller's ``now`` [s] (sim or
wall clock), never read behind its back; a clock going backwards restarts the baseline.
All three implement :class:`navstack.core.interfaces.ProgressChecker`; the controller
server passes the goal (in the pose's frame) to every ``check``, which only the goal
checker uses: a goal that moved by more than ``progress_epsilon`` (a new goal, not the
re-transform of the same one) restarts its baseline.
"""

from __future__ import annotations

import math

from pydantic import Field

from navstack.core.geometry import angle_diff
from navstack.core.interfaces import ProgressChecker
from navstack.core.msgs import Pose2D
from navstack.core.params import Params
from navstack.core.plugins import PROGRESS_CHECKERS, register_progress_checker


class SimpleProgressCheckerParams(Params):
    """Nav2 defaults: ``required_movement_radius`` 0.5 m, ``movement_time_allowance`` 10 s."""

    plugin: str = "nav2_controller::SimpleProgressChecker"
    required_movement_radius: float = Field(0.5, ge=0.0)
    movement_time_allowance: float = Field(10.0, gt=0.0)


class PoseProgressCheckerParams(SimpleProgressCheckerParams):
    """Adds Nav2's ``required_movement_angle`` [rad] (default 0.5)."""

    plugin: str = "nav2_controller::PoseProgressChecker"
    required_movement_angle: float = Field(0.5, ge=0.0)


class GoalProgressCheckerParams(Params):
    """``progress_epsilon`` [m] of goal-distance decrease required per ``dwell_time`` [s]."""

    plugin: str = "navstack::GoalProgressChecker"
    progress_epsilon: float = Field(0.1, ge=0.0)
    dwell_time: float = Field(10.0, gt=0.0)


@register_progress_checker("SimpleProgressChecker",
                           nav2="nav2_controller::SimpleProgressChecker")
class SimpleProgressChecker(ProgressChecker):
    """Movement of more than ``required_movement_radius`` within the time allowance."""

    params_model = SimpleProgressCheckerParams
    params: SimpleProgressCheckerParams

    def __init__(self, params: SimpleProgressCheckerParams | None = None) -> None:
        super().__init__(params)
        self.baseline_pose: Pose2D | None = None
        self.baseline_time = 0.0

    def reset(self) -> None:
        """Forget the baseline; the next :meth:`check` starts a new one."""
        self.baseline_pose = None

    def _moved_enough(self, pose: Pose2D, baseline: Pose2D) -> bool:
        return pose.distance_to(baseline) > self.params.required_movement_radius

    def check(self, pose: Pose2D, now: float, goal: Pose2D | None = None) -> bool:
        """True while progressing; False once stuck longer than the allowance (``goal``
        is not used)."""
        base = self.baseline_pose
        if base is None or now < self.baseline_time or self._moved_enough(pose, base):
            self.baseline_pose, self.baseline_time = pose, now
            return True
        return now - self.baseline_time <= self.params.movement_time_allowance

    def failure_message(self) -> str:
        p = self.params
        return (f"moved less than {p.required_movement_radius:.2f} m in "
                f"{p.movement_time_allowance:.1f} s")


@register_progress_checker("PoseProgressChecker", nav2="nav2_controller::PoseProgressChecker")
class PoseProgressChecker(SimpleProgressChecker):
    """Also counts a heading change above ``required_movement_angle`` as progress."""

    params_model = PoseProgressCheckerParams
    params: PoseProgressCheckerParams

    def __init__(self, params: PoseProgressCheckerParams | None = None) -> None:
        super().__init__(params or PoseProgressCheckerParams())

    def _moved_enough(self, pose: Pose2D, baseline: Pose2D) -> bool:
        return (super()._moved_enough(pose, baseline)
                or abs(angle_diff(pose.theta, baseline.theta))
                > self.params.required_movement_angle)

    def failure_message(self) -> str:
        p = self.params
        return (f"moved less than {p.required_movement_radius:.2f} m and turned less than "
                f"{p.required_movement_angle:.2f} rad in {p.movement_time_allowance:.1f} s")


@register_progress_checker("GoalProgressChecker", nav2="navstack::GoalProgressChecker")
class GoalProgressChecker(ProgressChecker):
    """Distance-to-goal must shrink by ``progress_epsilon`` at least every ``dwell_time``."""

    params_model = GoalProgressCheckerParams
    params: GoalProgressCheckerParams

    def __init__(self, params: GoalProgressCheckerParams | None = None,
                 goal: Pose2D | None = None) -> None:
        super().__init__(params)
        self.goal = goal
        self.baseline_distance: float | None = None
        self.baseline_time = 0.0

    def set_goal(self, goal: Pose2D) -> None:
        """Track progress toward a new goal (restarts the baseline)."""
        self.goal = goal
        self.reset()

    def reset(self) -> None:
        self.baseline_distance = None

    def check(self, pose: Pose2D, now: float, goal: Pose2D | None = None) -> bool:
        """True while the goal distance keeps dropping; ``goal`` overrides :meth:`set_goal`
        (a goal within ``progress_epsilon`` of the current one is the same goal)."""
        if goal is not None and (self.goal is None or math.hypot(
                goal.x - self.goal.x, goal.y - self.goal.y) > self.params.progress_epsilon):
            self.set_goal(goal)
        if self.goal is None:
            raise ValueError("GoalProgressChecker.check needs a goal: call set_goal(goal) "
                             "or pass goal=")
        dist = math.hypot(pose.x - self.goal.x, pose.y - self.goal.y)
        base = self.baseline_distance
        if base is None or now < self.baseline_time or dist < base - self.params.progress_epsilon:
            self.baseline_distance, self.baseline_time = dist, now
            return True
        return now - self.baseline_time <= self.params.dwell_time

    def failure_message(self) -> str:
        p = self.params
        return (f"the distance to the goal shrank by less than {p.progress_epsilon:.2f} m in "
                f"{p.dwell_time:.1f} s")


__all__ = ["PROGRESS_CHECKERS", "GoalProgressChecker", "GoalProgressCheckerParams",
           "PoseProgressChecker", "PoseProgressCheckerParams", "SimpleProgressChecker",
           "SimpleProgressCheckerParams"]
