"""Golden table of the golf cart's '<fi' packet, its steering formulas and decoding."""

from __future__ import annotations

import math

import pytest

from navstack.control.ackermann import ackermann_steering
from navstack.drivers.errors import EncodeError, MalformedPacket
from navstack.drivers.golf_cart import (
    STOP_PACKET,
    CartCommand,
    cart_steering,
    decode_cart_command,
    encode_cart_command,
    steering_to_steps,
)

# (speed m/s, steering rad, packet bytes)
GOLDEN = [
    (1.0, 0.3, "66 66 66 40 6b ff ff ff"),  # the documented example: 3.6 km/h, -149 steps
    (0.0, 0.0, "00 00 00 00 00 00 00 00"),
    (1.0, 0.0, "66 66 66 40 00 00 00 00"),
    (-1.0, 0.0, "66 66 66 c0 00 00 00 00"),
    (0.5, -0.3, "66 66 e6 3f 95 00 00 00"),
    (2.5, 0.74, "00 00 10 41 90 fe ff ff"),  # the limit: -368 steps
    (2.5, -0.74, "00 00 10 41 70 01 00 00"),
    (2.5, 0.8, "00 00 10 41 90 fe ff ff"),  # clamped to 0.74
    (2.5, -1.5, "00 00 10 41 70 01 00 00"),
    (-0.35, 0.2, "ae 47 a1 bf 9d ff ff ff"),
    (1.0, 0.001, "66 66 66 40 00 00 00 00"),  # 0.498 steps truncates to 0
    (1.0, 0.002, "66 66 66 40 00 00 00 00"),  # 0.996 steps truncates to 0
    (1.0, -0.002, "66 66 66 40 00 00 00 00"),
    (1.0, 0.0020087, "66 66 66 40 ff ff ff ff"),  # 1.00001 steps -> -1
    (0.1, 0.5, "ec 51 b8 3e 08 ff ff ff"),
    (0.25, 0.1, "66 66 66 3f cf ff ff ff"),
    (3.0, 0.05, "cd cc 2c 41 e8 ff ff ff"),
    (-0.2, -0.6, "ec 51 38 bf 2a 01 00 00"),
    (1.2345, 0.4567, "e3 36 8e 40 1d ff ff ff"),
    (0.01, 0.7399, "bc 74 13 3d 90 fe ff ff"),
    (5.0, 0.0, "00 00 90 41 00 00 00 00"),
    (0.3, 0.3, "71 3d 8a 3f 6b ff ff ff"),
    (0.7, -0.15, "ae 47 21 40 4a 00 00 00"),
    (1.8, 0.25, "29 5c cf 40 84 ff ff ff"),
    (0.05, -0.05, "ec 51 38 3e 18 00 00 00"),
    (2.0, 0.6, "66 66 e6 40 d6 fe ff ff"),
    (2.0, -0.6, "66 66 e6 40 2a 01 00 00"),
    (1.5, 0.35, "cd cc ac 40 52 ff ff ff"),
    (1.0, 1e-9, "66 66 66 40 00 00 00 00"),
    (0.8, -0.738, "ec 51 38 40 6f 01 00 00"),
]


@pytest.mark.parametrize(("speed", "steering", "packet"), GOLDEN)
def test_golden_table(speed: float, steering: float, packet: str) -> None:
    assert encode_cart_command(speed, steering) == bytes.fromhex(packet)


def test_documented_example_and_stop_packet() -> None:
    assert len(GOLDEN) >= 30
    assert encode_cart_command(1.0, 0.30) == b"\x66\x66\x66\x40\x6b\xff\xff\xff"
    assert bytes(8) == STOP_PACKET
    assert steering_to_steps(0.30) == -149
    assert steering_to_steps(-0.74) == 368


@pytest.mark.parametrize(("speed", "steering", "packet"), GOLDEN)
def test_round_trip_within_quantisation(speed: float, steering: float, packet: str) -> None:
    cmd = decode_cart_command(bytes.fromhex(packet))
    assert abs(cmd.speed - speed) < 1e-6 * max(1.0, abs(speed))
    clamped = max(-0.74, min(0.74, steering))
    assert abs(cmd.steering - clamped) < 1.0 / 497.84 + 1e-12
    assert abs(cmd.steering) <= abs(clamped) + 1e-12  # truncation only ever shrinks it


@pytest.mark.parametrize(("vx", "wz", "physical", "compat"), [
    (1.0, 0.0, 0.0, 0.0),
    (1.0, 0.1, 0.235545, 0.236083),
    (1.0, -0.1, -0.235545, -0.236083),
    (2.0, 0.5, 0.54042, 0.545516),
    (1.0, 0.5, 0.74, 0.74),  # both clamp
    (0.0, 0.5, 0.0, 0.0),  # no curvature without speed
    (-0.3, 0.1, -0.674741, -0.670537),  # reversing
    (2.5, 0.2, 0.189692, 0.189978),
    (1.0, 0.3, 0.624023, 0.631082),
])
def test_steering_formulas(vx: float, wz: float, physical: float, compat: float) -> None:
    assert cart_steering(vx, wz, 2.4, 1.0, "physical") == pytest.approx(physical, abs=1e-6)
    assert cart_steering(vx, wz, 2.4, 1.0, "compat") == pytest.approx(compat, abs=1e-6)


@pytest.mark.parametrize(("vx", "wz"), [(1.0, 0.1), (2.0, -0.4), (0.7, 0.2)])
def test_physical_is_the_bicycle_angle_and_compat_the_mean_wheel(vx: float, wz: float) -> None:
    """Away from the clamp: physical = the bicycle-model centre angle of control/ackermann,
    compat = the mean of its left and right wheel angles."""
    ref = ackermann_steering(vx, wz, 2.4, 1.0, 0.74)
    assert cart_steering(vx, wz, 2.4, 1.0, "physical") == pytest.approx(ref.center, abs=1e-12)
    assert cart_steering(vx, wz, 2.4, 1.0, "compat") == pytest.approx(
        0.5 * (ref.left + ref.right), abs=1e-12)
    # the curvature the physical angle realises is the commanded one
    delta = cart_steering(vx, wz, 2.4, 1.0, "physical")
    assert vx * math.tan(delta) / 2.4 == pytest.approx(wz, rel=1e-12)


def test_decode_values() -> None:
    assert decode_cart_command(bytes.fromhex("66 66 66 40 6b ff ff ff")) == \
        CartCommand(pytest.approx(3.6), -149)  # type: ignore[arg-type]


@pytest.mark.parametrize(("data", "reason"), [
    (bytes(7), "expected 8 bytes, got 7"),
    (bytes(9), "expected 8 bytes, got 9"),
    (bytes.fromhex("00 00 c0 7f 00 00 00 00"), "speed is nan"),
    (bytes.fromhex("00 00 80 7f 00 00 00 00"), "speed is inf"),
    (bytes.fromhex("00 00 48 42 00 00 00 00"), "speed 50 km/h beyond"),
    (bytes.fromhex("00 00 00 00 71 01 00 00"), "steering target 369 steps beyond"),
    (bytes.fromhex("00 00 00 00 00 00 00 80"), "steering target -2147483648"),
])
def test_decode_rejects(data: bytes, reason: str) -> None:
    with pytest.raises(MalformedPacket, match=reason):
        decode_cart_command(data)


def test_encode_refuses_non_finite_and_bad_geometry() -> None:
    with pytest.raises(EncodeError, match="must be finite"):
        encode_cart_command(math.nan, 0.0)
    with pytest.raises(EncodeError, match="must be finite"):
        cart_steering(1.0, math.inf, 2.4, 1.0)
    with pytest.raises(EncodeError, match="wheel_base must be > 0"):
        cart_steering(1.0, 0.1, 0.0, 1.0)
    with pytest.raises(EncodeError, match="unknown steering mode"):
        cart_steering(1.0, 0.1, 2.4, 1.0, "ideal")  # type: ignore[arg-type]
