"""The rover VCU's GNSS and odometry packets: documented layout, strict decoding."""

from __future__ import annotations

import struct

import pytest

from navstack.drivers.errors import MalformedPacket
from navstack.drivers.rover_telemetry import (
    GNSS_PACKET,
    ODOMETRY_PACKET,
    RoverGnssPacket,
    RoverOdometryPacket,
    decode_rover_gnss,
    decode_rover_odometry,
    decode_rover_telemetry,
    encode_rover_gnss,
    encode_rover_odometry,
)

GNSS = RoverGnssPacket(38.406415, -110.791924, 1380.0, 45.0, 1.5, 2.0, 3.0, 3, 9, 7)
GNSS_BYTES = bytes.fromhex("4b cd 1e 68 05 34 43 40 b8 3a 00 e2 ae b2 5b c0 00 80 ac 44 00 00 "
                           "34 42 00 00 c0 3f 00 00 00 40 00 00 40 40 03 09 07 00")
ODOM = RoverOdometryPacket(5, 123456, 0.5, 0.75, 0.25, -0.125, 2)  # exact in float32
ODOM_BYTES = bytes.fromhex("52 56 4f 44 05 00 40 e2 01 00 00 00 00 3f 00 00 40 3f 00 00 80 3e "
                           "00 00 00 be 02 00 00 00")


def test_layout_sizes_and_course_is_field_3() -> None:
    assert GNSS_PACKET.size == 40 and ODOMETRY_PACKET.size == 30
    assert struct.unpack_from("<ddfff", GNSS_BYTES)[3] == 45.0  # COG at field index 3
    assert GNSS_BYTES[20:24] == struct.pack("<f", 45.0)


def test_golden_packets() -> None:
    assert encode_rover_gnss(GNSS) == GNSS_BYTES
    assert encode_rover_odometry(ODOM) == ODOM_BYTES
    g = decode_rover_gnss(GNSS_BYTES)
    assert (g.latitude, g.longitude) == (38.406415, -110.791924)
    assert (g.altitude, g.course_deg, g.speed, g.fix_type, g.satellites, g.seq) == \
        (1380.0, 45.0, 1.5, 3, 9, 7)
    assert decode_rover_odometry(ODOM_BYTES) == ODOM
    assert decode_rover_telemetry(GNSS_BYTES) == g
    assert decode_rover_telemetry(ODOM_BYTES) == ODOM
    assert not ODOM.estop and RoverOdometryPacket(0, 0, 0, 0, 0, 0, 1).estop


def _gnss(**over: float) -> bytes:
    values = {**GNSS.__class__.__dataclass_fields__}
    fields = [getattr(GNSS, k) for k in values]
    for k, v in over.items():
        fields[list(values).index(k)] = v
    return GNSS_PACKET.pack(*fields)


@pytest.mark.parametrize(("data", "reason"), [
    (GNSS_BYTES[:-1], "expected 40 bytes, got 39"),
    (_gnss(latitude=float("nan")), "latitude is nan"),
    (_gnss(latitude=91.0), "latitude outside"),
    (_gnss(longitude=-180.5), "longitude outside"),
    (_gnss(course_deg=360.0), "course over ground outside"),
    (_gnss(course_deg=-1.0), "course over ground outside"),
    (_gnss(speed=-0.1), "speed over ground outside"),
    (_gnss(h_acc=float("inf")), "h_acc is inf"),
    (_gnss(altitude=1e6), "altitude outside"),
    (_gnss(fix_type=6), "fix type 6"),
])
def test_gnss_rejects(data: bytes, reason: str) -> None:
    with pytest.raises(MalformedPacket, match=reason):
        decode_rover_gnss(data)


@pytest.mark.parametrize(("data", "reason"), [
    (ODOM_BYTES[:-2], "expected 30 bytes, got 28"),
    (b"XXOD" + ODOM_BYTES[4:], "magic b'XXOD'"),
    (ODOMETRY_PACKET.pack(b"RVOD", 0, 0, float("nan"), 0, 0, 0, 0), "left_speed nan"),
    (ODOMETRY_PACKET.pack(b"RVOD", 0, 0, 0, 11.0, 0, 0, 0), "right_speed 11.0"),
    (ODOMETRY_PACKET.pack(b"RVOD", 0, 0, 0, 0, 25.0, 0, 0), "yaw_rate 25.0"),
    (ODOMETRY_PACKET.pack(b"RVOD", 0, 0, 0, 0, 0, 0, 8), "undefined bits"),
])
def test_odometry_rejects(data: bytes, reason: str) -> None:
    with pytest.raises(MalformedPacket, match=reason):
        decode_rover_odometry(data)


def test_telemetry_rejects_other_lengths() -> None:
    with pytest.raises(MalformedPacket, match="length 12 matches neither"):
        decode_rover_telemetry(b"104510123001")
