"""Odometry sources for outdoor vehicles without quadrature wheel encoders.

Three pure pieces, fed with explicit time and plain numbers (no bus):

* :class:`WheelImuDeadReckoning` -- counts pulses of a single-channel wheel sensor (a hall
  sensor with ``pulses_per_revolution`` magnets, 4 on the seed golf cart, wheel radius
  0.225 m: 2 pi 0.225 / 4 = 0.3534 m per pulse) and takes the heading from the IMU yaw.
  A single channel cannot tell direction, so the sign comes from the drive command.
  Each step is integrated as a circular arc between the previous and the new heading
  (exact for constant curvature).
* :class:`GnssOdometry` -- the same integration with the GNSS Doppler speed over ground
  (unsigned: forward or backward from the drive command) and the IMU yaw relative to its
  initial value, rotated into ENU by the calibrated offset; the course over ground, when
  the vehicle moves fast enough for it to be defined, is compared with the predicted
  direction of travel (:attr:`GnssOdometry.course_error`), which exposes slip or a bad
  heading offset.
* :class:`HeadingCalibration` -- the start-up procedure that finds that offset: drive
  straight for ``duration`` (2.5 s) at ``speed`` (1.5 m/s), average ``course_over_ground -
  imu_yaw`` over the samples fast enough for a valid course, then report
  ``READY`` ("odometry ready").  An IMU yaw is relative to wherever its magnetometer-free
  integration started; the GNSS course is relative to true north; their difference is
  the constant that turns the one into ENU.

Angles are radians, ENU yaw counter-clockwise from east; courses are given as ENU yaw
(use :func:`course_over_ground` on an ENU velocity, or
:func:`navstack.geo.conversions.bearing_to_yaw` on an NMEA track angle).
"""

from __future__ import annotations

import math
from enum import Enum

import numpy as np
from pydantic import Field

from navstack.core.errors import InvalidMessage, NavstackError
from navstack.core.geometry import angle_diff, normalize_angle
from navstack.core.msgs import (
    Header,
    Odometry,
    Pose2D,
    PoseWithCovariance,
    Twist,
    Twist2D,
    TwistWithCovariance,
    TwistWithCovarianceStamped,
)
from navstack.core.params import Params

__all__ = [
    "CalibrationError", "CalibrationState", "GnssOdometry", "HeadingCalibration",
    "HeadingCalibrationParams", "WheelEncoderParams", "WheelImuDeadReckoning",
    "arc_step", "course_over_ground", "speed_over_ground",
]


class CalibrationError(NavstackError):
    """The heading calibration could not produce an offset; the message says why."""


def speed_over_ground(vel: TwistWithCovarianceStamped) -> float:
    """Horizontal speed [m/s] of an ENU velocity message (x east, y north)."""
    v = vel.twist.twist.linear
    return math.hypot(v.x, v.y)


def course_over_ground(vel: TwistWithCovarianceStamped) -> float:
    """Direction of travel as ENU yaw [rad] of an ENU velocity (undefined near zero speed:
    check :func:`speed_over_ground` first)."""
    v = vel.twist.twist.linear
    return math.atan2(v.y, v.x)


def arc_step(pose: Pose2D, distance: float, new_yaw: float) -> Pose2D:
    """Move ``distance`` [m] (negative: backwards) along the circular arc that turns the
    heading from ``pose.theta`` to ``new_yaw``: chord ``distance * sinc(dtheta / 2)`` along
    the mean heading.  Exact for constant curvature, e.g. a full circle returns home."""
    dth = angle_diff(new_yaw, pose.theta)
    half = 0.5 * dth
    chord = distance * (math.sin(half) / half if abs(half) > 1e-9 else 1.0 - half * half / 6.0)
    mid = pose.theta + half
    return Pose2D(pose.x + chord * math.cos(mid), pose.y + chord * math.sin(mid),
                  normalize_angle(new_yaw))


def _direction(command_vx: float, last: float) -> float:
    """+1 / -1 from the drive command; keep the last sign while the command is ~0
    (a coasting vehicle keeps its direction)."""
    if command_vx > 1e-6:
        return 1.0
    if command_vx < -1e-6:
        return -1.0
    return last


class WheelEncoderParams(Params):
    """A single-channel pulse wheel sensor (seed golf cart: 4 pulses per revolution on a
    0.225 m wheel).  ``counter_modulus`` > 0 is the value at which the hardware counter
    wraps (65536 for a 16-bit counter); 0 means it never wraps."""

    wheel_radius: float = Field(default=0.225, gt=0.0)
    pulses_per_revolution: int = Field(default=4, ge=1)
    counter_modulus: int = Field(default=0, ge=0)

    @property
    def distance_per_pulse(self) -> float:
        """Distance [m] travelled per pulse: ``2 pi r / pulses_per_revolution``."""
        return 2.0 * math.pi * self.wheel_radius / self.pulses_per_revolution


class WheelImuDeadReckoning:
    """Pulse counting + IMU heading dead reckoning in the ``odom`` frame.

    The odometry heading is ``initial_pose.theta + (imu_yaw - first imu_yaw)``, so the
    frame starts at ``initial_pose`` whatever the IMU's own zero.  :meth:`update` takes
    the *cumulative* counter reading (what the microcontroller reports); the first call
    only latches the counter and the IMU reference.
    """

    def __init__(self, params: WheelEncoderParams | None = None,
                 initial_pose: Pose2D | None = None) -> None:
        self.params = params or WheelEncoderParams()
        self.initial_pose = initial_pose or Pose2D()
        self.pose = self.initial_pose
        self.distance = 0.0
        self.pulses = 0
        self.velocity = 0.0
        self._counter: int | None = None
        self._imu_ref = 0.0
        self._last_t = 0.0
        self._sign = 1.0

    def heading(self, imu_yaw: float) -> float:
        """Odometry-frame yaw for an IMU yaw."""
        return normalize_angle(self.initial_pose.theta + (imu_yaw - self._imu_ref))

    def update(self, now: float, counter: int, imu_yaw: float, command_vx: float) -> Pose2D:
        """Integrate the pulses counted since the previous call; returns the new pose."""
        if self._counter is None:
            self._counter, self._imu_ref, self._last_t = int(counter), imu_yaw, now
            self._sign = _direction(command_vx, 1.0)
            return self.pose
        delta = int(counter) - self._counter
        if self.params.counter_modulus > 0:
            delta %= self.params.counter_modulus
        self._counter = int(counter)
        return self.add_pulses(now, delta, imu_yaw, command_vx)

    def add_pulses(self, now: float, pulses: int, imu_yaw: float, command_vx: float) -> Pose2D:
        """Integrate ``pulses`` (>= 0) counted since the previous update."""
        if pulses < 0:
            raise InvalidMessage(f"pulse count went backwards by {-pulses}; a single-channel "
                                   "counter only counts up (set counter_modulus if it wraps)")
        if self._counter is None:  # used without update(): latch the IMU reference now
            self._counter, self._imu_ref, self._last_t = 0, imu_yaw, now
        self._sign = _direction(command_vx, self._sign)
        d = self._sign * pulses * self.params.distance_per_pulse
        self.pose = arc_step(self.pose, d, self.heading(imu_yaw))
        self.distance += abs(d)
        self.pulses += pulses
        dt = now - self._last_t
        self.velocity = d / dt if dt > 0.0 else self.velocity
        self._last_t = now
        return self.pose

    def odometry(self, now: float, frame_id: str = "odom",
                 child_frame_id: str = "base_link") -> Odometry:
        """The current pose and forward velocity as nav_msgs/Odometry (no covariance model:
        pulse quantisation is ``distance_per_pulse``, reported as the x/y std)."""
        q = self.params.distance_per_pulse ** 2
        cov = np.diag([q, q, 1e6, 1e6, 1e6, 1e-4])
        return Odometry(Header(now, frame_id), child_frame_id,
                        PoseWithCovariance(self.pose.to_pose(), cov),
                        TwistWithCovariance(Twist.planar(self.velocity, 0.0, 0.0),
                                            np.diag([q, 1e6, 1e6, 1e6, 1e6, 1e6])))


class GnssOdometry:
    """Dead reckoning from GNSS speed over ground and IMU heading, in ENU about the start.

    ``yaw_offset`` (from :class:`HeadingCalibration`) turns an IMU yaw into ENU:
    ``heading_enu = imu_yaw + yaw_offset``.  The position starts at ``initial_position``
    (ENU metres, e.g. the first fix about the datum) and integrates
    ``sign(command) * SOG`` along the heading, averaging the speed of consecutive samples
    over each interval and following the arc between their headings.
    """

    def __init__(self, yaw_offset: float, initial_position: tuple[float, float] = (0.0, 0.0),
                 min_course_speed: float = 0.5) -> None:
        self.yaw_offset = float(yaw_offset)
        self.min_course_speed = float(min_course_speed)
        self.pose = Pose2D(initial_position[0], initial_position[1], 0.0)
        self.distance = 0.0
        self.course_error = math.nan
        self._last: tuple[float, float] | None = None  # time, signed speed
        self._sign = 1.0
        self._initial_imu_yaw: float | None = None

    def heading(self, imu_yaw: float) -> float:
        """ENU heading [rad] for an IMU yaw."""
        return normalize_angle(imu_yaw + self.yaw_offset)

    def yaw_change(self, imu_yaw: float) -> float:
        """Heading change since the first sample (the IMU yaw relative to its initial
        value), [rad]."""
        ref = imu_yaw if self._initial_imu_yaw is None else self._initial_imu_yaw
        return angle_diff(imu_yaw, ref)

    def update(self, now: float, speed_over_ground: float, imu_yaw: float,
               command_vx: float, course: float | None = None) -> Pose2D:
        """Integrate to ``now``; ``course`` (ENU yaw of the GNSS velocity) is optional."""
        self._sign = _direction(command_vx, self._sign)
        v = self._sign * abs(speed_over_ground)
        heading = self.heading(imu_yaw)
        if self._last is None:
            self._initial_imu_yaw = imu_yaw
            self.pose = Pose2D(self.pose.x, self.pose.y, heading)
        else:
            t0, v0 = self._last
            d = 0.5 * (v0 + v) * max(now - t0, 0.0)
            self.pose = arc_step(self.pose, d, heading)
            self.distance += abs(d)
        self._last = (now, v)
        if course is not None and abs(speed_over_ground) >= self.min_course_speed:
            travel = heading if self._sign > 0 else normalize_angle(heading + math.pi)
            self.course_error = angle_diff(course, travel)
        return self.pose


class CalibrationState(Enum):
    WAITING = "waiting"
    CALIBRATING = "calibrating"
    READY = "odometry ready"
    FAILED = "failed"


class HeadingCalibrationParams(Params):
    """The straight-drive heading calibration.  ``min_speed`` [m/s]: samples slower than
    this (still accelerating) are ignored since their course is noisy;
    ``max_yaw_change`` [rad]: the IMU yaw may not wander more than this from its mean
    (the drive must be straight); ``min_samples`` valid samples are required."""

    duration: float = Field(default=2.5, gt=0.0)
    speed: float = Field(default=1.5, gt=0.0)
    min_speed: float = Field(default=1.0, gt=0.0)
    max_yaw_change: float = Field(default=0.1, gt=0.0)
    min_samples: int = Field(default=3, ge=1)


class HeadingCalibration:
    """Drive straight, average ``course - imu_yaw``, report the IMU -> ENU yaw offset.

    Use: :meth:`start` at ``now``; send :meth:`command` as the drive command every cycle;
    feed :meth:`add_sample` with each GNSS velocity and the IMU yaw of that moment; when
    :meth:`command` returns zero the state is ``READY`` (``yaw_offset`` set) or ``FAILED``
    (``reason`` says why).
    """

    def __init__(self, params: HeadingCalibrationParams | None = None) -> None:
        self.params = params or HeadingCalibrationParams()
        self.state = CalibrationState.WAITING
        self.yaw_offset = math.nan
        self.reason = ""
        self._start = math.nan
        self._diffs: list[float] = []
        self._imu: list[float] = []

    @property
    def odometry_ready(self) -> bool:
        return self.state is CalibrationState.READY

    def start(self, now: float) -> None:
        self.state = CalibrationState.CALIBRATING
        self._start = now
        self._diffs.clear()
        self._imu.clear()
        self.yaw_offset = math.nan
        self.reason = ""

    def command(self, now: float) -> Twist2D:
        """The drive command: ``speed`` straight ahead during the window, then zero (and
        the result is computed)."""
        if self.state is not CalibrationState.CALIBRATING:
            return Twist2D()
        if now - self._start < self.params.duration - 1e-9:
            return Twist2D(self.params.speed, 0.0, 0.0)
        self._finish()
        return Twist2D()

    def add_sample(self, now: float, speed_over_ground: float, course: float,
                   imu_yaw: float) -> bool:
        """Take one GNSS velocity sample; returns whether it was used."""
        if self.state is not CalibrationState.CALIBRATING:
            return False
        if not self._start - 1e-9 <= now <= self._start + self.params.duration + 1e-9:
            return False
        if speed_over_ground < self.params.min_speed:
            return False
        self._diffs.append(angle_diff(course, imu_yaw))
        self._imu.append(imu_yaw)
        return True

    def _finish(self) -> None:
        p = self.params
        if len(self._diffs) < p.min_samples:
            self.state = CalibrationState.FAILED
            self.reason = (f"only {len(self._diffs)} GNSS velocity samples at >= "
                           f"{p.min_speed} m/s in {p.duration} s (need {p.min_samples}); "
                           "check that the vehicle drove and the receiver has a fix")
            return
        imu = np.asarray(self._imu)
        mean_imu = math.atan2(float(np.mean(np.sin(imu))), float(np.mean(np.cos(imu))))
        spread = float(np.max(np.abs(normalize_angle(imu - mean_imu))))
        if spread > p.max_yaw_change:
            self.state = CalibrationState.FAILED
            self.reason = (f"the IMU yaw varied by {spread:.3f} rad (> max_yaw_change "
                           f"{p.max_yaw_change}) during the calibration drive; drive straight")
            return
        d = np.asarray(self._diffs)
        self.yaw_offset = math.atan2(float(np.mean(np.sin(d))), float(np.mean(np.cos(d))))
        self.state = CalibrationState.READY
