"""The simulated vehicle's pty: a driver that opens the port right after the vehicle
powers on gets a working link, every time."""

from __future__ import annotations

from pathlib import Path

import pytest

from navstack.drivers.framing import FixedFramer
from navstack.drivers.transport import SerialTransport
from navstack.sim.vehicles import pty as pty_module
from navstack.sim.vehicles.pty import PtyMasterTransport


def test_driver_opening_between_select_and_read_keeps_the_vehicle_pty(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The vehicle's reader saw the unopened slave's hang-up as readable, the driver
    opened the slave before the read, and the read's EAGAIN closed the master: the
    driver's open or first write then failed with EIO (half the link benchmark's CI
    runs).  The interleaving is forced here: select reports readable after the open."""
    link = tmp_path / "ttyTEST"
    vehicle = PtyMasterTransport("steering", link, FixedFramer(4))
    vehicle.open()
    driver = SerialTransport("steering", str(link), 115200)
    driver.open()
    with monkeypatch.context() as m:
        m.setattr(pty_module.select, "select", lambda r, w, x, t: (list(r), [], []))
        assert vehicle.poll(0.0) == []  # EAGAIN: nothing yet, the link stays up
    assert vehicle.is_open and vehicle.stats.opens == 1
    assert driver.write(b"abcd"), driver.stats
    got: list[bytes] = []
    for _ in range(50):
        got += vehicle.poll(0.02)
        if got:
            break
    assert got == [b"abcd"]
    driver.close()
    vehicle.close()
