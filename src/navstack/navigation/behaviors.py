"""The built-in recovery behaviors (Nav2 ``nav2_behaviors``): Spin, BackUp,
DriveOnHeading and Wait, each a :class:`~navstack.core.interfaces.Behavior` plugin served
by the :class:`~navstack.navigation.behavior_server.BehaviorServer`.

Spin follows Nav2 ``Spin::onCycleUpdate``: ``v = sqrt(2 rotational_acc_lim *
remaining)`` clamped to ``[min_rotational_vel, max_rotational_vel]``, done when the
accumulated yaw reaches ``|target_yaw|``.  Drive-on-heading / backup drive at the goal
speed until the straight-line distance from the start pose reaches the goal distance
(Nav2 Humble: no ramp), so they stop less than one cycle of travel past the target.
Wait publishes nothing for ``time`` seconds.

As in Nav2, Spin's limits are behavior-server parameters (``behavior_server:
ros__parameters: max_rotational_vel: ...``); a ``spin:`` section may override them.
"""

from __future__ import annotations

import math
from typing import Generic, TypeVar

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.errors import InvalidBehaviorGoal
from navstack.core.geometry import angle_diff
from navstack.core.interfaces import Behavior, BehaviorStep
from navstack.core.msgs import Pose2D, Twist2D
from navstack.core.params import Params
from navstack.core.plugins import register_behavior
from navstack.navigation.messages import BackUpGoal, DriveOnHeadingGoal, SpinGoal, WaitGoal

G = TypeVar("G", BackUpGoal, DriveOnHeadingGoal)


def clip_run(travel: NDArray[np.float64], remaining: float) -> NDArray[np.float64]:
    """Projected travel along the steps, cut at (and including) the first that reaches
    ``remaining``, where the behavior would stop."""
    reached = np.flatnonzero(travel >= remaining)
    if reached.size:
        travel = travel[: reached[0] + 1].copy()
        travel[-1] = max(remaining, 0.0)
    return travel


class SpinParams(Params):
    """Nav2 Spin's parameters (behavior-server level in Nav2; names and defaults)."""

    max_rotational_vel: float = Field(1.0, gt=0.0)
    min_rotational_vel: float = Field(0.4, ge=0.0)
    rotational_acc_lim: float = Field(3.2, gt=0.0)


@register_behavior("Spin", nav2="nav2_behaviors::Spin")
class Spin(Behavior[SpinGoal]):
    """Rotate in place by ``target_yaw`` (sign = direction)."""

    params_model = SpinParams
    params: SpinParams
    goal_type = SpinGoal

    def __init__(self, params: SpinParams | None = None) -> None:
        super().__init__(params)
        self.cmd_yaw = self.prev_yaw = self.relative = 0.0
        self._time_allowance = 0.0

    def start(self, goal: SpinGoal, pose: Pose2D, now: float) -> None:
        if not math.isfinite(goal.target_yaw):
            raise InvalidBehaviorGoal(f"target_yaw must be a finite angle in radians, "
                                      f"got {goal.target_yaw}")
        self.cmd_yaw, self._time_allowance = goal.target_yaw, goal.time_allowance
        self.prev_yaw, self.relative = pose.theta, 0.0

    def cycle(self, pose: Pose2D, now: float) -> BehaviorStep:
        p = self.params
        self.relative += angle_diff(pose.theta, self.prev_yaw)
        self.prev_yaw = pose.theta
        remaining = abs(self.cmd_yaw) - abs(self.relative)
        if remaining < 1e-6:
            return BehaviorStep(Twist2D(), self.relative, done=True)
        vel = math.sqrt(2.0 * p.rotational_acc_lim * remaining)
        vel = min(max(vel, p.min_rotational_vel), p.max_rotational_vel)
        return BehaviorStep(Twist2D(0.0, 0.0, math.copysign(vel, self.cmd_yaw)), self.relative)

    def projection(self, pose: Pose2D, twist: Twist2D, steps: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        remaining = abs(self.cmd_yaw) - abs(self.relative)
        turn = clip_run(np.abs(twist.wz) * steps, remaining)
        out = np.empty((len(turn), 3))
        out[:, 0], out[:, 1] = pose.x, pose.y
        out[:, 2] = pose.theta + math.copysign(1.0, twist.wz) * turn
        return out

    @property
    def time_allowance(self) -> float:
        return self._time_allowance

    @property
    def progress(self) -> float:
        return self.relative

    @property
    def description(self) -> str:
        return f"spinning {self.cmd_yaw:.2f} rad"


class _Straight(Behavior[G], Generic[G]):
    """Drive straight at ``speed`` until ``|distance|`` from the start pose is covered."""

    verb = "driving"

    def __init__(self, params: Params | None = None) -> None:
        super().__init__(params)
        self.start_pose = Pose2D()
        self.target = self.speed = self.traveled = self._time_allowance = 0.0

    def _begin(self, distance: float, speed: float, time_allowance: float,
               pose: Pose2D) -> None:
        if not (math.isfinite(distance) and math.isfinite(speed)):
            raise InvalidBehaviorGoal(f"distance and speed must be finite, got {distance} m "
                                      f"and {speed} m/s")
        if speed == 0.0:
            raise InvalidBehaviorGoal("speed must be non-zero")
        if distance * speed < 0.0:
            raise InvalidBehaviorGoal(
                f"distance {distance:g} m and speed {speed:g} m/s have different signs; "
                f"give both the sign of the direction of travel")
        self.start_pose, self.target, self.speed = pose, abs(distance), speed
        self._time_allowance, self.traveled = time_allowance, 0.0

    def cycle(self, pose: Pose2D, now: float) -> BehaviorStep:
        self.traveled = self.start_pose.distance_to(pose)
        if self.traveled >= self.target - 1e-9:  # slack for float sums of odometry steps
            return BehaviorStep(Twist2D(), self.traveled, done=True)
        return BehaviorStep(Twist2D(self.speed, 0.0, 0.0), self.traveled)

    def projection(self, pose: Pose2D, twist: Twist2D, steps: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        s = math.copysign(1.0, twist.vx) * clip_run(abs(twist.vx) * steps,
                                                    self.target - self.traveled)
        out = np.empty((len(s), 3))
        out[:, 0] = pose.x + s * math.cos(pose.theta)
        out[:, 1] = pose.y + s * math.sin(pose.theta)
        out[:, 2] = pose.theta
        return out

    @property
    def time_allowance(self) -> float:
        return self._time_allowance

    @property
    def progress(self) -> float:
        return self.traveled

    @property
    def description(self) -> str:
        return f"{self.verb} {self.target:.2f} m at {abs(self.speed):.2f} m/s"


@register_behavior("DriveOnHeading", nav2="nav2_behaviors::DriveOnHeading")
class DriveOnHeading(_Straight[DriveOnHeadingGoal]):
    """Drive ``distance`` along the current heading (sign = direction) at ``speed``."""

    goal_type = DriveOnHeadingGoal
    verb = "driving on heading"

    def start(self, goal: DriveOnHeadingGoal, pose: Pose2D, now: float) -> None:
        self._begin(goal.distance, goal.speed, goal.time_allowance, pose)


@register_behavior("BackUp", nav2="nav2_behaviors::BackUp")
class BackUp(_Straight[BackUpGoal]):
    """Drive ``|distance|`` backwards at ``|speed|`` (Nav2 BackUp)."""

    goal_type = BackUpGoal
    verb = "backing up"

    def start(self, goal: BackUpGoal, pose: Pose2D, now: float) -> None:
        self._begin(-abs(goal.distance), -abs(goal.speed), goal.time_allowance, pose)


@register_behavior("Wait", nav2="nav2_behaviors::Wait")
class Wait(Behavior[WaitGoal]):
    """Do nothing for ``time`` seconds (feedback: time left)."""

    goal_type = WaitGoal

    def __init__(self, params: Params | None = None) -> None:
        super().__init__(params)
        self.end = self.now = self.duration = 0.0

    def start(self, goal: WaitGoal, pose: Pose2D, now: float) -> None:
        if not (math.isfinite(goal.time) and goal.time >= 0.0):
            raise InvalidBehaviorGoal(f"wait time must be a finite number of seconds >= 0, "
                                      f"got {goal.time}")
        self.end, self.now, self.duration = now + goal.time, now, goal.time

    def cycle(self, pose: Pose2D, now: float) -> BehaviorStep:
        self.now = now
        left = self.end - now
        return BehaviorStep(None, max(left, 0.0), done=left <= 1e-9)

    @property
    def progress(self) -> float:
        return max(self.end - self.now, 0.0)

    @property
    def description(self) -> str:
        return f"waiting {self.duration:g} s"
