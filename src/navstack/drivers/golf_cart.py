"""The golf cart's steering/speed packet to its Arduino Uno: ``struct.pack('<fi', v, steps)``.

Eight bytes, no header, no checksum (``../shared/FIELD-ROBOTS.md``)::

    bytes 0-3   float32 LE   speed setpoint [km/h] = linear.x * 3.6 (negative: reverse)
    bytes 4-7   int32 LE     steering stepper target [steps] = -int(delta * 497.84)

``delta`` [rad, positive left, REP-103] is clamped to +-0.74 rad before conversion, so
|steps| <= 368; ``int`` truncates toward zero (0.30 rad -> 149.352 -> -149).  The stop
packet is speed 0 with the wheels straight: eight zero bytes.

The steering angle comes from the twist ``(linear.x, angular.z)`` in one of two ways:

* **physical** (default): the bicycle-model angle ``delta = atan(wheel_base * wz / vx)``,
  clamped to +-0.74 -- the steering-rack angle that realises the commanded curvature in
  the kinematic model the planners, MPPI and the simulator use (Rajamani, *Vehicle
  Dynamics and Control*, sec. 2.2; ``control/ackermann.py`` has the same equations).
  With ``|vx| ~ 0`` a car has no curvature to realise: the wheels go straight.
* **compat**: the cart's own conversion, as FIELD-ROBOTS.md describes it -- the
  tan-based Ackermann left and right wheel angles ``atan(L / (R -+ W/2))`` with
  ``R = vx / wz``, each clamped to +-0.74, and the stepper driven to their mean.  The
  cart's source is not public; this is the reconstruction documented in docs/drivers.md.
  It differs from the physical angle by up to ~0.02 rad in tight turns and, where a wheel
  clamps, sends less than the clamped bicycle angle.

:func:`decode_cart_command` is the Arduino side; it rejects a packet of the wrong
length, a non-finite speed, or a speed / step count no cart command can produce (the
plausibility test a byte-slipped stream fails, see :mod:`.framing`).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Literal

from navstack.drivers.errors import EncodeError, MalformedPacket

__all__ = ["CART_COMMAND", "MAX_SPEED_KMH", "MAX_STEERING", "STEPS_PER_RAD", "STOP_PACKET",
           "CartCommand", "SteeringMode", "cart_steering", "decode_cart_command",
           "encode_cart_command", "plausible_cart_command", "steering_to_steps"]

CART_COMMAND = struct.Struct("<fi")
STEPS_PER_RAD = 497.84
MAX_STEERING = 0.74
MAX_SPEED_KMH = 40.0
"""Plausibility bound on a decoded setpoint [km/h] (a golf cart tops out near 25)."""
MAX_STEPS = int(MAX_STEERING * STEPS_PER_RAD)  # 368: the most the encoder sends
STOP_PACKET = CART_COMMAND.pack(0.0, 0)
CODEC = "golf cart command"
SteeringMode = Literal["physical", "compat"]


@dataclass(frozen=True, slots=True)
class CartCommand:
    """A decoded cart packet: the setpoint [km/h] and the stepper target [steps]."""

    speed_kmh: float
    steps: int

    @property
    def speed(self) -> float:
        """Setpoint [m/s]."""
        return self.speed_kmh / 3.6

    @property
    def steering(self) -> float:
        """Steering angle [rad, positive left] the stepper target stands for."""
        return -self.steps / STEPS_PER_RAD


def steering_to_steps(delta: float) -> int:
    """``-int(clamp(delta, +-0.74) * 497.84)``: the cart's stepper target."""
    clamped = max(-MAX_STEERING, min(MAX_STEERING, delta))
    return -int(clamped * STEPS_PER_RAD)


def cart_steering(vx: float, wz: float, wheel_base: float, wheel_separation: float,
                  mode: SteeringMode = "physical") -> float:
    """Steering angle [rad] for the twist ``(vx, wz)`` (module docstring), clamped."""
    if not (math.isfinite(vx) and math.isfinite(wz)):
        raise EncodeError(f"{CODEC}: velocities must be finite, got vx={vx}, wz={wz}")
    if wheel_base <= 0.0 or wheel_separation < 0.0:
        raise EncodeError(f"{CODEC}: wheel_base must be > 0 and wheel_separation >= 0, got "
                          f"{wheel_base} and {wheel_separation}")
    if wz == 0.0:
        return 0.0
    if mode == "physical":
        if abs(vx) < 1e-6:
            return 0.0
        delta = math.atan(wheel_base * wz / vx)
        return max(-MAX_STEERING, min(MAX_STEERING, delta))
    if mode != "compat":
        raise EncodeError(f"{CODEC}: unknown steering mode {mode!r}; use 'physical' or "
                          "'compat'")
    radius = vx / wz
    half = wheel_separation / 2.0
    wheels = []
    for offset in (-half, half):
        d = radius + offset
        angle = math.copysign(math.pi / 2, wheel_base * d) if d == 0.0 else \
            math.atan(wheel_base / d)
        wheels.append(max(-MAX_STEERING, min(MAX_STEERING, angle)))
    return 0.5 * (wheels[0] + wheels[1])


def encode_cart_command(speed: float, steering: float) -> bytes:
    """The 8-byte packet for ``speed`` [m/s] and steering angle ``steering`` [rad].

    >>> encode_cart_command(1.0, 0.30).hex(" ")
    '66 66 66 40 6b ff ff ff'
    """
    if not (math.isfinite(speed) and math.isfinite(steering)):
        raise EncodeError(f"{CODEC}: speed and steering must be finite, got {speed}, "
                          f"{steering}")
    return CART_COMMAND.pack(speed * 3.6, steering_to_steps(steering))


def decode_cart_command(data: bytes) -> CartCommand:
    """Parse one 8-byte packet (the Arduino side); :class:`MalformedPacket` otherwise."""
    if len(data) != CART_COMMAND.size:
        raise MalformedPacket(CODEC, f"expected {CART_COMMAND.size} bytes, got {len(data)}",
                              data)
    speed_kmh, steps = CART_COMMAND.unpack(data)
    if not math.isfinite(speed_kmh):
        raise MalformedPacket(CODEC, f"speed is {speed_kmh}", data)
    if abs(speed_kmh) > MAX_SPEED_KMH:
        raise MalformedPacket(CODEC, f"speed {speed_kmh:.3g} km/h beyond +-{MAX_SPEED_KMH}",
                              data)
    if abs(steps) > MAX_STEPS:
        raise MalformedPacket(CODEC, f"steering target {steps} steps beyond +-{MAX_STEPS} "
                              f"(0.74 rad)", data)
    return CartCommand(float(speed_kmh), int(steps))


def plausible_cart_command(window: bytes) -> bool:
    """Whether 8 bytes decode as a cart command (the framer's resynchronisation test)."""
    try:
        decode_cart_command(window)
    except MalformedPacket:
        return False
    return True
