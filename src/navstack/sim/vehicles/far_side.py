"""The vehicle's ends of its links: transports, one reader thread per link, and the
controls a link-loss test needs.

:class:`FarSide` reads every link on its own thread (like the vehicle's UART / network
stack), decodes commands with the vehicle's decoder and hands them to ``on_command``
with the wall time they were decoded -- from that thread, so the firmware object it
feeds must take the lock :attr:`FarSide.lock`.  Telemetry goes out with :meth:`send`.

``mute()`` makes the vehicle deaf and dumb while it keeps running (a radio fault):
packets are still read -- so nothing piles up in the OS -- but dropped, and nothing is
sent.  ``kill()`` powers it off: threads stop and the links close (the UDP socket
goes away, the pty master closes so the driver's port reports EIO).  ``restart()``
opens new links at the same addresses.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

from navstack.drivers.errors import MalformedPacket
from navstack.drivers.transport import LinkReader, Transport

__all__ = ["FarSide"]


class FarSide:
    """See module docstring.  ``decode(link, packet)`` returns a command or raises
    :class:`MalformedPacket`; ``command_links`` are the links commands arrive on."""

    def __init__(self, name: str, transports: Mapping[str, Transport],
                 decode: Callable[[str, bytes], Any],
                 on_command: Callable[[Any, float], None],
                 command_links: tuple[str, ...]) -> None:
        self.name = name
        self.transports = dict(transports)
        self.decode = decode
        self.on_command = on_command
        self.command_links = command_links
        self.lock = threading.Lock()
        self.consumed = threading.Condition()
        self.packets_consumed = 0
        self.commands = 0
        self.malformed = 0
        self.muted = False
        self.alive = False
        self.consumed_walls: deque[tuple[bool, float]] = deque(maxlen=1000)
        """Per command packet consumed: (decoded and applied, ``time.perf_counter()``)."""
        self._readers = {n: LinkReader(t, self._sink(n), poll_timeout=0.1)
                         for n, t in self.transports.items()}

    def _sink(self, link: str) -> Callable[[list[bytes], float], None]:
        def take(packets: list[bytes], _wall: float) -> None:
            for packet in packets:
                if link in self.command_links:
                    applied = False
                    if not self.muted:
                        try:
                            cmd = self.decode(link, packet)
                        except MalformedPacket:
                            self.malformed += 1
                        else:
                            with self.lock:
                                self.commands += 1
                                self.on_command(cmd, time.perf_counter())
                            applied = True
                    self.consumed_walls.append((applied, time.perf_counter()))
                with self.consumed:
                    self.packets_consumed += 1
                    self.consumed.notify_all()
        return take

    def start(self) -> None:
        for transport in self.transports.values():
            transport.open()
        for reader in self._readers.values():
            reader.start()
        self.alive = True

    def kill(self) -> None:
        """Power off: stop reading, close every link."""
        self.alive = False
        for reader in self._readers.values():
            reader.stop()
        for transport in self.transports.values():
            transport.close()

    def restart(self) -> None:
        """Power on again with fresh links at the same addresses."""
        self.muted = False
        self.start()

    def mute(self) -> None:
        self.muted = True

    def unmute(self) -> None:
        self.muted = False

    def send(self, link: str, packet: bytes) -> bool:
        """Write telemetry (dropped while muted or dead)."""
        if self.muted or not self.alive:
            return False
        return self.transports[link].write(packet)

    def wait_consumed(self, count: int, timeout: float) -> bool:
        """Block until ``count`` packets have been read (any outcome), at most ``timeout``
        wall seconds; ``False`` if they did not all arrive."""
        deadline = time.monotonic() + timeout
        with self.consumed:
            while self.packets_consumed < count:
                left = deadline - time.monotonic()
                if left <= 0 or not self.alive:
                    return False
                self.consumed.wait(left)
        return True
