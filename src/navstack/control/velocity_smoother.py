"""Velocity smoother (Nav2 ``nav2_velocity_smoother``), pure: no bus, times passed in.

Every ``1 / smoothing_frequency`` seconds the latest command is clamped to
``[min_velocity, max_velocity]`` and moved from the current velocity by at most
``max_accel / smoothing_frequency`` when speeding up and ``|max_decel| /
smoothing_frequency`` when slowing down or passing through zero, per axis (vx, vy, wz)
-- Nav2's ``applyConstraints``.  With ``scale_velocities`` all axes are scaled by the
most limiting axis's factor so the command keeps its direction (``findEtaConstraint``).
The current velocity is the last output (``feedback: OPEN_LOOP``) or the odometry
averaged over ``odom_duration`` (``CLOSED_LOOP``, Nav2's ``OdomSmoother``).

``deadband_velocity``: output components smaller in magnitude are published as 0.  Nav2
before the fix applied the deadband *before* storing the open-loop state, so a command
starting from rest whose first step ``max_accel / smoothing_frequency`` fell inside the
deadband was zeroed and stored as zero -- and the next cycle started from zero again: the
output stuck at zero for ever.  Here the deadband applies to the published value only;
the open-loop state keeps the un-deadbanded velocity and keeps ramping.

``velocity_timeout``: when no command arrived for longer, the target becomes zero (Nav2),
the output ramps down at the deceleration limits, the first zero is published once and
then nothing until a new command (:meth:`VelocitySmoother.cycle` returns ``None``).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Literal

from pydantic import Field, model_validator

from navstack.core.msgs import Twist2D
from navstack.core.params import Params

__all__ = ["OdomSmoother", "VelocitySmoother", "VelocitySmootherParams"]

Vec3 = tuple[float, float, float]


class VelocitySmootherParams(Params):
    """Nav2 velocity_smoother parameters (names and Humble defaults); each vector is
    ``[vx, vy, wz]``."""

    smoothing_frequency: float = Field(20.0, gt=0.0, allow_inf_nan=False)
    scale_velocities: bool = False
    feedback: Literal["OPEN_LOOP", "CLOSED_LOOP"] = "OPEN_LOOP"
    max_velocity: Vec3 = (0.5, 0.0, 2.5)
    min_velocity: Vec3 = (-0.5, 0.0, -2.5)
    max_accel: Vec3 = (2.5, 0.0, 3.2)
    max_decel: Vec3 = (-2.5, 0.0, -3.2)
    deadband_velocity: Vec3 = (0.0, 0.0, 0.0)
    velocity_timeout: float = Field(1.0, gt=0.0, allow_inf_nan=False)
    odom_duration: float = Field(0.1, gt=0.0, allow_inf_nan=False)
    odom_topic: str = "odom"
    use_realtime_priority: bool = False
    enable_stamped_cmd_vel: bool = False
    use_sim_time: bool = True
    cmd_vel_in_topic: str = "/cmd_vel_nav"
    """navstack: the input topic (Nav2 remaps ``cmd_vel``)."""
    cmd_vel_out_topic: str = "/cmd_vel_smoothed"
    """navstack: the output topic (Nav2 remaps ``cmd_vel_smoothed``)."""

    @model_validator(mode="after")
    def _check(self) -> VelocitySmootherParams:
        """Nav2 refuses these on configure: accelerations must be >= 0, decelerations
        <= 0 (the sign says which), and min <= max velocity."""
        for i, axis in enumerate(("vx", "vy", "wz")):
            if self.max_accel[i] < 0.0:
                raise ValueError(f"max_accel {axis} must be >= 0 (got {self.max_accel[i]})")
            if self.max_decel[i] > 0.0:
                raise ValueError(f"max_decel {axis} must be <= 0: a deceleration is "
                                 f"negative (got {self.max_decel[i]})")
            if self.min_velocity[i] > self.max_velocity[i]:
                raise ValueError(f"min_velocity {axis} {self.min_velocity[i]} exceeds "
                                 f"max_velocity {self.max_velocity[i]}")
            if self.deadband_velocity[i] < 0.0:
                raise ValueError(f"deadband_velocity {axis} must be >= 0")
        values = (*self.max_velocity, *self.min_velocity, *self.max_accel, *self.max_decel,
                  *self.deadband_velocity)
        if not all(math.isfinite(v) for v in values):
            raise ValueError("velocity and acceleration limits must be finite")
        return self


class OdomSmoother:
    """Mean odometry twist over the last ``duration`` seconds (Nav2 ``OdomSmoother``)."""

    def __init__(self, duration: float) -> None:
        self.duration = duration
        self._buf: deque[tuple[float, Vec3]] = deque()

    def add(self, t: float, twist: Twist2D) -> None:
        self._buf.append((t, (twist.vx, twist.vy, twist.wz)))
        while self._buf and t - self._buf[0][0] > self.duration:
            self._buf.popleft()

    def twist(self) -> Twist2D | None:
        if not self._buf:
            return None
        n = len(self._buf)
        s = [sum(v[i] for _, v in self._buf) / n for i in range(3)]
        return Twist2D(s[0], s[1], s[2])


def _limit(v_curr: float, v_cmd: float, accel: float, decel: float, freq: float,
           eta: float) -> float:
    """Nav2 ``applyConstraints``: accelerating when |v_cmd| >= |v_curr| with the same sign
    (not passing zero), decelerating otherwise."""
    dv = v_cmd - v_curr
    if abs(v_cmd) >= abs(v_curr) and v_curr * v_cmd >= 0.0:
        lo, hi = -accel / freq, accel / freq
    else:
        lo, hi = decel / freq, -decel / freq
    return v_curr + min(max(eta * dv, lo), hi)


def _eta(v_curr: float, v_cmd: float, accel: float, decel: float, freq: float) -> float:
    """Nav2 ``findEtaConstraint``: the scale bringing this axis's change within its
    limit (-1: no constraint)."""
    dv = v_cmd - v_curr
    if abs(v_cmd) >= abs(v_curr) and v_curr * v_cmd >= 0.0:
        lo, hi = -accel / freq, accel / freq
    else:
        lo, hi = decel / freq, -decel / freq
    if dv > hi:
        return hi / dv
    if dv < lo:
        return lo / dv
    return -1.0


class VelocitySmoother:
    """Feed commands (:meth:`command`) and odometry (:meth:`odometry`); call
    :meth:`cycle` at ``smoothing_frequency`` for the twist to publish (``None``: publish
    nothing)."""

    def __init__(self, params: VelocitySmootherParams | None = None) -> None:
        self.params = params or VelocitySmootherParams()
        self.target: Twist2D | None = None
        self.last_command_t = -math.inf
        self.state = Twist2D()
        """The smoothed velocity before the deadband (the open-loop feedback)."""
        self.stopped = True
        self.odom = OdomSmoother(self.params.odom_duration)
        self.rejected = 0

    def command(self, cmd: Twist2D, now: float) -> bool:
        """A new input command; a non-finite one is refused (Nav2 ``validateTwist``)."""
        if not cmd.is_finite():
            self.rejected += 1
            return False
        self.target = cmd
        self.last_command_t = now
        self.stopped = False
        return True

    def odometry(self, twist: Twist2D, now: float) -> None:
        self.odom.add(now, twist)

    def reset(self) -> None:
        self.target, self.state, self.stopped = None, Twist2D(), True
        self.last_command_t = -math.inf

    def cycle(self, now: float) -> Twist2D | None:
        """One smoothing step at ``now``."""
        p = self.params
        if self.target is None or self.stopped:
            return None
        target = self.target
        if now - self.last_command_t > p.velocity_timeout:
            if self.state == Twist2D():
                self.stopped = True
                return None
            target = Twist2D()
        current = self.state  # OPEN_LOOP: the last output
        if p.feedback == "CLOSED_LOOP":
            current = self.odom.twist() or self.state
        cmd = (min(max(target.vx, p.min_velocity[0]), p.max_velocity[0]),
               min(max(target.vy, p.min_velocity[1]), p.max_velocity[1]),
               min(max(target.wz, p.min_velocity[2]), p.max_velocity[2]))
        cur = (current.vx, current.vy, current.wz)
        f = p.smoothing_frequency
        eta = 1.0
        if p.scale_velocities:
            for i in range(3):
                e = _eta(cur[i], cmd[i], p.max_accel[i], p.max_decel[i], f)
                if 0.0 < e < eta:  # the most limiting axis (Nav2 keeps the smallest)
                    eta = e
        out = tuple(_limit(cur[i], cmd[i], p.max_accel[i], p.max_decel[i], f, eta)
                    for i in range(3))
        self.state = Twist2D(*out)
        pub = tuple(0.0 if abs(v) < p.deadband_velocity[i] else v for i, v in enumerate(out))
        return Twist2D(*pub)
