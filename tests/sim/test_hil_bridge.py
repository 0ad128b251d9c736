"""The HIL bridge's lock step after a wait ran out: the late packet stays paired with
its own command, so the next command waits for its own packet (and its latency is its
own), instead of every later command being applied one command late."""

from __future__ import annotations

from collections import deque
from types import SimpleNamespace

import pytest

from navstack.sim.vehicles.bridge import HilBridgeNode


class _FarSide:
    """The vehicle's reader, scripted: ``arrive(wall)`` consumes one command packet."""

    def __init__(self) -> None:
        self.alive = True
        self.packets_consumed = 0
        self.consumed_walls: deque[tuple[bool, float]] = deque()

    def arrive(self, wall: float) -> None:
        self.packets_consumed += 1
        self.consumed_walls.append((True, wall))

    def wait_consumed(self, count: int, timeout: float) -> bool:
        return self.packets_consumed >= count


def _bridge(far: _FarSide) -> SimpleNamespace:
    applied: list[float] = []
    return SimpleNamespace(vehicle=SimpleNamespace(far_side=far), _consumed_target=0,
                           _missed=0, sync_timeout=0.01, latencies=[], sync_timeouts=0,
                           now=0.0, applied=applied, _actuate=applied.append)


def test_a_late_command_packet_keeps_the_next_command_paired_with_its_own() -> None:
    far = _FarSide()
    bridge = _bridge(far)
    HilBridgeNode.on_command_written(bridge, b"1", 1.000)  # type: ignore[arg-type]
    assert bridge.sync_timeouts == 1 and bridge.latencies == []
    far.arrive(1.400)  # command 1's packet, late
    far.arrive(2.002)  # command 2's packet
    HilBridgeNode.on_command_written(bridge, b"2", 2.000)  # type: ignore[arg-type]
    assert bridge._consumed_target == 2 and bridge.sync_timeouts == 1
    assert bridge.latencies == [pytest.approx(0.002)]
    far.arrive(3.001)
    HilBridgeNode.on_command_written(bridge, b"3", 3.000)  # type: ignore[arg-type]
    assert bridge._consumed_target == 3 and bridge.latencies[-1] == pytest.approx(0.001)


def test_two_timeouts_in_a_row_resynchronise_on_what_arrived() -> None:
    """A packet that never comes (lost) must not make every later wait run out."""
    far = _FarSide()
    bridge = _bridge(far)
    HilBridgeNode.on_command_written(bridge, b"1", 1.0)  # type: ignore[arg-type]
    HilBridgeNode.on_command_written(bridge, b"2", 2.0)  # type: ignore[arg-type]
    assert bridge.sync_timeouts == 2 and bridge._consumed_target == 0
    far.arrive(3.001)
    HilBridgeNode.on_command_written(bridge, b"3", 3.0)  # type: ignore[arg-type]
    assert bridge.sync_timeouts == 2 and bridge._consumed_target == 1
    assert bridge.latencies == [pytest.approx(0.001)]
