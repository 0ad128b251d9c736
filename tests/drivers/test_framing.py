"""Framers: lines, fixed packets with resynchronisation, mixed NMEA/UBX streams."""

from __future__ import annotations

import numpy as np
from pyubx2 import GET, UBXMessage

from navstack.drivers.framing import DatagramFramer, FixedFramer, GnssFramer, LineFramer
from navstack.drivers.golf_cart import decode_cart_command, encode_cart_command
from navstack.drivers.golf_cart import plausible_cart_command as _plausible_cart_command


def test_line_framer_splits_and_drops_overlong() -> None:
    f = LineFramer(max_line=20)
    assert f.feed(b"abc\r\nde") == [b"abc\r\n"]
    assert f.feed(b"f\n") == [b"def\n"]
    assert f.feed(b"x" * 30) == [] and f.dropped_frames == 1
    assert f.feed(b"yyy\nok\n") == [b"ok\n"]  # the rest of the long line is dropped too
    assert f.dropped_bytes == 34
    f.feed(b"partial")
    f.reset()
    assert f.feed(b"\n") == [b"\n"]


def test_fixed_framer_resynchronises_after_a_lost_byte() -> None:
    packets = [encode_cart_command(1.0 + 0.1 * k, 0.01 * k) for k in range(10)]
    stream = b"".join(packets)
    stream = stream[:19] + stream[20:]  # one byte of packet 2 lost on the wire
    f = FixedFramer(8, _plausible_cart_command)
    out: list[bytes] = []
    for i in range(0, len(stream), 5):  # arrives in odd chunks
        out += f.feed(stream[i:i + 5])
    decoded = [decode_cart_command(p) for p in out]
    assert out[:2] == packets[:2]
    assert out[-6:] == packets[-6:]  # locked on again within the damaged packet's neighbours
    assert f.resync_bytes > 0
    assert all(abs(d.speed_kmh) < 40 for d in decoded)


def test_fixed_framer_bounds_its_buffer() -> None:
    f = FixedFramer(8, lambda b: False, max_buffer=64)
    f.feed(bytes(1000))
    assert len(f._buf) < 8 and f.dropped_bytes > 900


def test_gnss_framer_mixed_stream() -> None:
    pvt = bytes(UBXMessage("NAV", "NAV-PVT", GET, fixType=3).serialize())
    gga = b"$GPGGA,184353.07,1929.045,S,02410.506,E,1,04,2.6,100.00,M,-33.9,M,,0000*6D\r\n"
    stream = b"\x00junk" + gga + pvt + b"\xb5" + gga + pvt
    f = GnssFramer()
    out: list[bytes] = []
    rng = np.random.default_rng(0)
    i = 0
    while i < len(stream):
        n = int(rng.integers(1, 17))
        out += f.feed(stream[i:i + n])
        i += n
    assert out == [gga, pvt, gga, pvt]
    assert f.dropped_bytes == 6


def test_datagram_framer() -> None:
    assert DatagramFramer().feed(b"x") == [b"x"] and DatagramFramer().feed(b"") == [b""]
