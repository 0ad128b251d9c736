"""What the rover's VCU sends back over UDP: little-endian binary packets, one per datagram.

FIELD-ROBOTS.md gives one fact about the original GNSS packet -- course over ground is
field index 3 -- and says the rest is undocumented.  navstack defines the layout below
(keeping COG at index 3) and a second packet for the VCU's odometry; datagrams keep
packet boundaries, so the length tells them apart (40 vs 30 bytes) and the odometry
packet also starts with the magic ``b"RVOD"``.

GNSS packet, ``struct '<ddfffffBBH'`` (40 bytes)::

    index  field                         type   unit
    0      latitude                      f64    deg (WGS84, + north)
    1      longitude                     f64    deg (+ east)
    2      altitude                      f32    m above the ellipsoid
    3      course over ground            f32    deg, clockwise from true north, [0, 360)
    4      speed over ground             f32    m/s
    5      horizontal accuracy (1 sigma) f32    m
    6      vertical accuracy (1 sigma)   f32    m
    7      fix type                      u8     0 none, 1 dead reckoning, 2 2-D, 3 3-D,
                                                4 GNSS + DR, 5 time only (UBX fixType)
    8      satellites used               u8
    9      sequence                      u16    wraps 65535 -> 0

Odometry packet, ``struct '<4sHIffffBxxx'`` (30 bytes)::

    0  magic b"RVOD" | 1 sequence u16 | 2 VCU time u32 [ms] | 3 left track speed f32 [m/s]
    4  right track speed f32 [m/s] | 5 yaw rate f32 [rad/s] (VCU gyro, + left)
    6  forward acceleration f32 [m/s^2] | 7 status u8 (bit 0 e-stop pressed,
    bit 1 autonomous mode, bit 2 motor fault) | 3 pad bytes

Every decode checks the length, finiteness and physical ranges and raises
:class:`MalformedPacket` naming the field.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from navstack.drivers.errors import EncodeError, MalformedPacket

__all__ = ["GNSS_PACKET", "ODOMETRY_MAGIC", "ODOMETRY_PACKET", "RoverGnssPacket",
           "RoverOdometryPacket", "decode_rover_gnss", "decode_rover_odometry",
           "decode_rover_telemetry", "encode_rover_gnss", "encode_rover_odometry"]

GNSS_PACKET = struct.Struct("<ddfffffBBH")
ODOMETRY_PACKET = struct.Struct("<4sHIffffBxxx")
ODOMETRY_MAGIC = b"RVOD"
COURSE_FIELD = 3
STATUS_ESTOP, STATUS_AUTONOMOUS, STATUS_MOTOR_FAULT = 1, 2, 4
MAX_TRACK_SPEED = 10.0
MAX_YAW_RATE = 20.0
MAX_ACCEL = 50.0


@dataclass(frozen=True, slots=True)
class RoverGnssPacket:
    """The rover's GNSS packet (fields in layout order, units of the module docstring)."""

    latitude: float
    longitude: float
    altitude: float
    course_deg: float
    speed: float
    h_acc: float
    v_acc: float
    fix_type: int
    satellites: int
    seq: int


@dataclass(frozen=True, slots=True)
class RoverOdometryPacket:
    """The VCU's odometry packet."""

    seq: int
    t_ms: int
    left_speed: float
    right_speed: float
    yaw_rate: float
    accel_x: float
    status: int

    @property
    def estop(self) -> bool:
        return bool(self.status & STATUS_ESTOP)


def encode_rover_gnss(p: RoverGnssPacket) -> bytes:
    values = (p.latitude, p.longitude, p.altitude, p.course_deg, p.speed, p.h_acc, p.v_acc)
    if not all(math.isfinite(v) for v in values):
        raise EncodeError(f"rover GNSS packet: non-finite field in {values}")
    return GNSS_PACKET.pack(*values, p.fix_type, p.satellites, p.seq % 65536)


def encode_rover_odometry(p: RoverOdometryPacket) -> bytes:
    values = (p.left_speed, p.right_speed, p.yaw_rate, p.accel_x)
    if not all(math.isfinite(v) for v in values):
        raise EncodeError(f"rover odometry packet: non-finite field in {values}")
    return ODOMETRY_PACKET.pack(ODOMETRY_MAGIC, p.seq % 65536, p.t_ms % 2 ** 32, *values,
                                p.status)


def decode_rover_gnss(data: bytes) -> RoverGnssPacket:
    codec = "rover GNSS packet"
    if len(data) != GNSS_PACKET.size:
        raise MalformedPacket(codec, f"expected {GNSS_PACKET.size} bytes, got {len(data)}", data)
    p = RoverGnssPacket(*GNSS_PACKET.unpack(data))
    names = ("latitude", "longitude", "altitude", "course_deg", "speed", "h_acc", "v_acc")
    for name in names:
        if not math.isfinite(getattr(p, name)):
            raise MalformedPacket(codec, f"{name} is {getattr(p, name)}", data)
    checks = ((abs(p.latitude) <= 90.0, "latitude outside [-90, 90]"),
              (abs(p.longitude) <= 180.0, "longitude outside [-180, 180]"),
              (-1000.0 <= p.altitude <= 20000.0, "altitude outside [-1000, 20000] m"),
              (0.0 <= p.course_deg < 360.0, "course over ground outside [0, 360)"),
              (0.0 <= p.speed <= 100.0, "speed over ground outside [0, 100] m/s"),
              (0.0 <= p.h_acc <= 1e6 and 0.0 <= p.v_acc <= 1e6, "accuracy outside [0, 1e6] m"),
              (p.fix_type <= 5, f"fix type {p.fix_type} (valid 0..5)"))
    for ok, reason in checks:
        if not ok:
            raise MalformedPacket(codec, reason, data)
    return p


def decode_rover_odometry(data: bytes) -> RoverOdometryPacket:
    codec = "rover odometry packet"
    if len(data) != ODOMETRY_PACKET.size:
        raise MalformedPacket(codec, f"expected {ODOMETRY_PACKET.size} bytes, got {len(data)}",
                              data)
    magic, seq, t_ms, left, right, yaw, acc, status = ODOMETRY_PACKET.unpack(data)
    if magic != ODOMETRY_MAGIC:
        raise MalformedPacket(codec, f"magic {magic!r} is not {ODOMETRY_MAGIC!r}", data)
    for name, value, bound in (("left_speed", left, MAX_TRACK_SPEED),
                               ("right_speed", right, MAX_TRACK_SPEED),
                               ("yaw_rate", yaw, MAX_YAW_RATE), ("accel_x", acc, MAX_ACCEL)):
        if not math.isfinite(value) or abs(value) > bound:
            raise MalformedPacket(codec, f"{name} {value} not finite or beyond +-{bound}", data)
    if status > 7:
        raise MalformedPacket(codec, f"status {status:#04x} has undefined bits set", data)
    return RoverOdometryPacket(seq, t_ms, left, right, yaw, acc, status)


def decode_rover_telemetry(data: bytes) -> RoverGnssPacket | RoverOdometryPacket:
    """Either packet, told apart by length (and the odometry magic)."""
    if len(data) == ODOMETRY_PACKET.size:
        return decode_rover_odometry(data)
    if len(data) == GNSS_PACKET.size:
        return decode_rover_gnss(data)
    raise MalformedPacket("rover telemetry", f"length {len(data)} matches neither the GNSS "
                          f"({GNSS_PACKET.size}) nor the odometry ({ODOMETRY_PACKET.size}) "
                          "packet", data)
