"""Transports: UDP and serial links with statistics and reconnect-with-back-off.

A :class:`Transport` moves bytes; its :class:`~navstack.drivers.framing.Framer` cuts
what arrives into packets.  Both directions are counted in :class:`LinkStats` (packets,
bytes, rates, I/O errors, reconnects, last-seen), which the driver node adds its decode
errors to.  A transport whose device fails (a USB adapter unplugged, a pty whose other
end closed, a port that does not exist yet) closes itself and is re-opened on the next
``poll``/``write`` once the back-off delay has passed: 0.1 s, doubling up to 2 s,
reset by a successful open (:class:`Backoff`).  Nothing here raises on I/O trouble while
running -- a link that is down returns no packets and refuses writes, and the watchdog
above it notices the silence.

* :class:`UdpTransport` binds ``bind`` ("ip:port", the rover's own address) and sends to
  ``remote`` (the VCU's "ip:port").  Datagrams are packets.
* :class:`SerialTransport` opens ``port`` through pyserial's ``serial_for_url``: a device
  (``/dev/ttyACM0``), a pty or a symlink to one (what udev's ``/dev/serial/by-id`` links
  are), or a URL such as ``loop://`` for tests.

:class:`LinkReader` runs ``poll`` on a thread and hands the packets, stamped with the
monotonic wall clock, to a callback; the driver node drains them on its own clock.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import serial

from navstack.core.errors import ConfigError
from navstack.drivers.errors import LinkUnavailable, MalformedPacket
from navstack.drivers.framing import DatagramFramer, Framer

__all__ = ["Backoff", "LinkReader", "LinkStats", "SerialTransport", "Transport",
           "UdpTransport", "parse_endpoint"]

RATE_WINDOW = 2.0
"""Seconds over which packet rates are measured."""


def parse_endpoint(text: str, key_path: str = "") -> tuple[str, int]:
    """``"ip:port"`` -> ``(ip, port)``; :class:`ConfigError` naming ``key_path`` otherwise."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ConfigError(f"expected 'ip:port' (e.g. '192.168.1.50:5006'), got {text!r}",
                          key_path=key_path)
    return host, int(port)


class Backoff:
    """Reconnect delays: ``initial``, doubling up to ``maximum``; ``reset`` on success."""

    def __init__(self, initial: float = 0.1, maximum: float = 2.0) -> None:
        self.initial, self.maximum = initial, maximum
        self.delay = initial
        self.next_attempt = 0.0

    def ready(self, now: float) -> bool:
        return now >= self.next_attempt

    def failed(self, now: float) -> None:
        self.next_attempt = now + self.delay
        self.delay = min(self.delay * 2.0, self.maximum)

    def reset(self) -> None:
        self.delay = self.initial
        self.next_attempt = 0.0


class LinkStats:
    """Counters of one link (thread-safe; wall-clock times from ``time.monotonic``)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._lock = threading.Lock()
        self.packets_rx = self.bytes_rx = self.packets_tx = self.bytes_tx = 0
        self.malformed = 0
        self.malformed_by_codec: dict[str, int] = {}
        self.last_malformed = ""
        self.framing_dropped_bytes = 0
        self.io_errors = 0
        self.last_error = ""
        self.reconnects = 0
        self.opens = 0
        self.last_rx: float | None = None
        self.last_tx: float | None = None
        self._rx_times: deque[float] = deque()
        self._tx_times: deque[float] = deque()

    def received(self, n_packets: int, n_bytes: int, t: float) -> None:
        with self._lock:
            self.bytes_rx += n_bytes
            if n_packets:
                self.packets_rx += n_packets
                self.last_rx = t
                self._rx_times.extend([t] * n_packets)
                _trim(self._rx_times, t)

    def sent(self, n_bytes: int, t: float) -> None:
        with self._lock:
            self.packets_tx += 1
            self.bytes_tx += n_bytes
            self.last_tx = t
            self._tx_times.append(t)
            _trim(self._tx_times, t)

    def bad_packet(self, error: MalformedPacket) -> None:
        with self._lock:
            self.malformed += 1
            self.malformed_by_codec[error.codec] = self.malformed_by_codec.get(error.codec, 0) + 1
            self.last_malformed = str(error)

    def io_error(self, message: str) -> None:
        with self._lock:
            self.io_errors += 1
            self.last_error = message

    def rates(self, now: float | None = None) -> tuple[float, float]:
        """(rx, tx) packets per second over the last :data:`RATE_WINDOW` seconds."""
        now = time.monotonic() if now is None else now
        with self._lock:
            _trim(self._rx_times, now)
            _trim(self._tx_times, now)
            return len(self._rx_times) / RATE_WINDOW, len(self._tx_times) / RATE_WINDOW

    def snapshot(self, now: float | None = None) -> dict[str, Any]:
        """Every counter as a plain dict (``last_rx_age`` in seconds, ``None`` if never)."""
        now = time.monotonic() if now is None else now
        rx_rate, tx_rate = self.rates(now)
        with self._lock:
            return {"link": self.name, "packets_rx": self.packets_rx, "bytes_rx": self.bytes_rx,
                    "packets_tx": self.packets_tx, "bytes_tx": self.bytes_tx,
                    "rx_rate_hz": rx_rate, "tx_rate_hz": tx_rate, "malformed": self.malformed,
                    "malformed_by_codec": dict(self.malformed_by_codec),
                    "last_malformed": self.last_malformed,
                    "framing_dropped_bytes": self.framing_dropped_bytes,
                    "io_errors": self.io_errors, "last_error": self.last_error,
                    "reconnects": self.reconnects,
                    "last_rx_age": None if self.last_rx is None else now - self.last_rx}


def _trim(times: deque[float], now: float) -> None:
    while times and times[0] < now - RATE_WINDOW:
        times.popleft()


class Transport(ABC):
    """A byte link that re-opens itself with back-off (module docstring)."""

    def __init__(self, name: str, framer: Framer, backoff: Backoff | None = None) -> None:
        self.name = name
        self.framer = framer
        self.stats = LinkStats(name)
        self.backoff = backoff or Backoff()
        self._lock = threading.RLock()
        self._open = False
        self._closed_by_user = False

    @property
    def is_open(self) -> bool:
        return self._open

    def open(self) -> None:
        """Open now; :class:`LinkUnavailable` (naming the device) if that fails."""
        with self._lock:
            self._closed_by_user = False
            if not self._open:
                self._open_device()
                self._open = True
                self.stats.opens += 1
                if self.stats.opens > 1:
                    self.stats.reconnects += 1
                self.framer.reset()
                self.backoff.reset()

    def close(self) -> None:
        """Close and stay closed (no reconnect) until :meth:`open`."""
        with self._lock:
            self._closed_by_user = True
            self._drop()

    def _drop(self) -> None:
        if self._open:
            self._open = False
            self._close_device()

    def _ensure_open(self) -> bool:
        if self._open:
            return True
        if self._closed_by_user:
            return False
        now = time.monotonic()
        if not self.backoff.ready(now):
            return False
        with self._lock:
            try:
                self.open()
            except LinkUnavailable as exc:
                self.stats.io_error(str(exc))
                self.backoff.failed(now)
                return False
        return True

    def _failed(self, exc: BaseException) -> None:
        with self._lock:
            self.stats.io_error(f"{self.name}: {type(exc).__name__}: {exc}")
            self._drop()
            self.backoff.failed(time.monotonic())

    def write(self, data: bytes) -> bool:
        """Send ``data``; ``False`` when the link is down or the write would block
        (counted, never raised, never blocking for long)."""
        if not self._ensure_open():
            return False
        try:
            self._write(data)
        except (BlockingIOError, serial.SerialTimeoutException) as exc:
            self.stats.io_error(f"{self.name}: write dropped: {exc}")  # link stays up
            return False
        except (OSError, serial.SerialException, ValueError) as exc:
            self._failed(exc)
            return False
        self.stats.sent(len(data), time.monotonic())
        return True

    def poll(self, timeout: float = 0.05) -> list[bytes]:
        """Packets received within ``timeout`` seconds (``[]`` if none or the link is down)."""
        if not self._ensure_open():
            time.sleep(min(timeout, 0.01))
            return []
        try:
            data = self._read(timeout)
        except (OSError, serial.SerialException, ValueError, TypeError) as exc:
            self._failed(exc)
            return []
        if not data:
            return []
        before = self.framer.dropped_bytes
        packets: list[bytes] = []
        for chunk in data:
            packets += self.framer.feed(chunk)
        self.stats.framing_dropped_bytes += self.framer.dropped_bytes - before
        self.stats.received(len(packets), sum(map(len, data)), time.monotonic())
        return packets

    @abstractmethod
    def _open_device(self) -> None:
        """Open the device; raise :class:`LinkUnavailable`."""

    @abstractmethod
    def _close_device(self) -> None:
        """Release the device (never raises)."""

    @abstractmethod
    def _write(self, data: bytes) -> None:
        """Send; raise OSError / SerialException on failure."""

    @abstractmethod
    def _read(self, timeout: float) -> list[bytes]:
        """Chunks received within ``timeout`` (datagrams or stream pieces)."""


class UdpTransport(Transport):
    """UDP: bound at ``bind``, sending to ``remote`` (``None``: receive only)."""

    def __init__(self, name: str, bind: tuple[str, int], remote: tuple[str, int] | None,
                 framer: Framer | None = None, backoff: Backoff | None = None) -> None:
        super().__init__(name, framer or DatagramFramer(), backoff)
        self.bind_address = bind
        self.remote = remote
        self._sock: socket.socket | None = None

    @property
    def local_address(self) -> tuple[str, int]:
        """The bound address (the real port when ``bind`` asked for port 0)."""
        if self._sock is None:
            return self.bind_address
        host, port = self._sock.getsockname()[:2]
        return str(host), int(port)

    def _open_device(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind(self.bind_address)
        except OSError as exc:
            sock.close()
            raise LinkUnavailable(f"{self.name}: cannot bind UDP {self.bind_address[0]}:"
                                  f"{self.bind_address[1]}: {exc.strerror or exc}; is another "
                                  "driver running, or is the address not on this machine?"
                                  ) from None
        if self.bind_address[1] == 0:  # keep the port the OS chose across reconnects
            self.bind_address = (self.bind_address[0], sock.getsockname()[1])
        self._sock = sock

    def _close_device(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def _write(self, data: bytes) -> None:
        if self.remote is None:
            raise OSError("no remote address to send to")
        assert self._sock is not None
        self._sock.sendto(data, self.remote)

    def _read(self, timeout: float) -> list[bytes]:
        sock = self._sock
        assert sock is not None
        sock.settimeout(timeout)
        try:
            first = sock.recv(65535)
        except (TimeoutError, BlockingIOError):  # nothing within the timeout (or at once)
            return []
        except ConnectionRefusedError:  # ICMP port unreachable from an earlier send
            return []
        chunks = [first]
        sock.setblocking(False)
        try:
            while True:
                chunks.append(sock.recv(65535))
        except (BlockingIOError, ConnectionRefusedError):
            pass
        return chunks


class SerialTransport(Transport):
    """A serial port through pyserial (device path, pty, symlink, or URL like ``loop://``)."""

    def __init__(self, name: str, port: str, baudrate: int = 115200,
                 framer: Framer | None = None, backoff: Backoff | None = None) -> None:
        super().__init__(name, framer or DatagramFramer(), backoff)
        self.port = port
        self.baudrate = baudrate
        self._serial: serial.SerialBase | None = None

    def _open_device(self) -> None:
        try:
            self._serial = serial.serial_for_url(self.port, baudrate=self.baudrate, timeout=0.05,
                                                 write_timeout=0.05)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise LinkUnavailable(f"{self.name}: cannot open serial port {self.port!r} at "
                                  f"{self.baudrate} baud: {exc}; check the device exists and "
                                  "that you may open it (dialout group)") from None

    def _close_device(self) -> None:
        if self._serial is not None:
            with contextlib.suppress(OSError, serial.SerialException):
                self._serial.close()
            self._serial = None

    def _write(self, data: bytes) -> None:
        # no flush(): tcdrain would wait, without a timeout, for the far end to read
        assert self._serial is not None
        self._serial.write(data)

    def _read(self, timeout: float) -> list[bytes]:
        ser = self._serial
        assert ser is not None
        ser.timeout = timeout
        first = ser.read(1)
        if not first:
            return []
        waiting = ser.in_waiting
        return [first + (ser.read(waiting) if waiting else b"")]


@dataclass
class _ReaderState:
    thread: threading.Thread | None = None
    stop: threading.Event | None = None


class LinkReader:
    """Polls a transport on a daemon thread; ``sink(packets, t_monotonic)`` gets what came."""

    def __init__(self, transport: Transport, sink: Callable[[list[bytes], float], None],
                 poll_timeout: float = 0.1) -> None:
        """``poll_timeout``: how long one read may block; data wakes the read at once, so
        this only bounds how often an idle link's thread wakes up (and how long
        :meth:`stop` may take)."""
        self.transport = transport
        self.sink = sink
        self.poll_timeout = poll_timeout
        self._state = _ReaderState()

    @property
    def running(self) -> bool:
        t = self._state.thread
        return t is not None and t.is_alive()

    def start(self) -> None:
        if self.running:
            return
        stop = threading.Event()
        thread = threading.Thread(target=self._run, args=(stop,), daemon=True,
                                  name=f"link-{self.transport.name}")
        self._state = _ReaderState(thread, stop)
        thread.start()

    def stop(self, timeout: float = 1.0) -> None:
        state = self._state
        if state.stop is not None:
            state.stop.set()
        if state.thread is not None:
            state.thread.join(timeout)
        self._state = _ReaderState()

    def _run(self, stop: threading.Event) -> None:
        while not stop.is_set():
            packets = self.transport.poll(self.poll_timeout)
            if packets and not stop.is_set():
                self.sink(packets, time.monotonic())
