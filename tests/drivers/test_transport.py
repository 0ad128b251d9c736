"""Transports on real OS links: UDP loopback, pyserial loop://, pty pairs (with the far
end closing and coming back), statistics and back-off."""

from __future__ import annotations

import os
import pty
import time
from pathlib import Path

import pytest

from navstack.core.errors import ConfigError
from navstack.drivers.errors import LinkUnavailable, MalformedPacket
from navstack.drivers.framing import LineFramer
from navstack.drivers.transport import (
    Backoff,
    LinkReader,
    SerialTransport,
    UdpTransport,
    parse_endpoint,
)


def _poll_until(transport: UdpTransport | SerialTransport, n: int, timeout: float = 2.0
                ) -> list[bytes]:
    out: list[bytes] = []
    t_end = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < t_end:
        out += transport.poll(0.02)
    return out


def test_parse_endpoint() -> None:
    assert parse_endpoint("192.168.1.50:5006") == ("192.168.1.50", 5006)
    for bad in ("5006", "host:", ":80", "h:99999", "h:x"):
        with pytest.raises(ConfigError, match="expected 'ip:port'"):
            parse_endpoint(bad, "links.vcu.remote")


def test_udp_round_trip_and_stats() -> None:
    a = UdpTransport("a", ("127.0.0.1", 0), None)
    a.open()
    b = UdpTransport("b", ("127.0.0.1", 0), a.local_address)
    b.open()
    a.remote = b.local_address
    try:
        assert b.write(b"104510123001") and b.write(b"x")
        assert _poll_until(a, 2) == [b"104510123001", b"x"]  # datagrams stay whole
        assert a.write(b"pong")
        assert _poll_until(b, 1) == [b"pong"]
        s = a.stats.snapshot()
        assert (s["packets_rx"], s["bytes_rx"], s["packets_tx"]) == (2, 13, 1)
        assert s["last_rx_age"] is not None and s["last_rx_age"] < 1.0
        assert s["rx_rate_hz"] == pytest.approx(1.0)  # 2 packets in the 2 s window
        a.stats.bad_packet(MalformedPacket("rover VCU command", "non-digit character"))
        assert a.stats.snapshot()["malformed_by_codec"] == {"rover VCU command": 1}
    finally:
        a.close()
        b.close()


def test_udp_bind_conflict_is_a_clear_error_and_retried_with_backoff() -> None:
    a = UdpTransport("a", ("127.0.0.1", 0), None)
    a.open()
    port = a.local_address[1]
    b = UdpTransport("vcu", ("127.0.0.1", port), ("127.0.0.1", 9),
                     backoff=Backoff(0.05, 0.2))
    try:
        with pytest.raises(LinkUnavailable, match=f"cannot bind UDP 127.0.0.1:{port}"):
            b.open()
        assert not b.write(b"x")  # down: refused, counted, not raised
        assert b.stats.io_errors == 1 and "cannot bind" in b.stats.last_error
        assert not b.write(b"x")  # within the back-off: no new attempt
        assert b.stats.io_errors == 1
        a.close()  # the port frees up; the next attempt after the delay succeeds
        time.sleep(0.06)
        assert b.write(b"x") and b.is_open
    finally:
        a.close()
        b.close()


def test_serial_loop_url() -> None:
    t = SerialTransport("loop", "loop://", 115200, LineFramer())
    t.open()
    try:
        assert t.write(b"$CART,1*00\r\n$CA") and t.write(b"RT,2*00\r\n")
        assert _poll_until(t, 2) == [b"$CART,1*00\r\n", b"$CART,2*00\r\n"]
    finally:
        t.close()


def test_serial_missing_device_names_it() -> None:
    t = SerialTransport("steering", "/dev/does-not-exist-navstack", 115200)
    with pytest.raises(LinkUnavailable, match="cannot open serial port "
                                              "'/dev/does-not-exist-navstack' at 115200 baud"):
        t.open()


def _pty_link(link: Path) -> int:
    master, slave = pty.openpty()
    if link.is_symlink():
        link.unlink()
    link.symlink_to(os.ttyname(slave))
    os.close(slave)
    return master


def test_pty_far_end_closes_and_returns(tmp_path: Path) -> None:
    """A vehicle on a pty (behind a stable symlink, like /dev/serial/by-id): the driver
    reads, the vehicle goes away (EIO), comes back on a new pty behind the same link, and
    the transport reconnects by itself after the back-off."""
    link = tmp_path / "ttyCART"
    master = _pty_link(link)
    t = SerialTransport("sensors", str(link), 115200, LineFramer(), Backoff(0.05, 0.1))
    t.open()
    got: list[bytes] = []
    reader = LinkReader(t, lambda packets, _: got.extend(packets), poll_timeout=0.02)
    reader.start()
    try:
        os.write(master, b"line 1\r\n")
        t_end = time.monotonic() + 2.0
        while not got and time.monotonic() < t_end:
            time.sleep(0.01)
        assert got == [b"line 1\r\n"]
        os.close(master)  # the Arduino is unplugged
        t_end = time.monotonic() + 2.0
        while t.is_open and time.monotonic() < t_end:
            time.sleep(0.01)
        assert not t.is_open and t.stats.io_errors >= 1
        master = _pty_link(link)  # plugged in again: a new pty behind the same name
        t_end = time.monotonic() + 3.0
        while not t.is_open and time.monotonic() < t_end:
            time.sleep(0.01)
        assert t.is_open and t.stats.reconnects >= 1
        os.write(master, b"line 2\r\n")
        t_end = time.monotonic() + 2.0
        while len(got) < 2 and time.monotonic() < t_end:
            time.sleep(0.01)
        assert got == [b"line 1\r\n", b"line 2\r\n"]
    finally:
        reader.stop()
        t.close()
        os.close(master)


def test_backoff_doubles_and_resets() -> None:
    b = Backoff(0.1, 0.5)
    b.failed(0.0)
    assert not b.ready(0.05) and b.ready(0.1)
    b.failed(1.0)
    b.failed(2.0)
    b.failed(3.0)
    assert b.delay == 0.5 and b.next_attempt == 3.5
    b.reset()
    assert b.delay == 0.1 and b.ready(0.0)
