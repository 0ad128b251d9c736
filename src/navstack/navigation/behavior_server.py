"""``BehaviorServer``: the spin / backup / drive_on_heading / wait recovery actions (Nav2
``nav2_behaviors``, ``TimedBehavior`` semantics).

Each accepted goal runs from a timer at ``cycle_frequency``.  Every cycle reads the
robot pose ``local_frame -> robot_base_frame`` from TF (older than
``transform_tolerance`` -> ``TF_ERROR``), checks ``time_allowance`` (0 = unlimited;
exceeded -> ``TIMEOUT``), publishes ``BehaviorFeedback`` and a Twist on
``cmd_vel_topic``.  Before a motion command is published the motion is projected ahead
in steps of ``1 / cycle_frequency`` for ``simulate_ahead_time`` seconds (stopping where
the behavior would end) and each projected pose is passed to ``collision_checker``; a
hit stops the robot and fails with ``COLLISION_AHEAD`` naming the pose.  The current
pose itself is not checked, so a robot touching an obstacle can still back away from
it.  Whatever the outcome, a zero Twist is published when a behavior ends.

Spin follows Nav2 ``Spin::onCycleUpdate``: ``v = sqrt(2 rotational_acc_lim *
remaining)`` clamped to ``[min_rotational_vel, max_rotational_vel]``, done when the
accumulated yaw reaches ``|target_yaw|``.  Drive-on-heading / backup drive at the goal
speed until the straight-line distance from the start pose reaches the goal distance
(Nav2 Humble: no ramp), so they stop less than one cycle of travel past the target.

Deviation: ``cycle_frequency`` defaults to 20 Hz (Nav2: 10 Hz), the controller rate,
which halves the overshoot of the last cycle.  A new goal to any behavior preempts the
running one (it ends CANCELED, "preempted by a new goal").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.errors import TransformError
from navstack.core.geometry import angle_diff
from navstack.core.msgs import Pose2D, Twist, Twist2D
from navstack.core.params import Params
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionServer, GoalHandle
from navstack.runtime.node import LifecycleState, Node, Runtime
from navstack.runtime.scheduler import Timer

CollisionChecker = Callable[[Pose2D], bool]
"""True when the robot footprint at this ``local_frame`` pose is in collision."""
BehaviorCode = m.BehaviorErrorCode


class BehaviorServerParams(Params):
    """Nav2 ``behavior_server`` parameters (Nav2 names and defaults, except
    ``cycle_frequency``); ``cmd_vel_topic`` is where the Twists go."""

    cycle_frequency: float = Field(20.0, gt=0.0)
    local_frame: str = "odom"
    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    transform_tolerance: float = Field(0.1, gt=0.0)
    simulate_ahead_time: float = Field(2.0, ge=0.0)
    max_rotational_vel: float = Field(1.0, gt=0.0)
    min_rotational_vel: float = Field(0.4, ge=0.0)
    rotational_acc_lim: float = Field(3.2, gt=0.0)
    cmd_vel_topic: str = "/cmd_vel"


@dataclass(frozen=True)
class BehaviorResult:
    """Result payload (Nav2 ``total_elapsed_time``) plus the final progress value."""

    total_elapsed_time: float
    progress: float


@dataclass(frozen=True)
class _Cycle:
    twist: Twist2D | None  # None: command nothing this cycle (wait)
    progress: float
    done: bool = False


class _InvalidInput(Exception):
    """A goal field is out of range (-> INVALID_INPUT)."""


class _TfError(Exception):
    """The robot pose cannot be read from TF (-> TF_ERROR)."""


def _fmt(p: Pose2D | NDArray[np.float64]) -> str:
    x, y, th = (p.x, p.y, p.theta) if isinstance(p, Pose2D) else (p[0], p[1], p[2])
    return f"(x={x:.2f}, y={y:.2f}, yaw={th:.2f})"


class _Spin:
    """Nav2 Spin: rotate in place by ``target_yaw`` (sign = direction)."""

    def __init__(self, goal: m.SpinGoal, pose: Pose2D, p: BehaviorServerParams) -> None:
        if not math.isfinite(goal.target_yaw):
            raise _InvalidInput(f"target_yaw must be a finite angle in radians, "
                                f"got {goal.target_yaw}")
        self.p, self.cmd_yaw, self.time_allowance = p, goal.target_yaw, goal.time_allowance
        self.prev_yaw, self.relative = pose.theta, 0.0
        self.what = f"spinning {goal.target_yaw:.2f} rad"

    def cycle(self, pose: Pose2D, now: float) -> _Cycle:
        self.relative += angle_diff(pose.theta, self.prev_yaw)
        self.prev_yaw = pose.theta
        remaining = abs(self.cmd_yaw) - abs(self.relative)
        if remaining < 1e-6:
            return _Cycle(Twist2D(), self.relative, done=True)
        vel = math.sqrt(2.0 * self.p.rotational_acc_lim * remaining)
        vel = min(max(vel, self.p.min_rotational_vel), self.p.max_rotational_vel)
        return _Cycle(Twist2D(0.0, 0.0, math.copysign(vel, self.cmd_yaw)), self.relative)

    def projection(self, pose: Pose2D, twist: Twist2D, steps: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        remaining = abs(self.cmd_yaw) - abs(self.relative)
        turn = _clip_run(np.abs(twist.wz) * steps, remaining)
        out = np.empty((len(turn), 3))
        out[:, 0], out[:, 1] = pose.x, pose.y
        out[:, 2] = pose.theta + math.copysign(1.0, twist.wz) * turn
        return out


class _Drive:
    """Nav2 DriveOnHeading (and BackUp with both signs negative): straight at ``speed``."""

    def __init__(self, distance: float, speed: float, time_allowance: float, pose: Pose2D,
                 name: str) -> None:
        if not (math.isfinite(distance) and math.isfinite(speed)):
            raise _InvalidInput(f"distance and speed must be finite, got {distance} m and "
                                f"{speed} m/s")
        if speed == 0.0:
            raise _InvalidInput("speed must be non-zero")
        if distance * speed < 0.0:
            raise _InvalidInput(f"distance {distance:g} m and speed {speed:g} m/s have different "
                                f"signs; give both the sign of the direction of travel")
        self.start, self.target, self.speed = pose, abs(distance), speed
        self.time_allowance, self.traveled = time_allowance, 0.0
        self.what = f"{name} {self.target:.2f} m at {abs(speed):.2f} m/s"

    def cycle(self, pose: Pose2D, now: float) -> _Cycle:
        self.traveled = self.start.distance_to(pose)
        if self.traveled >= self.target - 1e-9:  # slack for float sums of odometry steps
            return _Cycle(Twist2D(), self.traveled, done=True)
        return _Cycle(Twist2D(self.speed, 0.0, 0.0), self.traveled)

    def projection(self, pose: Pose2D, twist: Twist2D, steps: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        s = math.copysign(1.0, twist.vx) * _clip_run(abs(twist.vx) * steps,
                                                     self.target - self.traveled)
        out = np.empty((len(s), 3))
        out[:, 0] = pose.x + s * math.cos(pose.theta)
        out[:, 1] = pose.y + s * math.sin(pose.theta)
        out[:, 2] = pose.theta
        return out


class _Wait:
    """Nav2 Wait: do nothing for ``time`` seconds (feedback: time left)."""

    def __init__(self, goal: m.WaitGoal, now: float) -> None:
        if not (math.isfinite(goal.time) and goal.time >= 0.0):
            raise _InvalidInput(f"wait time must be a finite number of seconds >= 0, "
                                f"got {goal.time}")
        self.end, self.time_allowance, self.now = now + goal.time, 0.0, now
        self.what = f"waiting {goal.time:g} s"

    def cycle(self, pose: Pose2D, now: float) -> _Cycle:
        self.now = now
        left = self.end - now
        return _Cycle(None, max(left, 0.0), done=left <= 1e-9)

    def projection(self, pose: Pose2D, twist: Twist2D, steps: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        return np.zeros((0, 3))


_Behavior = _Spin | _Drive | _Wait


def _clip_run(travel: NDArray[np.float64], remaining: float) -> NDArray[np.float64]:
    """Projected travel along the steps, cut at (and including) the first that reaches
    ``remaining``, where the behavior would stop."""
    reached = np.flatnonzero(travel >= remaining)
    if reached.size:
        travel = travel[: reached[0] + 1].copy()
        travel[-1] = max(remaining, 0.0)
    return travel


@dataclass
class _Active:
    kind: str
    handle: GoalHandle[Any]
    behavior: _Behavior
    start: float
    timer: Timer | None = None


class BehaviorServer(Node):
    """Spin, BackUp, DriveOnHeading and Wait action servers publishing on ``cmd_vel_topic``.

    ``collision_checker(pose)`` says whether the footprint at an odom-frame pose collides
    (the stack wires it to the local costmap); ``None`` disables collision checking.
    """

    def __init__(self, runtime: Runtime, params: BehaviorServerParams | None = None,
                 collision_checker: CollisionChecker | None = None,
                 name: str = "behavior_server") -> None:
        super().__init__(name, runtime)
        self.params = params or BehaviorServerParams()
        self.collision_checker = collision_checker
        self._servers: list[ActionServer[Any]] = []
        self._active: _Active | None = None
        n = int(self.params.cycle_frequency * self.params.simulate_ahead_time + 1e-9)
        self._steps = np.arange(1, n + 1) / self.params.cycle_frequency

    def on_configure(self) -> None:
        self._pub = self.create_publisher(self.params.cmd_vel_topic, Twist)
        for kind, action in (("spin", m.SPIN), ("backup", m.BACKUP),
                             ("drive_on_heading", m.DRIVE_ON_HEADING), ("wait", m.WAIT)):
            self._servers.append(ActionServer(self.bus, action, self._goal_handler(kind),
                                              self._on_cancel))

    def on_deactivate(self) -> None:
        if self._active is not None:
            self._end(self._active, "canceled", reason=f"{self.name} was deactivated")

    def on_cleanup(self) -> None:
        for server in self._servers:
            server.close()
        self._servers.clear()

    @property
    def active_behavior(self) -> str | None:
        return self._active.kind if self._active is not None else None

    # --- goals -----------------------------------------------------------------------
    def _robot_pose(self) -> Pose2D:
        local, base = self.params.local_frame, self.params.robot_base_frame
        try:
            ts = self.tf.lookup(local, base)
        except TransformError as exc:
            raise _TfError(f"robot pose ({base} in {local}) is not available: {exc}") from None
        age = self.now - ts.header.stamp
        if age > self.params.transform_tolerance:
            raise _TfError(f"robot pose ({base} in {local}) is {age:.2f} s old "
                           f"(transform_tolerance {self.params.transform_tolerance:g} s); "
                           f"is odometry running?")
        return ts.transform.to_pose2d()

    def _make(self, kind: str, goal: Any, pose: Pose2D) -> _Behavior:
        if kind == "spin":
            return _Spin(goal, pose, self.params)
        if kind == "backup":
            return _Drive(-abs(goal.distance), -abs(goal.speed), goal.time_allowance, pose,
                          "backing up")
        if kind == "drive_on_heading":
            return _Drive(goal.distance, goal.speed, goal.time_allowance, pose,
                          "driving on heading")
        return _Wait(goal, self.now)

    def _goal_handler(self, kind: str) -> Callable[[GoalHandle[Any]], bool | str]:
        def on_goal(handle: GoalHandle[Any]) -> bool | str:
            if self.state is not LifecycleState.ACTIVE:
                return f"{self.name} is not active (state {self.state.value}); activate it first"
            handle.execute()
            try:
                behavior = self._make(kind, handle.goal, self._robot_pose())
            except _TfError as exc:
                handle.fail(int(BehaviorCode.TF_ERROR), f"{kind}: {exc}")
                return True
            except _InvalidInput as exc:
                handle.fail(int(BehaviorCode.INVALID_INPUT), f"{kind}: {exc}")
                return True
            if self._active is not None:
                self._end(self._active, "canceled", reason="preempted by a new goal")
            act = _Active(kind, handle, behavior, self.now)
            self._active = act
            act.timer = self.runtime.scheduler.create_timer(
                1.0 / self.params.cycle_frequency, self._cycle, first_at=self.now)
            return True
        return on_goal

    def _on_cancel(self, handle: GoalHandle[Any]) -> None:
        act = self._active
        if act is not None and act.handle is handle:
            self._end(act, "canceled")
        else:
            handle.canceled()

    def _end(self, act: _Active, outcome: str, code: int = 0, reason: str = "",
             progress: float = 0.0) -> None:
        if act.timer is not None:
            act.timer.cancel()
        if self._active is act:
            self._active = None
        self._pub.publish(Twist())
        result = BehaviorResult(self.now - act.start, progress)
        if outcome == "succeeded":
            act.handle.succeed(result)
        elif outcome == "failed":
            act.handle.fail(code, reason, result)
        else:
            act.handle.canceled(result, reason=reason or "canceled on request")

    # --- cycle -------------------------------------------------------------------------
    def _cycle(self) -> None:
        act = self._active
        if act is None or act.handle.done:
            return
        b = act.behavior
        elapsed = self.now - act.start
        if b.time_allowance > 0.0 and elapsed > b.time_allowance:
            self._end(act, "failed", int(BehaviorCode.TIMEOUT),
                      f"{act.kind}: {b.what} did not finish within time_allowance "
                      f"{b.time_allowance:g} s", _progress(b))
            return
        try:
            pose = self._robot_pose()
        except _TfError as exc:
            self._end(act, "failed", int(BehaviorCode.TF_ERROR), f"{act.kind}: {exc}",
                      _progress(b))
            return
        step = b.cycle(pose, self.now)
        act.handle.publish_feedback(m.BehaviorFeedback(step.progress))
        if step.done:
            self._end(act, "succeeded", progress=step.progress)
            return
        if step.twist is None:
            return
        hit = self._collision_ahead(b, pose, step.twist)
        if hit is not None:
            self._end(act, "failed", int(BehaviorCode.COLLISION_AHEAD),
                      f"{act.kind}: collision ahead: {b.what} would put the footprint in "
                      f"collision at {self.params.local_frame} pose {_fmt(hit)} within "
                      f"simulate_ahead_time {self.params.simulate_ahead_time:g} s; stopped at "
                      f"{_fmt(pose)}", step.progress)
            return
        self._pub.publish(step.twist.to_twist())

    def _collision_ahead(self, b: _Behavior, pose: Pose2D, twist: Twist2D
                         ) -> NDArray[np.float64] | None:
        if self.collision_checker is None:
            return None
        for row in b.projection(pose, twist, self._steps):
            if self.collision_checker(Pose2D(float(row[0]), float(row[1]), float(row[2]))):
                return row
        return None


def _progress(b: _Behavior) -> float:
    if isinstance(b, _Spin):
        return b.relative
    if isinstance(b, _Drive):
        return b.traveled
    return max(b.end - b.now, 0.0)
