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
"""

from __future__ import annotations

import math

from pydantic import Field

from navstack.core.geometry import angle_diff
from navstack.core.msgs import Pose2D
from navstack.core.params import Params
from navstack.core.registry import PluginRegistry


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


class SimpleProgressChecker:
    """Movement of more than ``required_movement_radius`` within the time allowance."""

    def __init__(self, params: SimpleProgressCheckerParams | None = None) -> None:
        self.params = params or SimpleProgressCheckerParams()
        self.baseline_pose: Pose2D | None = None
        self.baseline_time = 0.0

    def reset(self) -> None:
        """Forget the baseline; the next :meth:`check` starts a new one."""
        self.baseline_pose = None

    def _moved_enough(self, pose: Pose2D, baseline: Pose2D) -> bool:
        return pose.distance_to(baseline) > self.params.required_movement_radius

    def check(self, pose: Pose2D, now: float) -> bool:
        """True while progressing; False once stuck longer than the allowance."""
        base = self.baseline_pose
        if base is None or now < self.baseline_time or self._moved_enough(pose, base):
            self.baseline_pose, self.baseline_time = pose, now
            return True
        return now - self.baseline_time <= self.params.movement_time_allowance


class PoseProgressChecker(SimpleProgressChecker):
    """Also counts a heading change above ``required_movement_angle`` as progress."""

    params: PoseProgressCheckerParams

    def __init__(self, params: PoseProgressCheckerParams | None = None) -> None:
        super().__init__(params or PoseProgressCheckerParams())

    def _moved_enough(self, pose: Pose2D, baseline: Pose2D) -> bool:
        return (super()._moved_enough(pose, baseline)
                or abs(angle_diff(pose.theta, baseline.theta))
                > self.params.required_movement_angle)


class GoalProgressChecker:
    """Distance-to-goal must shrink by ``progress_epsilon`` at least every ``dwell_time``."""

    def __init__(self, params: GoalProgressCheckerParams | None = None,
                 goal: Pose2D | None = None) -> None:
        self.params = params or GoalProgressCheckerParams()
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
        """True while the goal distance keeps dropping; ``goal`` overrides :meth:`set_goal`."""
        if goal is not None and goal != self.goal:
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


PROGRESS_CHECKERS: PluginRegistry[type[SimpleProgressChecker] | type[GoalProgressChecker]] = (
    PluginRegistry("progress checker"))
PROGRESS_CHECKERS.register("SimpleProgressChecker", SimpleProgressChecker,
                           aliases=("nav2_controller::SimpleProgressChecker",
                                    "nav2_controller/SimpleProgressChecker"))
PROGRESS_CHECKERS.register("PoseProgressChecker", PoseProgressChecker,
                           aliases=("nav2_controller::PoseProgressChecker",
                                    "nav2_controller/PoseProgressChecker"))
PROGRESS_CHECKERS.register("GoalProgressChecker", GoalProgressChecker,
                           aliases=("navstack::GoalProgressChecker",))
