"""Pseudo-terminal pairs: the driver opens the slave by a stable path, like a USB serial
device; the simulated vehicle holds the master.

The master is non-blocking: a vehicle never stalls because the driver is not reading.
The path is a symlink (``/tmp/.../ttyCART``) to the slave (``/dev/pts/N``), as udev's
``/dev/serial/by-id/...`` links are: a vehicle that "reboots" gets a new pty and the
link is re-pointed, and the driver's reconnect finds it under the same name.  The slave
is put in raw mode at once so nothing the vehicle writes before the driver opens it is
echoed or translated.
"""

from __future__ import annotations

import contextlib
import os
import pty
import select
import time
import tty
from pathlib import Path

from navstack.drivers.errors import LinkUnavailable
from navstack.drivers.framing import Framer
from navstack.drivers.transport import Transport

__all__ = ["PtyMasterTransport", "open_pty_link"]


def open_pty_link(link: Path) -> int:
    """A new pty pair whose slave is reachable at ``link``; returns the master fd."""
    master, slave = pty.openpty()
    tty.setraw(slave)
    target = os.ttyname(slave)
    os.close(slave)  # the driver opens it by name
    tmp = link.with_name(link.name + ".new")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    tmp.symlink_to(target)
    os.replace(tmp, link)  # atomic re-point
    return master


class PtyMasterTransport(Transport):
    """The vehicle's end of a pty pair, re-created at ``link`` on every open."""

    def __init__(self, name: str, link: Path, framer: Framer) -> None:
        super().__init__(name, framer)
        self.link = link
        self._fd: int | None = None

    def _open_device(self) -> None:
        try:
            self._fd = open_pty_link(self.link)
            os.set_blocking(self._fd, False)
        except OSError as exc:
            raise LinkUnavailable(f"{self.name}: cannot create a pty at {self.link}: {exc}"
                                  ) from None

    def _close_device(self) -> None:
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
            self._fd = None

    def _write(self, data: bytes) -> None:
        """Write without ever blocking: a serial line has no flow control, so when the
        reader does not keep up (or has not opened the port) the bytes are lost --
        :class:`BlockingIOError` here, counted by the transport as an I/O error."""
        assert self._fd is not None
        n = os.write(self._fd, data)
        if n < len(data):
            raise BlockingIOError(f"{self.name}: pty buffer full, {len(data) - n} bytes lost")

    def _read(self, timeout: float) -> list[bytes]:
        fd = self._fd
        assert fd is not None
        ready, _, _ = select.select([fd], [], [], timeout)
        if not ready:
            return []
        try:
            return [os.read(fd, 4096)]
        except BlockingIOError:
            # select reported the hang-up of a closed slave, and the driver opened it
            # before the read: nothing to read, and the pty is fine (closing it here
            # pulled the device from under the driver: EIO on its open or first write)
            return []
        except OSError as exc:
            if exc.errno == 5:  # EIO: the driver has not opened the slave (yet / any more)
                time.sleep(timeout)  # select keeps reporting it readable: do not spin
                return []
            raise
