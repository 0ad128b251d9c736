"""Every decoder on >= 10,000 random packets: it returns a record or raises
MalformedPacket -- never anything else.  Random bytes, truncated and extended valid
packets, bit flips, NaN floats, bad checksums."""

from __future__ import annotations

import struct
from collections.abc import Callable

import numpy as np
import pytest
from pyubx2 import GET, UBXMessage

from navstack.drivers.cart_sensors import CartSensorSample, encode_sensor_line, parse_sensor_line
from navstack.drivers.errors import MalformedPacket
from navstack.drivers.gnss import decode_nmea, decode_ubx
from navstack.drivers.golf_cart import decode_cart_command, encode_cart_command
from navstack.drivers.rover_telemetry import (
    RoverGnssPacket,
    RoverOdometryPacket,
    decode_rover_telemetry,
    encode_rover_gnss,
    encode_rover_odometry,
)
from navstack.drivers.rover_vcu import decode_vcu_command, encode_vcu_command

N = 10_000
NAN32 = struct.pack("<f", float("nan"))


def _valid_samples() -> dict[str, list[bytes]]:
    pvt = bytes(UBXMessage("NAV", "NAV-PVT", GET, fixType=3, gnssFixOk=1, lat=52.62,
                           lon=-2.16, hAcc=1500, vAcc=2500, gSpeed=1200,
                           headMot=90.0).serialize())
    return {
        "vcu": [encode_vcu_command(0.123, 0.45), encode_vcu_command(-1.0, 0.29, "teleop")],
        "cart": [encode_cart_command(1.0, 0.3), encode_cart_command(-0.3, -0.7)],
        "sensor": [encode_sensor_line(CartSensorSample(1, 1000, 3, 1.2, (0.1, 0.2, 9.8),
                                                       (0.0, 0.0, 0.1), (20.0, 1.0, -40.0)))],
        "rover": [encode_rover_gnss(RoverGnssPacket(38.4, -110.8, 1380.0, 45.0, 1.5, 2.0, 3.0,
                                                    3, 9, 1)),
                  encode_rover_odometry(RoverOdometryPacket(1, 10, 0.5, 0.6, 0.1, 0.0, 0))],
        "nmea": [b"$GPGGA,184353.07,1929.045,S,02410.506,E,1,04,2.6,100.00,M,-33.9,M,,0000*6D",
                 b"$GPRMC,225446,A,4916.45,N,12311.12,W,000.5,054.7,191194,020.3,E*68",
                 b"$GPVTG,108.53,T,,M,0.04,N,0.07,K,A*31"],
        "ubx": [pvt],
    }


def _mutate(rng: np.random.Generator, valid: list[bytes]) -> bytes:
    base = valid[int(rng.integers(len(valid)))]
    kind = int(rng.integers(7))
    if kind == 0:  # random bytes, random length
        return rng.bytes(int(rng.integers(0, 120)))
    if kind == 1:  # truncated
        return base[:int(rng.integers(0, len(base)))]
    if kind == 2:  # extended
        return base + rng.bytes(int(rng.integers(1, 8)))
    if kind == 3:  # bit flips
        data = bytearray(base)
        for _ in range(int(rng.integers(1, 4))):
            i = int(rng.integers(len(data)))
            data[i] ^= 1 << int(rng.integers(8))
        return bytes(data)
    if kind == 4 and len(base) >= 4:  # a NaN float somewhere
        i = int(rng.integers(0, len(base) - 3))
        return base[:i] + NAN32 + base[i + 4:]
    if kind == 5:  # printable noise (defeats "non-ASCII" short cuts)
        return bytes(rng.integers(32, 127, int(rng.integers(0, 100))).astype(np.uint8))
    data = bytearray(base)  # one byte replaced (bad checksum / digit / field)
    data[int(rng.integers(len(data)))] = int(rng.integers(256))
    return bytes(data)


DECODERS: dict[str, Callable[[bytes], object]] = {
    "vcu": decode_vcu_command, "cart": decode_cart_command, "sensor": parse_sensor_line,
    "rover": decode_rover_telemetry, "nmea": decode_nmea, "ubx": decode_ubx,
}


@pytest.mark.parametrize("name", sorted(DECODERS))
def test_fuzz_decoder(name: str) -> None:
    rng = np.random.default_rng(sum(map(ord, name)))
    valid = _valid_samples()[name]
    decode = DECODERS[name]
    ok = bad = 0
    reasons: set[str] = set()
    for _ in range(N):
        packet = _mutate(rng, valid)
        try:
            decode(packet)
            ok += 1
        except MalformedPacket as exc:
            bad += 1
            reasons.add(exc.codec)
    assert ok + bad == N
    assert bad > N // 2  # the mutations mostly break packets, and they are caught
    for packet in valid:  # the originals still decode
        decode(packet)
