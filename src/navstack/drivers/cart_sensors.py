"""The golf cart's sensor Arduino (Mega, 115200 baud): one ASCII line per sample.

The cart's line format is not documented (FIELD-ROBOTS.md: "lines carry calibrated IMU
data, averaged wheel velocity and elapsed time"), so navstack defines one, NMEA-style so
a terminal shows it and a checksum catches line noise::

    $CART,<seq>,<t_ms>,<pulses>,<v>,<ax>,<ay>,<az>,<gx>,<gy>,<gz>,<mx>,<my>,<mz>*HH\\r\\n

    seq      uint16 sample counter, wraps 65535 -> 0 (a gap = lost lines)
    t_ms     uint32 Arduino millis() at the sample [ms] (wraps after 49.7 days)
    pulses   uint32 wheel pulses since boot (4 per revolution, no direction)
    v        averaged wheel speed [m/s], >= 0 (pulse period, see below), 3 decimals
    ax ay az accelerometer [m/s^2], 3 decimals      } MPU9250, sensor frame,
    gx gy gz gyroscope [rad/s], 4 decimals          } calibrated on the Arduino
    mx my mz magnetometer [uT], 2 decimals          } unless the driver is told to
    HH       XOR of every byte between '$' and '*', two uppercase hex digits

The wheel: radius 0.225 m, 4 pulses per revolution, so one pulse is
``2 pi 0.225 / 4 = 0.3534 m``.  With so few pulses the Arduino reports the speed from
the pulse *period* (0.3534 m / time between the last two pulses; while no new pulse
arrives, 0.3534 m / time since the last one, and 0 after ``stop_timeout``), which is
what :class:`WheelPulseSpeed` computes.  The line carries no direction: the driver
signs the speed with the commanded direction.

IMU calibration is affine: ``calibrated = A (raw - b)`` with ``A`` a 3x3 matrix and
``b`` an offset (:func:`calibrate`), for the accelerometer and the magnetometer.

:func:`parse_sensor_line` is strict: the exact field count, integer fields as digits
only, decimals as plain decimals (no exponent, no ``nan``/``inf``), the checksum, and
physical ranges (MPU9250: |a| <= 16 g, |w| <= 2000 deg/s, |m| <= 4900 uT; v <= 30 m/s).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.drivers.errors import EncodeError, MalformedPacket

__all__ = ["MAX_LINE", "PULSES_PER_REV", "PULSE_DISTANCE", "WHEEL_RADIUS", "CartSensorSample",
           "WheelPulseSpeed", "calibrate", "encode_sensor_line", "nmea_checksum",
           "parse_sensor_line"]

PULSES_PER_REV = 4
WHEEL_RADIUS = 0.225
PULSE_DISTANCE = 2.0 * math.pi * WHEEL_RADIUS / PULSES_PER_REV
MAX_LINE = 160
"""Longest valid line [bytes]; a longer one is noise (the framer drops it)."""
CODEC = "cart sensor line"
_TAG = "CART"
_INT = re.compile(r"\d{1,10}")
_DEC = re.compile(r"-?\d{1,6}(\.\d{1,6})?")
_G = 9.80665
_LIMITS = {"v": 30.0, "a": 16 * _G, "g": math.radians(2000.0), "m": 4900.0}


@dataclass(frozen=True, slots=True)
class CartSensorSample:
    """One decoded line (units of the module docstring; vectors in the sensor frame)."""

    seq: int
    t_ms: int
    pulses: int
    speed: float
    accel: tuple[float, float, float]
    gyro: tuple[float, float, float]
    mag_ut: tuple[float, float, float]


def nmea_checksum(body: str) -> str:
    """XOR of the bytes of ``body`` as two uppercase hex digits (NMEA 0183)."""
    value = 0
    for ch in body.encode("ascii"):
        value ^= ch
    return f"{value:02X}"


def _fmt(values: Sequence[float], decimals: int) -> list[str]:
    out = []
    for v in values:
        if not math.isfinite(v):
            raise EncodeError(f"{CODEC}: cannot encode non-finite value {v}")
        text = f"{v:.{decimals}f}"
        out.append("0." + "0" * decimals if text.lstrip("-").strip("0.") == "" else text)
    return out


def encode_sensor_line(sample: CartSensorSample) -> bytes:
    """The line for ``sample`` including checksum and CR LF (what the Arduino prints)."""
    fields = [_TAG, str(sample.seq % 65536), str(sample.t_ms % 2 ** 32),
              str(sample.pulses % 2 ** 32), *_fmt([sample.speed], 3),
              *_fmt(sample.accel, 3), *_fmt(sample.gyro, 4), *_fmt(sample.mag_ut, 2)]
    body = ",".join(fields)
    return f"${body}*{nmea_checksum(body)}\r\n".encode("ascii")


def parse_sensor_line(line: bytes) -> CartSensorSample:
    """Decode one line (with or without the CR LF); :class:`MalformedPacket` otherwise."""
    if len(line) > MAX_LINE:
        raise MalformedPacket(CODEC, f"line longer than {MAX_LINE} bytes", line)
    try:
        text = line.decode("ascii").rstrip("\r\n")
    except UnicodeDecodeError:
        raise MalformedPacket(CODEC, "non-ASCII bytes", line) from None
    if not text.startswith("$") or text.count("*") != 1:
        raise MalformedPacket(CODEC, "expected '$...*HH'", text)
    body, checksum = text[1:].split("*")
    if len(checksum) != 2 or checksum.upper() != checksum or \
            not all(c in "0123456789ABCDEF" for c in checksum):
        raise MalformedPacket(CODEC, f"checksum must be two uppercase hex digits, got "
                              f"{checksum!r}", text)
    if nmea_checksum(body) != checksum:
        raise MalformedPacket(CODEC, f"checksum mismatch (line says {checksum}, bytes give "
                              f"{nmea_checksum(body)})", text)
    fields = body.split(",")
    if fields[0] != _TAG:
        raise MalformedPacket(CODEC, f"unknown sentence {fields[0]!r} (expected {_TAG!r})", text)
    if len(fields) != 14:
        raise MalformedPacket(CODEC, f"expected 13 values after {_TAG}, got {len(fields) - 1}",
                              text)
    ints = []
    for name, value, bound in (("seq", fields[1], 65535), ("t_ms", fields[2], 2 ** 32 - 1),
                               ("pulses", fields[3], 2 ** 32 - 1)):
        if not _INT.fullmatch(value) or int(value) > bound:
            raise MalformedPacket(CODEC, f"{name} must be an integer in [0, {bound}], got "
                                  f"{value!r}", text)
        ints.append(int(value))
    decs = []
    for i, value in enumerate(fields[4:]):
        if not _DEC.fullmatch(value):
            raise MalformedPacket(CODEC, f"field {i + 4} must be a plain decimal, got "
                                  f"{value!r}", text)
        decs.append(float(value))
    speed, accel, gyro, mag = decs[0], decs[1:4], decs[4:7], decs[7:10]
    for kind, values in (("v", [speed]), ("a", accel), ("g", gyro), ("m", mag)):
        if any(abs(v) > _LIMITS[kind] for v in values):
            raise MalformedPacket(CODEC, f"{kind} value out of range (|x| <= "
                                  f"{_LIMITS[kind]:.4g}): {values}", text)
    if speed < 0.0:
        raise MalformedPacket(CODEC, f"wheel speed must be >= 0, got {speed}", text)
    return CartSensorSample(ints[0], ints[1], ints[2], speed, (accel[0], accel[1], accel[2]),
                            (gyro[0], gyro[1], gyro[2]), (mag[0], mag[1], mag[2]))


def calibrate(raw: ArrayLike, A: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Affine IMU calibration ``A (raw - b)`` (``raw``: (3,) or (N, 3))."""
    raw_arr = np.asarray(raw, dtype=np.float64)
    A_arr = np.asarray(A, dtype=np.float64).reshape(3, 3)
    b_arr = np.asarray(b, dtype=np.float64).reshape(3)
    return np.asarray((raw_arr - b_arr) @ A_arr.T)


class WheelPulseSpeed:
    """The Arduino's averaged wheel speed from pulse edges (module docstring): feed it
    the cumulative pulse count at each sample time; ``speed`` is the pulse-period speed."""

    def __init__(self, pulse_distance: float = PULSE_DISTANCE, stop_timeout: float = 2.0
                 ) -> None:
        self.pulse_distance = pulse_distance
        self.stop_timeout = stop_timeout
        self._count: int | None = None
        self._last_edge: float | None = None
        self._period = math.inf

    def update(self, t: float, pulses: int) -> float:
        """Speed [m/s] at time ``t`` [s] given the cumulative ``pulses`` then."""
        if self._count is None:
            self._count = pulses
            self._last_edge = t
            return 0.0
        assert self._last_edge is not None
        new = pulses - self._count
        if new > 0:
            self._period = (t - self._last_edge) / new if t > self._last_edge else self._period
            self._last_edge = t
            self._count = pulses
        since = t - self._last_edge
        if since > self.stop_timeout:
            self._period = math.inf
            return 0.0
        period = max(self._period, since)
        return self.pulse_distance / period if math.isfinite(period) and period > 0 else 0.0
