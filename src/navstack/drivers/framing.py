"""Cutting a byte stream into packets.

A UDP datagram is one packet; a serial port delivers a stream that must be cut:

* :class:`LineFramer` -- text lines (the cart's sensor Arduino, NMEA).  A line longer
  than ``max_line`` is noise: it is dropped up to the next newline and counted.
* :class:`FixedFramer` -- fixed-size binary packets with no header (the cart's ``'<fi'``
  command).  Without a header a lost byte would shift every later packet, so when a
  ``plausible`` test is given a failing window slides by one byte until a plausible
  packet lines up again (the resynchronised bytes are counted).
* :class:`GnssFramer` -- a u-blox receiver's mixed output: NMEA lines (``$`` ... LF)
  and UBX frames (``0xB5 0x62`` class id length payload checksum), with garbage between
  them skipped and counted.

Each framer keeps at most ``max_buffer`` bytes, so a stream of noise cannot grow memory.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

__all__ = ["DatagramFramer", "FixedFramer", "Framer", "GnssFramer", "LineFramer"]


class Framer(ABC):
    """Base: ``feed(data) -> packets``; counts bytes thrown away."""

    def __init__(self) -> None:
        self.dropped_bytes = 0
        self.dropped_frames = 0

    @abstractmethod
    def feed(self, data: bytes) -> list[bytes]:
        """The complete packets ``data`` finishes (partial ones are kept)."""

    @abstractmethod
    def reset(self) -> None:
        """Forget a partial packet (after a reconnect)."""


class DatagramFramer(Framer):
    """Every datagram is one packet -- an empty one too, so the decoder reports it (a
    zero-length datagram is malformed, not nothing)."""

    def reset(self) -> None:
        """Nothing is buffered between datagrams."""

    def feed(self, data: bytes) -> list[bytes]:
        return [data]


class LineFramer(Framer):
    """Lines ending in ``\\n`` (a preceding ``\\r`` is kept for the decoder to strip)."""

    def __init__(self, max_line: int = 256) -> None:
        super().__init__()
        self.max_line = max_line
        self._buf = bytearray()
        self._discarding = False

    def reset(self) -> None:
        self._buf.clear()
        self._discarding = False

    def feed(self, data: bytes) -> list[bytes]:
        out: list[bytes] = []
        self._buf += data
        while True:
            end = self._buf.find(b"\n")
            if end < 0:
                if len(self._buf) > self.max_line:  # no newline in sight: noise
                    self.dropped_bytes += len(self._buf)
                    if not self._discarding:
                        self.dropped_frames += 1
                    self._discarding = True
                    self._buf.clear()
                return out
            line = bytes(self._buf[:end + 1])
            del self._buf[:end + 1]
            if self._discarding or len(line) > self.max_line:
                self.dropped_bytes += len(line)
                if not self._discarding:
                    self.dropped_frames += 1
                self._discarding = False
                continue
            out.append(line)


class FixedFramer(Framer):
    """Fixed ``size``-byte packets; with ``plausible`` a bad window slides one byte."""

    def __init__(self, size: int, plausible: Callable[[bytes], bool] | None = None,
                 max_buffer: int = 4096) -> None:
        super().__init__()
        self.size = size
        self.plausible = plausible
        self.max_buffer = max_buffer
        self.resync_bytes = 0
        self._buf = bytearray()

    def reset(self) -> None:
        self._buf.clear()

    def feed(self, data: bytes) -> list[bytes]:
        out: list[bytes] = []
        self._buf += data
        if len(self._buf) > self.max_buffer:
            cut = len(self._buf) - self.max_buffer
            self.dropped_bytes += cut
            del self._buf[:cut]
        while len(self._buf) >= self.size:
            window = bytes(self._buf[:self.size])
            if self.plausible is not None and not self.plausible(window):
                del self._buf[0]
                self.resync_bytes += 1
                self.dropped_bytes += 1
                continue
            out.append(window)
            del self._buf[:self.size]
        return out


class GnssFramer(Framer):
    """NMEA sentences and UBX frames from one stream (u-blox receivers send both)."""

    def __init__(self, max_line: int = 120, max_ubx: int = 1024) -> None:
        super().__init__()
        self.max_line = max_line
        self.max_ubx = max_ubx
        self._buf = bytearray()

    def reset(self) -> None:
        self._buf.clear()

    def feed(self, data: bytes) -> list[bytes]:
        out: list[bytes] = []
        buf = self._buf
        buf += data
        while buf:
            dollar, ubx = buf.find(b"$"), buf.find(b"\xb5\x62")
            starts = [i for i in (dollar, ubx) if i >= 0]
            if not starts:  # nothing that can start a frame; keep a trailing 0xB5
                keep = 1 if buf[-1:] == b"\xb5" else 0
                self.dropped_bytes += len(buf) - keep
                del buf[:len(buf) - keep]
                break
            start = min(starts)
            if start:
                self.dropped_bytes += start
                del buf[:start]
            if buf[:1] == b"$":
                end = buf.find(b"\n")
                if end < 0:
                    if len(buf) > self.max_line:
                        self._drop(1)
                        continue
                    break
                if end + 1 > self.max_line:
                    self._drop(1)
                    continue
                out.append(bytes(buf[:end + 1]))
                del buf[:end + 1]
                continue
            if len(buf) < 6:
                break
            total = 8 + int.from_bytes(buf[4:6], "little")
            if total > self.max_ubx:
                self._drop(2)
                continue
            if len(buf) < total:
                break
            out.append(bytes(buf[:total]))
            del buf[:total]
        return out

    def _drop(self, n: int) -> None:
        self.dropped_bytes += n
        self.dropped_frames += 1
        del self._buf[:n]
