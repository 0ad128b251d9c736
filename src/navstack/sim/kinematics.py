"""Planar robot kinematics for the simulator: differential drive, omnidirectional, Ackermann.

Each model turns a body-frame velocity command (``Twist2D``, REP-103: x forward, y left,
yaw counter-clockwise) into the next :class:`RobotState` after ``dt`` seconds:

1. the command is clamped to the velocity limits (Nav2 ``max_vel_x``/``min_vel_x``/
   ``max_vel_y``/``max_vel_theta`` semantics),
2. each velocity component moves toward its clamped target by at most ``acc * dt``
   (``acc_lim_x``/``acc_lim_y``/``acc_lim_theta``), for Ackermann the steering angle moves
   toward its target by at most ``max_steering_rate * dt``,
3. the resulting velocities are held constant over ``dt`` (zero-order hold) and the pose is
   integrated *exactly*: a constant body twist ``(vx, vy, wz)`` traces a circular arc, so
   the result does not depend on how a run is cut into steps.

The Ackermann model is the kinematic bicycle model with ``base_link`` on the rear axle
(the reference point Nav2's Smac Hybrid-A* and MPPI ``AckermannConstraints`` assume):
``yaw_rate = vx * tan(delta) / wheelbase``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import ConfigDict, Field, ValidationInfo, field_validator

from navstack.core.errors import InvalidMessage, SimulationError
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import Pose2D, Twist2D
from navstack.core.params import Params

STRAIGHT_EPS = 1e-9
"""|wz| below which the pose integration uses the straight-line limit [rad/s]."""
STEER_HOLD_EPS = 1e-6
"""|vx| below which an Ackermann command carries no curvature; the steering is held [m/s]."""


@dataclass(frozen=True, slots=True)
class RobotState:
    """True planar state of a simulated robot.

    ``x, y`` [m] and ``yaw`` [rad] of ``base_link`` in the world (``map``) frame;
    ``vx, vy`` [m/s] and ``wz`` [rad/s] in the body frame; ``steering_angle`` [rad] is
    the bicycle-model front-wheel angle (0 for non-Ackermann robots).
    """

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0
    steering_angle: float = 0.0

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    @property
    def twist(self) -> Twist2D:
        return Twist2D(self.vx, self.vy, self.wz)

    @staticmethod
    def at(pose: Pose2D) -> RobotState:
        """A robot at rest at ``pose``."""
        return RobotState(pose.x, pose.y, normalize_angle(pose.theta))

    def is_finite(self) -> bool:
        # one isfinite on the sum: NaN and inf propagate through addition (hot path)
        return math.isfinite(self.x + self.y + self.yaw + self.vx + self.vy + self.wz
                             + self.steering_angle) or all(
            math.isfinite(v) for v in (self.x, self.y, self.yaw, self.vx, self.vy, self.wz,
                                       self.steering_angle))


def integrate_pose(x: float, y: float, yaw: float, vx: float, vy: float, wz: float,
                   dt: float) -> tuple[float, float, float]:
    """Pose after holding the body twist ``(vx, vy, wz)`` constant for ``dt`` seconds.

    Exact for a constant twist: the world velocity ``R(yaw + wz t) [vx, vy]`` integrates to
    ``dx = vx S - vy C``, ``dy = vx C + vy S`` with ``S = (sin yaw1 - sin yaw0) / wz`` and
    ``C = (cos yaw0 - cos yaw1) / wz``.  Written with the mid-arc heading and
    ``sin(h) / h`` (``h = wz dt / 2``), which is well conditioned as ``wz -> 0``; for
    ``|wz| < 1e-9`` the straight-line limit ``sin(h) / h = 1`` is used.
    """
    h = 0.5 * wz * dt
    k = dt if abs(wz) < STRAIGHT_EPS else dt * math.sin(h) / h
    mid = yaw + h
    S = k * math.cos(mid)
    C = k * math.sin(mid)
    return x + vx * S - vy * C, y + vx * C + vy * S, normalize_angle(yaw + wz * dt)


def approach(current: float, target: float, max_delta: float) -> float:
    """Move ``current`` toward ``target`` by at most ``max_delta`` (>= 0)."""
    delta = target - current
    if delta > max_delta:
        return current + max_delta
    if delta < -max_delta:
        return current - max_delta
    return target


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


class KinematicModel(ABC):
    """Base of the kinematic models: validation, limits, exact pose integration."""

    holonomic: bool = False

    def step(self, state: RobotState, cmd: Twist2D, dt: float) -> RobotState:
        """The state after applying ``cmd`` (body frame) for ``dt`` seconds.

        Raises ``InvalidMessage`` for a NaN/inf command or state (the caller should have
        rejected it; this guard keeps a NaN from ever entering the simulation) and
        ``SimulationError`` for a negative or non-finite ``dt``.
        """
        if not cmd.is_finite():
            raise InvalidMessage(
                f"velocity command must be finite, got vx={cmd.vx}, vy={cmd.vy}, wz={cmd.wz}; "
                "reject NaN/inf commands before they reach the robot model")
        if not state.is_finite():
            raise InvalidMessage(f"robot state must be finite, got {state}")
        if not math.isfinite(dt) or dt < 0.0:
            raise SimulationError(f"time step dt must be finite and >= 0, got {dt}")
        if dt == 0.0:
            return state
        vx, vy, wz, steer = self._velocities(state, cmd, dt)
        x, y, yaw = integrate_pose(state.x, state.y, state.yaw, vx, vy, wz, dt)
        return RobotState(x, y, yaw, vx, vy, wz, steer)

    @abstractmethod
    def _velocities(self, state: RobotState, cmd: Twist2D,
                    dt: float) -> tuple[float, float, float, float]:
        """Limited ``(vx, vy, wz, steering_angle)`` held over the next ``dt``."""

    @abstractmethod
    def clamp(self, cmd: Twist2D) -> Twist2D:
        """``cmd`` with each component clamped to the velocity limits (no acceleration)."""


class DiffDrive(KinematicModel):
    """Differential drive (unicycle): ``vy`` is always 0."""

    def __init__(self, max_vx: float, min_vx: float, max_wz: float, max_ax: float,
                 max_wz_acc: float) -> None:
        _check_limits(max_vx=max_vx, min_vx=min_vx, max_wz=max_wz, max_ax=max_ax,
                      max_wz_acc=max_wz_acc)
        self.max_vx, self.min_vx, self.max_wz = max_vx, min_vx, max_wz
        self.max_ax, self.max_wz_acc = max_ax, max_wz_acc

    def clamp(self, cmd: Twist2D) -> Twist2D:
        return Twist2D(_clamp(cmd.vx, self.min_vx, self.max_vx), 0.0,
                       _clamp(cmd.wz, -self.max_wz, self.max_wz))

    def _velocities(self, state: RobotState, cmd: Twist2D,
                    dt: float) -> tuple[float, float, float, float]:
        target = self.clamp(cmd)
        return (approach(state.vx, target.vx, self.max_ax * dt), 0.0,
                approach(state.wz, target.wz, self.max_wz_acc * dt), 0.0)


class Omni(KinematicModel):
    """Holonomic base (mecanum / omni wheels): ``vx``, ``vy``, ``wz`` limited independently."""

    holonomic = True

    def __init__(self, max_vx: float, min_vx: float, max_vy: float, max_wz: float,
                 max_ax: float, max_ay: float, max_wz_acc: float) -> None:
        _check_limits(max_vx=max_vx, min_vx=min_vx, max_vy=max_vy, max_wz=max_wz,
                      max_ax=max_ax, max_ay=max_ay, max_wz_acc=max_wz_acc)
        self.max_vx, self.min_vx, self.max_vy, self.max_wz = max_vx, min_vx, max_vy, max_wz
        self.max_ax, self.max_ay, self.max_wz_acc = max_ax, max_ay, max_wz_acc

    def clamp(self, cmd: Twist2D) -> Twist2D:
        return Twist2D(_clamp(cmd.vx, self.min_vx, self.max_vx),
                       _clamp(cmd.vy, -self.max_vy, self.max_vy),
                       _clamp(cmd.wz, -self.max_wz, self.max_wz))

    def _velocities(self, state: RobotState, cmd: Twist2D,
                    dt: float) -> tuple[float, float, float, float]:
        target = self.clamp(cmd)
        return (approach(state.vx, target.vx, self.max_ax * dt),
                approach(state.vy, target.vy, self.max_ay * dt),
                approach(state.wz, target.wz, self.max_wz_acc * dt), 0.0)


class Ackermann(KinematicModel):
    """Car-like kinematic bicycle model, ``base_link`` on the rear axle.

    The command's curvature ``wz / vx`` becomes the steering target
    ``delta = atan(wheelbase * wz / vx)`` (held at the current angle when ``|vx|`` is ~0,
    since a car cannot turn in place), clamped to ``+-max_steering_angle`` and
    rate-limited by ``max_steering_rate``.  The yaw rate then follows from the actual
    speed and steering: ``wz = vx * tan(delta) / wheelbase``.
    """

    def __init__(self, wheelbase: float, max_steering_angle: float, max_steering_rate: float,
                 max_vx: float, min_vx: float, max_ax: float) -> None:
        _check_limits(wheelbase=wheelbase, max_steering_angle=max_steering_angle,
                      max_steering_rate=max_steering_rate, max_vx=max_vx, min_vx=min_vx,
                      max_ax=max_ax)
        if max_steering_angle >= 0.5 * math.pi:
            raise SimulationError(
                f"max_steering_angle must be < pi/2, got {max_steering_angle}")
        self.wheelbase, self.max_steering_angle = wheelbase, max_steering_angle
        self.max_steering_rate, self.max_vx, self.min_vx = max_steering_rate, max_vx, min_vx
        self.max_ax = max_ax

    @property
    def min_turning_radius(self) -> float:
        """Smallest turning radius of ``base_link`` [m] (Smac ``minimum_turning_radius``)."""
        return self.wheelbase / math.tan(self.max_steering_angle)

    def steering_target(self, cmd: Twist2D, current: float) -> float:
        """Clamped steering angle realising the command's curvature (``current`` if vx ~ 0)."""
        if abs(cmd.vx) < STEER_HOLD_EPS:
            return current
        delta = math.atan(self.wheelbase * cmd.wz / cmd.vx)
        return _clamp(delta, -self.max_steering_angle, self.max_steering_angle)

    def clamp(self, cmd: Twist2D) -> Twist2D:
        vx = _clamp(cmd.vx, self.min_vx, self.max_vx)
        if abs(cmd.vx) < STEER_HOLD_EPS:
            return Twist2D(vx, 0.0, 0.0)
        delta = self.steering_target(cmd, 0.0)
        return Twist2D(vx, 0.0, vx * math.tan(delta) / self.wheelbase)

    def _velocities(self, state: RobotState, cmd: Twist2D,
                    dt: float) -> tuple[float, float, float, float]:
        vx = approach(state.vx, _clamp(cmd.vx, self.min_vx, self.max_vx), self.max_ax * dt)
        target = self.steering_target(cmd, state.steering_angle)
        steer = approach(state.steering_angle, target, self.max_steering_rate * dt)
        steer = _clamp(steer, -self.max_steering_angle, self.max_steering_angle)
        return vx, 0.0, vx * math.tan(steer) / self.wheelbase, steer


def _check_limits(**limits: float) -> None:
    for name, value in limits.items():
        if math.isnan(value):
            raise SimulationError(f"kinematic limit {name} is NaN")
        if name == "min_vx":
            if value > limits["max_vx"]:
                raise SimulationError(f"min_vx ({value}) must be <= max_vx ({limits['max_vx']})")
        elif name.startswith("max_v") or name == "max_wz":
            if value < 0.0:
                raise SimulationError(f"{name} must be >= 0, got {value}")
        elif value <= 0.0:
            raise SimulationError(f"{name} must be > 0, got {value}")


# --- parameters ---------------------------------------------------------------------------
KinematicsType = Literal["diff_drive", "omni", "ackermann"]
_TYPE_ALIASES = {
    "diffdrive": "diff_drive", "differential": "diff_drive", "unicycle": "diff_drive",
    "omni": "omni", "holonomic": "omni", "mecanum": "omni", "ackermann": "ackermann",
    "carlike": "ackermann", "bicycle": "ackermann",
}


class KinematicsParams(Params):
    """Drive type and limits of a robot base (``robot.kinematics`` in a robot profile).

    Velocity/acceleration names and defaults follow Nav2 DWB (``max_vel_x`` 0.26,
    ``max_vel_theta`` 1.0, ``acc_lim_x`` 2.5, ``acc_lim_theta`` 3.2, ...), except that
    ``min_vel_x`` defaults to ``-max_vel_x``: here it is the *base's* limit, and Nav2's
    BackUp behavior needs a base that can reverse.  ``wheelbase``/``wheel_separation`` are
    the ros2_control ackermann/diff_drive controller names.  ``type`` also accepts MPPI's
    ``motion_model`` spellings (``DiffDrive``, ``Omni``, ``Ackermann``).  For ``ackermann``
    the yaw rate follows from speed and steering, so ``max_vel_theta``/``acc_lim_theta``
    are controller-side limits only and do not constrain the simulated base.
    """

    model_config = ConfigDict(allow_inf_nan=False)

    type: KinematicsType = "diff_drive"
    max_vel_x: float = Field(default=0.26, ge=0.0, description="forward limit [m/s]")
    min_vel_x: float | None = Field(
        default=None, description="reverse limit [m/s] (< 0 to reverse); default -max_vel_x")
    max_vel_y: float = Field(default=0.0, ge=0.0, validate_default=True,
                             description="|vy| limit [m/s], omni only")
    max_vel_theta: float = Field(default=1.0, ge=0.0, description="|wz| limit [rad/s]")
    acc_lim_x: float = Field(default=2.5, gt=0.0, description="[m/s^2]")
    acc_lim_y: float = Field(default=0.0, ge=0.0, validate_default=True,
                             description="[m/s^2], omni only")
    acc_lim_theta: float = Field(default=3.2, gt=0.0, description="[rad/s^2]")
    wheelbase: float = Field(default=0.0, ge=0.0, validate_default=True,
                             description="axle distance [m], ackermann")
    wheel_separation: float = Field(default=0.0, ge=0.0, description="track width [m]")
    max_steering_angle: float = Field(default=0.6, gt=0.0, lt=0.5 * math.pi,
                                      description="[rad], ackermann")
    max_steering_rate: float = Field(default=1.0, gt=0.0, description="[rad/s], ackermann")

    @field_validator("type", mode="before")
    @classmethod
    def _type_alias(cls, value: Any) -> Any:
        if isinstance(value, str):
            return _TYPE_ALIASES.get(value.lower().replace("_", "").replace("-", ""), value)
        return value

    @field_validator("min_vel_x")
    @classmethod
    def _min_vel(cls, value: float | None, info: ValidationInfo) -> float | None:
        max_vx = info.data.get("max_vel_x")
        if value is not None and max_vx is not None and value > max_vx:
            raise ValueError(f"min_vel_x must be <= max_vel_x ({max_vx})")
        return value

    @field_validator("max_vel_y", "acc_lim_y")
    @classmethod
    def _omni_only(cls, value: float, info: ValidationInfo) -> float:
        kind = info.data.get("type")
        if kind == "omni" and value <= 0.0:
            raise ValueError(f"{info.field_name} must be > 0 for an omni robot")
        if kind in ("diff_drive", "ackermann") and info.field_name == "max_vel_y" and value:
            raise ValueError(f"a {kind} robot cannot move sideways: remove max_vel_y or "
                             "set kinematics.type to omni")
        return value

    @field_validator("wheelbase")
    @classmethod
    def _wheelbase(cls, value: float, info: ValidationInfo) -> float:
        if info.data.get("type") == "ackermann" and value <= 0.0:
            raise ValueError("wheelbase must be > 0 for an ackermann robot")
        return value

    @property
    def min_vx(self) -> float:
        """Effective reverse limit [m/s] (``min_vel_x`` or ``-max_vel_x``)."""
        return -self.max_vel_x if self.min_vel_x is None else self.min_vel_x


def make_model(params: KinematicsParams) -> KinematicModel:
    """Build the kinematic model named by ``params.type``."""
    p = params
    if p.type == "diff_drive":
        return DiffDrive(p.max_vel_x, p.min_vx, p.max_vel_theta, p.acc_lim_x, p.acc_lim_theta)
    if p.type == "omni":
        return Omni(p.max_vel_x, p.min_vx, p.max_vel_y, p.max_vel_theta, p.acc_lim_x,
                    p.acc_lim_y, p.acc_lim_theta)
    return Ackermann(p.wheelbase, p.max_steering_angle, p.max_steering_rate, p.max_vel_x,
                     p.min_vx, p.acc_lim_x)
