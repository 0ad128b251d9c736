"""The rover's VCU command string: one 12-character ASCII datagram per command.

Layout (``../shared/FIELD-ROBOTS.md``; byte 0 first)::

    byte  0      yaw direction   '1' when angular_z > 0, else '0'
    bytes 1-3    yaw magnitude   |angular_z| in 0.01 rad/s, zero-filled ("045" = 0.45 rad/s)
    byte  4      x direction     '1' when linear_x > 0, else '0'
    bytes 5-8    x magnitude     |linear_x| in 0.001 m/s, zero-filled ("0123" = 0.123 m/s)
    bytes 9-11   LED colour      "100" red (teleop), "001" blue (auto), "010" green (success)

Two ways to compute the magnitudes:

* **compat** reproduces the rover's own arithmetic,
  ``abs(int(round(angular_z, 2) * 100))`` and ``abs(int(round(linear_x, 3) * 1000))``, float
  truncation included: ``round(0.29, 2) * 100`` is 28.999999999999996, so 0.29 rad/s goes
  out as "028" (and Python's ``round`` rounds halves to even: 0.125 -> "012").
* **corrected** (the default) sends the nearest quantum, halves away from zero:
  0.29 -> "029", 0.125 -> "013".

The default is *corrected*: the VCU parses the same format either way, so nothing on the
vehicle changes, while compat truncates up to one quantum towards zero (a systematic
0.01 rad/s under-steer on every command the arithmetic happens to land below).  Compat
exists to reproduce byte for byte what the original stack sent (replaying its logs,
comparing with recordings).  In both modes magnitudes beyond the field (|angular_z| >
9.99 rad/s, |linear_x| > 9.999 m/s) saturate at "999" / "9999" instead of widening the
string, which the VCU would misparse; NaN/inf are refused (:class:`EncodeError`).

:func:`decode_vcu_command` is the vehicle side: it parses strictly (exactly 12 ASCII
digits, direction digits 0/1, a known LED code) and raises :class:`MalformedPacket`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from navstack.drivers.errors import EncodeError, MalformedPacket

__all__ = ["LED_CODES", "VCU_COMMAND_LENGTH", "RoverMode", "VcuCommand", "decode_vcu_command",
           "encode_vcu_command", "vcu_magnitude"]

RoverMode = Literal["teleop", "auto", "success"]
LED_CODES: dict[RoverMode, str] = {"teleop": "100", "auto": "001", "success": "010"}
"""LED colour digits by mode, as the rover's table gives them (red / blue / green)."""
_MODE_BY_LED = {code: mode for mode, code in LED_CODES.items()}
VCU_COMMAND_LENGTH = 12
YAW_SCALE, YAW_DIGITS = 100, 3  # 0.01 rad/s, 3 digits
X_SCALE, X_DIGITS = 1000, 4  # 0.001 m/s, 4 digits
CODEC = "rover VCU command"


@dataclass(frozen=True, slots=True)
class VcuCommand:
    """A decoded VCU command: body twist [m/s, rad/s] and the LED mode."""

    linear_x: float
    angular_z: float
    mode: RoverMode


def vcu_magnitude(value: float, decimals: int, digits: int, compat: bool) -> int:
    """The magnitude field's integer for ``value`` (module docstring), saturated to
    ``digits`` decimal digits."""
    cap = 10 ** digits - 1
    if compat:
        n = abs(int(round(value, decimals) * 10 ** decimals))
    else:
        n = math.floor(abs(value) * 10 ** decimals + 0.5)
    return min(n, cap)


def encode_vcu_command(linear_x: float, angular_z: float, mode: RoverMode = "auto", *,
                       compat: bool = False) -> bytes:
    """The 12-byte ASCII command for the body twist ``(linear_x, angular_z)``.

    >>> encode_vcu_command(0.123, 0.45)
    b'104510123001'
    """
    if not (math.isfinite(linear_x) and math.isfinite(angular_z)):
        raise EncodeError(f"{CODEC}: velocities must be finite, got linear_x={linear_x}, "
                          f"angular_z={angular_z}; refuse NaN/inf before encoding")
    led = LED_CODES.get(mode)
    if led is None:
        raise EncodeError(f"{CODEC}: unknown mode {mode!r}; choose one of "
                          f"{', '.join(map(repr, LED_CODES))}")
    yaw = vcu_magnitude(angular_z, 2, YAW_DIGITS, compat)
    vx = vcu_magnitude(linear_x, 3, X_DIGITS, compat)
    text = (("1" if angular_z > 0 else "0") + str(yaw).zfill(YAW_DIGITS)
            + ("1" if linear_x > 0 else "0") + str(vx).zfill(X_DIGITS) + led)
    return text.encode("ascii")


def decode_vcu_command(data: bytes) -> VcuCommand:
    """Parse a VCU command string (the vehicle side).  Strict: anything but 12 ASCII
    digits with 0/1 direction digits and a known LED code is :class:`MalformedPacket`.

    A '0' direction means the value was <= 0: the magnitude is negated.
    """
    if len(data) != VCU_COMMAND_LENGTH:
        raise MalformedPacket(CODEC, f"expected {VCU_COMMAND_LENGTH} bytes, got {len(data)}",
                              data)
    if not all(0x30 <= b <= 0x39 for b in data):
        raise MalformedPacket(CODEC, "non-digit character", data)
    text = data.decode("ascii")
    if text[0] not in "01" or text[4] not in "01":
        raise MalformedPacket(CODEC, f"direction digits must be 0 or 1, got {text[0]!r} and "
                              f"{text[4]!r}", data)
    mode = _MODE_BY_LED.get(text[9:12])
    if mode is None:
        raise MalformedPacket(CODEC, f"unknown LED code {text[9:12]!r} (known: "
                              f"{', '.join(sorted(_MODE_BY_LED))})", data)
    yaw = int(text[1:4]) / YAW_SCALE
    vx = int(text[5:9]) / X_SCALE
    return VcuCommand(vx if text[4] == "1" else -vx, yaw if text[0] == "1" else -yaw, mode)
