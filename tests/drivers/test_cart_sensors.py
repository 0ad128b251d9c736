"""The cart sensor Arduino's line format: encoding, strict parsing, calibration, pulses."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navstack.drivers.cart_sensors import (
    PULSE_DISTANCE,
    CartSensorSample,
    WheelPulseSpeed,
    calibrate,
    encode_sensor_line,
    nmea_checksum,
    parse_sensor_line,
)
from navstack.drivers.errors import EncodeError, MalformedPacket

LINE = b"$CART,12,34567,89,1.234,0.100,-0.200,9.807,0.0012,-0.0034,0.2500,21.50,-3.25,-40.00*1D\r\n"
SAMPLE = CartSensorSample(12, 34567, 89, 1.234, (0.1, -0.2, 9.807), (0.0012, -0.0034, 0.25),
                          (21.5, -3.25, -40.0))


def test_checksum_is_nmea_xor() -> None:
    # pynmea2's documented GGA example carries *6D
    body = "GPGGA,184353.07,1929.045,S,02410.506,E,1,04,2.6,100.00,M,-33.9,M,,0000"
    assert nmea_checksum(body) == "6D"


def test_golden_lines() -> None:
    assert encode_sensor_line(SAMPLE) == LINE
    assert encode_sensor_line(CartSensorSample(65535, 2 ** 32 - 1, 0, 0.0, (0, 0, 0), (0, 0, 0),
                                               (0, 0, 0))) == \
        b"$CART,65535,4294967295,0,0.000,0.000,0.000,0.000,0.0000,0.0000,0.0000,0.00,0.00,0.00*25\r\n"
    # counters wrap, negative zero prints as zero
    assert encode_sensor_line(CartSensorSample(65536, 2 ** 32, 2 ** 32 + 5, 2.5,
                                               (-0.0004, 0.0, 0.0), (-0.00004, 0, 0),
                                               (0.004, 0, 0))) == \
        b"$CART,0,0,5,2.500,0.000,0.000,0.000,0.0000,0.0000,0.0000,0.00,0.00,0.00*1A\r\n"


def test_parse_round_trip() -> None:
    assert parse_sensor_line(LINE) == SAMPLE
    assert parse_sensor_line(LINE.rstrip(b"\r\n")) == SAMPLE
    rng = np.random.default_rng(3)
    for _ in range(200):
        s = CartSensorSample(int(rng.integers(0, 65536)), int(rng.integers(0, 2 ** 32)),
                             int(rng.integers(0, 2 ** 32)), float(rng.uniform(0, 30)),
                             tuple(rng.uniform(-150, 150, 3)), tuple(rng.uniform(-30, 30, 3)),
                             tuple(rng.uniform(-4000, 4000, 3)))  # type: ignore[arg-type]
        back = parse_sensor_line(encode_sensor_line(s))
        assert (back.seq, back.t_ms, back.pulses) == (s.seq, s.t_ms, s.pulses)
        assert back.speed == pytest.approx(s.speed, abs=5e-4)
        assert np.allclose(back.accel, s.accel, atol=5e-4)
        assert np.allclose(back.gyro, s.gyro, atol=5e-5)
        assert np.allclose(back.mag_ut, s.mag_ut, atol=5e-3)


def _with_checksum(body: str) -> bytes:
    return f"${body}*{nmea_checksum(body)}\r\n".encode()


@pytest.mark.parametrize(("line", "reason"), [
    (LINE.replace(b"*1D", b"*1E"), "checksum mismatch"),
    (LINE.replace(b"*1D", b"*1d"), "two uppercase hex digits"),
    (LINE.replace(b"*1D", b""), r"expected '\$\.\.\.\*HH'"),
    (LINE[1:], r"expected '\$\.\.\.\*HH'"),
    (b"$CART,1,2*" + b"00", "checksum mismatch"),
    (_with_checksum("CART,1,2,3"), "expected 13 values after CART, got 3"),
    (_with_checksum("CART,12,34567,89,1.234,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40,7"),
     "expected 13 values after CART, got 14"),
    (_with_checksum("IMU,12,34567,89,1.234,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "unknown sentence 'IMU'"),
    (_with_checksum("CART,-1,34567,89,1.234,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "seq must be an integer"),
    (_with_checksum("CART,65536,1,89,1.234,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "seq must be an integer"),
    (_with_checksum("CART,1,1,8.9,1.234,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "pulses must be an integer"),
    (_with_checksum("CART,1,1,89,nan,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "field 4 must be a plain decimal, got 'nan'"),
    (_with_checksum("CART,1,1,89,1.0,inf,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "field 5 must be a plain decimal, got 'inf'"),
    (_with_checksum("CART,1,1,89,1.0,1e3,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "plain decimal, got '1e3'"),
    (_with_checksum("CART,1,1,89,1.0,,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "plain decimal, got ''"),
    (_with_checksum("CART,1,1,89,-1.0,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "wheel speed must be >= 0"),
    (_with_checksum("CART,1,1,89,31.0,0.1,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "v value out of range"),
    (_with_checksum("CART,1,1,89,1.0,200.0,-0.2,9.807,0.0012,-0.0034,0.25,21.5,-3.25,-40"),
     "a value out of range"),
    (_with_checksum("CART,1,1,89,1.0,0.1,-0.2,9.807,40.0,-0.0034,0.25,21.5,-3.25,-40"),
     "g value out of range"),
    (_with_checksum("CART,1,1,89,1.0,0.1,-0.2,9.807,0.0,-0.0034,0.25,5000.0,-3.25,-40"),
     "m value out of range"),
    (b"$CART\xff,1*00\r\n", "non-ASCII"),
    (b"$" + b"1" * 200 + b"\r\n", "longer than 160"),
])
def test_strict_parsing(line: bytes, reason: str) -> None:
    with pytest.raises(MalformedPacket, match=reason):
        parse_sensor_line(line)


def test_encode_refuses_non_finite() -> None:
    with pytest.raises(EncodeError, match="non-finite"):
        encode_sensor_line(CartSensorSample(0, 0, 0, math.nan, (0, 0, 0), (0, 0, 0), (0, 0, 0)))


def test_affine_calibration() -> None:
    A = np.array([[1.02, 0.01, 0.0], [0.0, 0.98, 0.02], [0.0, 0.0, 1.01]])
    b = np.array([0.1, -0.2, 0.3])
    raw = np.array([1.1, 0.8, 10.1])
    assert np.allclose(calibrate(raw, A, b), A @ (raw - b))
    batch = np.array([raw, raw * 2])
    assert np.allclose(calibrate(batch, A, b), (batch - b) @ A.T)
    # inverse distortion then calibration recovers the truth
    truth = np.array([0.3, -0.4, 9.8])
    distorted = np.linalg.solve(A, truth) + b
    assert np.allclose(calibrate(distorted, A, b), truth)


def test_wheel_pulse_speed() -> None:
    assert pytest.approx(2 * math.pi * 0.225 / 4) == PULSE_DISTANCE
    w = WheelPulseSpeed()
    v = 2.0  # m/s: a pulse every 0.1767 s
    speeds = []
    for k in range(200):
        t = k * 0.02
        speeds.append(w.update(t, math.floor(v * t / PULSE_DISTANCE)))
    assert speeds[0] == 0.0
    # after the first two pulses the period estimate is within one 20 ms sample
    assert all(abs(s - v) < 0.25 for s in speeds[40:])
    # the wheel stops: the speed decays as 1/time since the last pulse, then 0 after 2 s
    last = math.floor(v * 3.98 / PULSE_DISTANCE)
    decayed = [w.update(4.0 + k * 0.1, last) for k in range(1, 30)]
    assert all(a >= b for a, b in itertools.pairwise(decayed))
    assert decayed[-1] == 0.0
