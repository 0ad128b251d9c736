"""The rover's GPS legs as runtime pieces a mission (or a behaviour tree leaf) can start,
tick and read: the heading-calibration drive, the PI chase and the ``gps_goal_fix`` loop.

All three follow ``FIELD-ROBOTS.md`` (the planetary rover):

- :class:`HeadingCalibration` drives straight for 2.5 s at 1.5 m/s with obstacle
  detection off (straight onto ``/cmd_vel``, past the collision monitor), averages the
  GNSS course over ground (``/gps/vel``) and pairs it with the odom yaw of the drive: the
  bearing of the odom x axis, which every GPS goal is rotated by, and the local origin
  (the first fix after the drive, robot_localization's ``publish_origin``).
- :class:`GpsChaseLeg` is the rover's ``gps_goal_controller``: every ``period`` it places
  the goal in odom from the recent fixes (:class:`~navstack.geo.gps_goal.FixGoalFilter`),
  runs the PI law (:class:`~navstack.control.gps_chase.GpsChasePI`) and sends its output
  as an intermediate NavigateToPose goal; it stops within the rover's ~0.88 m.
- :class:`GpsGoalFixLeg` is the mission variant: it sends the goal itself to navigation
  and re-sends it from newer fixes more often as the rover nears it (every
  ``distance / resend_speed`` s, clamped to ``[min_period, max_period]``); a navigation
  result within ``accept_radius`` (10 m) of the goal ends the leg, farther it re-sends.

Both legs run an :class:`~navstack.control.oscillation.OscillationDetector` on the
commands to the base (the rover's parallel ``OscillationDetected`` guard): an oscillation
fails the leg with the detector's reason.  A leg's ``status`` is ``RUNNING`` until it
ends ``SUCCEEDED``, ``FAILED`` (``reason`` says why) or ``CANCELED``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from enum import Enum
from typing import Any

from pydantic import Field

from navstack.control.gps_chase import GpsChaseParams, GpsChasePI
from navstack.control.oscillation import OscillationDetector, OscillationParams
from navstack.core.errors import NavstackError
from navstack.core.msgs import (
    NavSatFix,
    NavSatStatus,
    Pose2D,
    PoseStamped,
    Twist,
    TwistWithCovarianceStamped,
)
from navstack.core.params import Params
from navstack.geo.gps_goal import (
    FixGoalFilter,
    LocalOrigin,
    course_over_ground,
    odom_axis_course,
    parse_coordinate,
)
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus
from navstack.runtime.node import Node, Runtime

__all__ = ["CalibrationParams", "GpsChaseLeg", "GpsChaseLegParams", "GpsGoalFixLeg",
           "GpsGoalFixParams", "HeadingCalibration", "LegStatus"]


class LegStatus(Enum):
    IDLE = "idle"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELED = "canceled"


class CalibrationParams(Params):
    """The rover's heading calibration: ``duration`` [s] at ``speed`` [m/s] straight ahead;
    course samples slower than ``min_speed`` [m/s] (accelerating) are left out."""

    duration: float = Field(default=2.5, gt=0.0)
    speed: float = Field(default=1.5, gt=0.0)
    min_speed: float = Field(default=0.75, gt=0.0)
    cmd_topic: str = "/cmd_vel"
    fix_topic: str = "/gps/fix"
    velocity_topic: str = "/gps/vel"
    odom_frame: str = "odom"
    base_frame: str = "base_link"


def _active(node: Node) -> Node:
    node.configure()
    node.activate()
    return node


class HeadingCalibration(Node):
    """Drive straight, average the course over ground; then :attr:`origin` is the local
    origin whose ``course_deg`` is the bearing of the odom x axis."""

    def __init__(self, runtime: Runtime, params: CalibrationParams | None = None) -> None:
        super().__init__("heading_calibration", runtime)
        self.params = params or CalibrationParams()
        self.status = LegStatus.IDLE
        self.reason = ""
        self.origin: LocalOrigin | None = None
        self.course_deg = math.nan
        self._start = math.inf
        self._east: list[float] = []
        self._north: list[float] = []
        self._yaw_sum = [0.0, 0.0]
        self._cmd = self.create_publisher(self.params.cmd_topic, Twist)
        self.create_subscription(self.params.velocity_topic, TwistWithCovarianceStamped,
                                 self._on_velocity)
        self.create_subscription(self.params.fix_topic, NavSatFix, self._on_fix)
        self.create_timer(0.05, self._tick)
        _active(self)

    def start(self) -> None:
        self.status, self.reason, self.origin = LegStatus.RUNNING, "", None
        self._start = self.now
        self._east, self._north, self._yaw_sum = [], [], [0.0, 0.0]

    def _driving(self) -> bool:
        return (self.status is LegStatus.RUNNING
                and self.now <= self._start + self.params.duration)

    def _on_velocity(self, msg: TwistWithCovarianceStamped) -> None:
        if not self._driving():
            return
        v = msg.twist.twist.linear
        self._east.append(v.x)
        self._north.append(v.y)
        try:
            yaw = self.tf.lookup_pose2d(self.params.odom_frame, self.params.base_frame).theta
        except NavstackError:
            return
        self._yaw_sum[0] += math.cos(yaw)
        self._yaw_sum[1] += math.sin(yaw)

    def _on_fix(self, msg: NavSatFix) -> None:
        if (self.status is LegStatus.RUNNING and not self._driving()
                and math.isfinite(self.course_deg)
                and msg.status.status >= NavSatStatus.STATUS_FIX):
            self.origin = LocalOrigin(msg.latitude, msg.longitude, self.course_deg)
            self.status = LegStatus.SUCCEEDED

    def _tick(self) -> None:
        if self.status is not LegStatus.RUNNING:
            return
        if self._driving():
            self._cmd.publish(Twist.planar(self.params.speed, 0.0, 0.0))
            return
        if math.isfinite(self.course_deg):
            return  # waiting for the origin fix
        self._cmd.publish(Twist.planar(0.0, 0.0, 0.0))
        try:
            course = course_over_ground(self._east, self._north, self.params.min_speed)
        except NavstackError as exc:
            self.status, self.reason = LegStatus.FAILED, str(exc)
            return
        yaw = math.atan2(self._yaw_sum[1], self._yaw_sum[0])
        self.course_deg = odom_axis_course(course, yaw)


class GpsChaseLegParams(Params):
    """The PI chase leg: ``chase`` the PI law, ``period`` [s] between PI steps (each sends
    an intermediate goal; every 1 s the navigator's preemptions halved the rover's speed:
    a 33 m leg took 67 s instead of 32 s at 2 s), ``filter_window`` [s] of fixes averaged,
    ``min_fixes`` before the first step, ``timeout`` [s] of the whole leg, ``oscillation``
    the guard, ``antenna`` the GNSS antenna's (x, y) on ``base_link`` [m]."""

    chase: GpsChaseParams = Field(default_factory=GpsChaseParams)
    oscillation: OscillationParams = Field(default_factory=OscillationParams)
    period: float = Field(default=2.0, gt=0.0)
    filter_window: float = Field(default=10.0, gt=0.0)
    min_fixes: int = Field(default=5, ge=1)
    timeout: float = Field(default=300.0, gt=0.0)
    fix_topic: str = "/gps/fix"
    cmd_topic: str = "/cmd_vel"
    odom_frame: str = "odom"
    base_frame: str = "base_link"
    antenna: tuple[float, float] = (0.0, 0.0)


class GpsGoalFixParams(GpsChaseLegParams):
    """The gps_goal_fix loop: re-send every ``distance / resend_speed`` s within
    [``min_period``, ``max_period``]; a navigation result within ``accept_radius`` [m]
    ends the leg; ``max_failures`` navigation failures farther out fail it; ``period``
    [s] is how often the schedule is checked."""

    period: float = Field(default=1.0, gt=0.0)
    resend_speed: float = Field(default=4.0, gt=0.0)
    min_period: float = Field(default=1.0, gt=0.0)
    max_period: float = Field(default=10.0, gt=0.0)
    accept_radius: float = Field(default=10.0, gt=0.0)
    max_failures: int = Field(default=3, ge=1)


class _GpsLeg(Node, ABC):
    """What both GPS legs share: fixes -> goal in odom, the oscillation guard, the
    navigation client, status."""

    def __init__(self, name: str, runtime: Runtime, axis_course_deg: float,
                 params: GpsChaseLegParams) -> None:
        super().__init__(name, runtime)
        self.params = params
        self.axis_course_deg = axis_course_deg
        self.status = LegStatus.IDLE
        self.reason = ""
        self.goal_odom: tuple[float, float] | None = None
        self.distance = math.inf
        self.goals_sent = 0
        self._filter: FixGoalFilter | None = None
        self._started = 0.0
        self._nav: ActionClient[m.NavigateToPoseGoal] = ActionClient(self.bus,
                                                                     m.NAVIGATE_TO_POSE)
        self._task: GoalHandle[Any] | None = None
        self.guard = OscillationDetector(params.oscillation)
        self.create_subscription(params.fix_topic, NavSatFix, self._on_fix)
        self.create_subscription(params.cmd_topic, Twist, self._on_cmd)
        self.create_timer(params.period, self._on_period)

    def start(self, latitude: float | str, longitude: float | str) -> None:
        """Chase the goal (decimal degrees or ``"deg,min,sec"``; GeoError naming the field)."""
        lat = parse_coordinate(latitude, "goal.latitude", "latitude")
        lon = parse_coordinate(longitude, "goal.longitude", "longitude")
        self._filter = FixGoalFilter(lat, lon, self.axis_course_deg, self.params.filter_window)
        self.status, self.reason, self.goal_odom = LegStatus.RUNNING, "", None
        self.distance, self.goals_sent, self._started = math.inf, 0, self.now
        self.guard.reset()
        self._on_start()

    def _on_start(self) -> None:
        """Reset of the variant's own state."""

    def cancel(self, reason: str = "canceled on request") -> None:
        if self.status is LegStatus.RUNNING:
            self._finish(LegStatus.CANCELED, reason)

    def _finish(self, status: LegStatus, reason: str) -> None:
        if self._task is not None and not self._task.done:
            self._task.cancel()
        self._task = None
        self.status, self.reason = status, reason

    def _pose(self, stamp: float | None = None) -> Pose2D | None:
        try:
            return self.tf.lookup_pose2d(self.params.odom_frame, self.params.base_frame, stamp)
        except NavstackError:
            if stamp is None:
                return None
            return self._pose(None)

    def _on_fix(self, msg: NavSatFix) -> None:
        if self.status is not LegStatus.RUNNING or self._filter is None:
            return
        if msg.status.status < NavSatStatus.STATUS_FIX or not math.isfinite(msg.latitude):
            return
        pose = self._pose(float(msg.header.stamp))
        if pose is None:
            return
        ax, ay = self.params.antenna
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        self.goal_odom = self._filter.add_fix(float(msg.header.stamp), msg.latitude,
                                              msg.longitude, pose.x + c * ax - s * ay,
                                              pose.y + s * ax + c * ay)

    def _on_cmd(self, msg: Twist) -> None:
        if self.status is not LegStatus.RUNNING:
            return
        pose = self._pose()
        if pose is None:
            return
        report = self.guard.update(self.now, msg.linear.x, msg.angular.z, pose.x, pose.y)
        if report is not None:
            self._finish(LegStatus.FAILED, report.reason)

    def _ready(self) -> Pose2D | None:
        """The robot's odom pose when a step can run (enough fixes, not timed out)."""
        if self.status is not LegStatus.RUNNING or self._filter is None:
            return None
        if self.now - self._started > self.params.timeout:
            self._finish(LegStatus.FAILED, f"GPS goal not reached within "
                                           f"{self.params.timeout:g} s ({self.distance:.1f} m "
                                           "left by the fixes)")
            return None
        if self._filter.fixes < self.params.min_fixes or self.goal_odom is None:
            return None
        pose = self._pose()
        if pose is not None:
            self.distance = math.hypot(self.goal_odom[0] - pose.x, self.goal_odom[1] - pose.y)
        return pose

    def _send(self, x: float, y: float, yaw: float) -> None:
        goal = PoseStamped.from_pose2d(Pose2D(x, y, yaw), self.params.odom_frame, self.now)
        self._task = self._nav.send_goal(m.NavigateToPoseGoal(goal))
        self.goals_sent += 1

    @abstractmethod
    def _on_period(self) -> None:
        """One step of the leg, every ``period``."""


class GpsChaseLeg(_GpsLeg):
    """The PI chase: intermediate goals from :class:`GpsChasePI` every ``period``."""

    def __init__(self, runtime: Runtime, axis_course_deg: float,
                 params: GpsChaseLegParams | None = None) -> None:
        super().__init__("gps_chase", runtime, axis_course_deg, params or GpsChaseLegParams())
        self.pi = GpsChasePI(self.params.chase)
        _active(self)

    def _on_start(self) -> None:
        self.pi.reset()

    def _on_period(self) -> None:
        pose = self._ready()
        if pose is None or self.goal_odom is None:
            return
        step = self.pi.step(self.goal_odom, (pose.x, pose.y), self.params.period)
        if step.done:
            self._finish(LegStatus.SUCCEEDED, f"within {self.params.chase.stop_radius:g} m "
                                              f"of the GPS goal ({step.distance:.2f} m)")
            return
        self._send(step.x, step.y, step.yaw)


class GpsGoalFixLeg(_GpsLeg):
    """The gps_goal_fix loop: the goal itself to navigation, re-sent more often nearer."""

    def __init__(self, runtime: Runtime, axis_course_deg: float,
                 params: GpsGoalFixParams | None = None) -> None:
        p = params or GpsGoalFixParams()
        super().__init__("gps_goal_fix", runtime, axis_course_deg, p)
        self.fix_params = p
        self._next_send = 0.0
        self.failures = 0
        _active(self)

    def _on_start(self) -> None:
        self._next_send, self.failures = self.now, 0

    def resend_period(self, distance: float) -> float:
        p = self.fix_params
        return min(max(distance / p.resend_speed, p.min_period), p.max_period)

    def _on_period(self) -> None:
        pose = self._ready()
        if pose is None or self.goal_odom is None:
            return
        p = self.fix_params
        task = self._task
        if task is not None and task.done and task.result is not None:
            self._task = None
            if self.distance <= p.accept_radius:
                how = ("reached" if task.result.status is GoalStatus.SUCCEEDED
                       else f"navigation {task.result.status.name.lower()}")
                self._finish(LegStatus.SUCCEEDED, f"{how} {self.distance:.2f} m from the GPS "
                                                  f"goal (accepting {p.accept_radius:g} m)")
                return
            if task.result.status is not GoalStatus.SUCCEEDED:
                self.failures += 1
                if self.failures >= p.max_failures:
                    self._finish(LegStatus.FAILED, f"navigation failed {self.failures} times "
                                                   f"{self.distance:.1f} m from the GPS goal: "
                                                   f"{task.result.error_msg}")
                    return
            self._next_send = self.now
        if self.now + 1e-9 < self._next_send:
            return
        yaw = math.atan2(self.goal_odom[1] - pose.y, self.goal_odom[0] - pose.x)
        self._send(self.goal_odom[0], self.goal_odom[1], yaw)
        self._next_send = self.now + self.resend_period(self.distance)
