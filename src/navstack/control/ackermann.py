"""cmd_vel -> Ackermann steering: the conversion the golf cart's steering Arduino runs.

A car-like base takes a body twist ``(vx, wz)`` (``geometry_msgs/Twist`` on ``/cmd_vel``,
what every Nav2 controller publishes) and must turn it into a speed and two front-wheel
angles.  With ``base_link`` on the rear axle the turn radius of the rear-axle centre is
``R = vx / wz``; the inner and outer front wheels lie ``wheel_separation / 2`` inside and
outside that circle, ``wheel_base`` ahead of the rear axle, so under the Ackermann
condition (all wheels turn about one centre; Rajamani, *Vehicle Dynamics and Control*,
2nd ed., 2012, sec. 2.2):

    tan(delta_left)   = wheel_base / (R - wheel_separation / 2)
    tan(delta_right)  = wheel_base / (R + wheel_separation / 2)
    tan(delta_center) = wheel_base / R            (the bicycle-model angle)

Positive angles steer left (REP-103).  Every angle is clamped to
``+-max_steering_angle`` (the cart's 0.74 rad mechanical limit); when the inner wheel hits
the limit the others are recomputed for the radius that angle allows, so the three stay
consistent.  A command that asks for a turn with no forward speed cannot be executed by a
car: it returns straight wheels and ``feasible=False`` rather than an arbitrary angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from navstack.core.errors import ConfigError

#: |vx| [m/s] below which a command carries no curvature (steering is not defined)
MIN_SPEED = 1e-6


@dataclass(frozen=True)
class SteeringCommand:
    """Wheel angles [rad] (left, right front wheels and the bicycle-model centre angle),
    the speed [m/s] to drive, and whether the requested curvature was reachable."""

    left: float
    right: float
    center: float
    speed: float
    feasible: bool


def ackermann_steering(vx: float, wz: float, wheel_base: float, wheel_separation: float,
                       max_steering_angle: float = 0.74) -> SteeringCommand:
    """Front-wheel angles for the body twist ``(vx, wz)`` (module docstring).

    Raises :class:`ConfigError` for a non-positive ``wheel_base`` or
    ``max_steering_angle``, or a ``wheel_separation`` that is negative.
    """
    if wheel_base <= 0.0:
        raise ConfigError(f"must be positive, got {wheel_base}", key_path="wheel_base")
    if wheel_separation < 0.0:
        raise ConfigError(f"must not be negative, got {wheel_separation}",
                          key_path="wheel_separation")
    if not 0.0 < max_steering_angle < math.pi / 2:
        raise ConfigError(f"must be in (0, pi/2), got {max_steering_angle}",
                          key_path="max_steering_angle")
    if wz == 0.0:
        return SteeringCommand(0.0, 0.0, 0.0, vx, True)
    if abs(vx) < MIN_SPEED:
        return SteeringCommand(0.0, 0.0, 0.0, 0.0, False)
    radius = vx / wz  # signed: > 0 turns left (when driving forward)
    half = wheel_separation / 2.0
    # the inner wheel turns most; the tightest radius it allows
    min_radius = wheel_base / math.tan(max_steering_angle) + half
    feasible = abs(radius) >= min_radius
    if not feasible:
        radius = math.copysign(min_radius, radius)
    left = math.atan(wheel_base / (radius - half))
    right = math.atan(wheel_base / (radius + half))
    center = math.atan(wheel_base / radius)
    return SteeringCommand(left, right, center, vx, feasible)
