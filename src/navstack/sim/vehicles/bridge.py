"""``HilBridgeNode``: the simulated vehicle's firmware driving the simulator's robot, on the
stack's clock, with its links in real I/O.

**How the two clocks meet.**  The stack runs on stepped simulated time; the links are
real sockets and ptys in wall time, read by threads.  The bridge keeps them in lock
step: simulated time does not advance while a packet is in flight.

* When the driver writes a command at simulated time *t* (:meth:`on_command_written`),
  the bridge waits -- in wall time, at most ``sync_timeout`` -- until the vehicle's
  reader thread has consumed it, then applies it to the firmware at *t* and actuates
  the robot at once.
* Telemetry is sampled at simulated time *t* on the bridge's timers, written by the
  vehicle, and the bridge waits until the driver's reader has queued it, then lets the
  driver decode and publish it (``deliver``) -- at *t*.

A wait that runs out (a reader thread starved of CPU for ``sync_timeout``) counts in
``sync_timeouts`` and leaves the packet in flight: it still counts towards its own
command or telemetry sample, so the packets that follow stay paired with their waits
(counting only what had arrived made every later command wait for the late packet
instead and be applied one command late for the rest of the run); a second timeout in
a row means packets were lost, and the counts resynchronise.

So a run through the wire is as deterministic as one in process (the bytes, not the
thread timing, decide what happens), its simulated latency is zero, and the wall time
each packet took (encode, write, OS, read, decode) is measured on the side
(:attr:`latencies`).  A vehicle that is muted or dead is not waited for: commands go
nowhere and the driver's watchdog, on the stack's clock, sees the silence.  Between
commands the firmware runs on its own timer (``actuation_rate_hz``, 50 Hz: the PID,
the stepper, the vehicle's watchdog).

The bridge also stands in for perfect localization: the simulator's own odometry is
wired away, so it publishes ``map -> odom`` = truth * (the driver's ``/odom``)^-1 at
10 Hz, future-dated by 0.1 s exactly as the simulator node does.
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from navstack.core.msgs import (
    Header,
    Odometry,
    TFMessage,
    Transform,
    TransformStamped,
    Twist2D,
)
from navstack.runtime.bus import QoS
from navstack.runtime.node import Node, Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.simulator import Simulator
from navstack.sim.vehicles.far_side import FarSide

__all__ = ["HilBridgeNode", "HilVehicle", "TelemetrySource"]


@dataclass(frozen=True)
class TelemetrySource:
    """One periodic telemetry stream: every ``period`` s, ``sample(sim, now, dt)`` gives
    the packets to send as ``(link, bytes)``."""

    name: str
    period: float
    sample: Callable[[Simulator, float, float], list[tuple[str, bytes]]]


class HilVehicle(ABC):
    """A simulated vehicle: firmware, the sensors it serves, its far-side links."""

    wired: frozenset[str]
    far_side: FarSide
    name: str

    def __init__(self) -> None:
        self.mailbox: deque[tuple[object, float]] = deque()

    def on_command(self, cmd: object, wall: float) -> None:
        """Called on the far side's thread (under its lock) for each decoded command."""
        self.mailbox.append((cmd, wall))

    @abstractmethod
    def receive(self, cmd: object, now: float) -> None:
        """Give the firmware a command at simulated time ``now`` (stack thread)."""

    @abstractmethod
    def actuate(self, sim: Simulator, now: float, dt: float) -> Twist2D | None:
        """Advance the firmware by ``dt``; the motion command for the robot, or ``None``
        to leave the robot's command alone."""

    @abstractmethod
    def telemetry(self) -> list[TelemetrySource]: ...

    @abstractmethod
    def power_off(self) -> None:
        """The vehicle died: its firmware forgets its command."""


class HilBridgeNode(Node):
    """See module docstring.  ``delivered(link)``: packets of ``link`` the driver has
    queued so far; ``deliver()``: make the driver decode and publish them now."""

    def __init__(self, runtime: Runtime, sim_node: SimulatorNode, vehicle: HilVehicle,
                 delivered: Callable[[str], int], deliver: Callable[[], None],
                 actuation_rate_hz: float = 50.0, sync_timeout: float = 1.0,
                 perfect_localization: bool = True, name: str = "hil_bridge") -> None:
        super().__init__(name, runtime)
        self.sim_node = sim_node
        self.vehicle = vehicle
        self.delivered = delivered
        self.deliver = deliver
        self.dt = 1.0 / actuation_rate_hz
        self.sync_timeout = sync_timeout
        self.perfect_localization = perfect_localization
        self._last_actuation = 0.0
        self._consumed_target = 0
        self._missed = 0  # consecutive command waits that timed out
        self._expected: dict[str, int] = {}  # telemetry packets written per link
        self._telemetry_missed: dict[str, int] = {}
        self.latencies: list[float] = []
        """Wall seconds from the driver receiving a command to the vehicle decoding it."""
        self.sync_timeouts = 0
        self._next_map_odom = 0.0

    def on_configure(self) -> None:
        self.pub_tf = self.create_publisher("/tf", TFMessage, QoS(depth=100))
        self.create_timer(self.dt, self._tick)
        self._streams = [self._telemetry(source) for source in self.vehicle.telemetry()]
        for source, stream in zip(self.vehicle.telemetry(), self._streams, strict=True):
            self.create_timer(source.period, stream)
        if self.perfect_localization:
            self.create_subscription("/odom", Odometry, self._on_odom, QoS(depth=10))

    def on_activate(self) -> None:
        # the first samples at activation, as the simulator node publishes its first
        # odometry then: navigation starts at the same instant as in process
        for stream in self._streams:
            stream()

    # --- commands ------------------------------------------------------------------------
    def on_command_written(self, packet: bytes, wall: float) -> None:
        """The driver wrote a command (stack thread): wait for the vehicle to read it,
        then apply it now."""
        far = self.vehicle.far_side
        if not far.alive:
            return
        target = self._consumed_target + 1
        if far.wait_consumed(target, self.sync_timeout):
            self._missed = 0
            if far.consumed_walls:
                applied, decoded = far.consumed_walls[-1]  # this command's packet
                if applied:
                    self.latencies.append(decoded - wall)
        else:
            self.sync_timeouts += 1
            self._missed += 1
            if self._missed > 1:  # twice in a row: packets were lost, not late
                target = far.packets_consumed
        # a late packet is still in flight: it counts towards this target, not the next
        # command's (else every later command would be applied one command late)
        self._consumed_target = target
        far.consumed_walls.clear()
        self._actuate(self.now)

    def _tick(self) -> None:
        self._actuate(self.now)

    def _actuate(self, now: float) -> None:
        self.sim_node.advance()
        v = self.vehicle
        while v.mailbox:
            cmd, _ = v.mailbox.popleft()
            v.receive(cmd, now)
        dt = max(0.0, now - self._last_actuation)
        self._last_actuation = now
        if not v.far_side.alive:
            v.power_off()
        twist = v.actuate(self.sim_node.sim, now, dt)
        if twist is not None:
            self.sim_node.sim.set_command(twist, now)

    # --- telemetry -----------------------------------------------------------------------
    def _telemetry(self, source: TelemetrySource) -> Callable[[], None]:
        last = [self.now]

        def run() -> None:
            self.sim_node.advance()
            now = self.now
            dt, last[0] = now - last[0], now
            far = self.vehicle.far_side
            sent_any = False
            for link, packet in source.sample(self.sim_node.sim, now, dt):
                # count the packets written, not those delivered: a packet that was late
                # once must not satisfy the wait for the next one (counted before the
                # write: the driver's reader may queue it at once)
                want = max(self._expected.get(link, 0), self.delivered(link)) + 1
                if far.send(link, packet):
                    sent_any = True
                    self._expected[link] = want
                    self._await_delivery(link, want)
            if sent_any:
                self.deliver()
        return run

    def _await_delivery(self, link: str, want: int) -> None:
        deadline = time.monotonic() + self.sync_timeout
        while self.delivered(link) < want:
            if time.monotonic() > deadline:
                self.sync_timeouts += 1
                missed = self._telemetry_missed.get(link, 0) + 1
                self._telemetry_missed[link] = missed
                if missed > 1:  # twice in a row: lost, not late -- count what came
                    self._expected[link] = self.delivered(link)
                return
            time.sleep(2e-5)
        self._telemetry_missed[link] = 0

    # --- perfect localization ------------------------------------------------------------
    def _on_odom(self, msg: Odometry) -> None:
        now = self.now
        if now + 1e-9 < self._next_map_odom:
            return
        self.sim_node.advance()
        odom_pose = msg.pose.pose.to_pose2d()
        transform = Transform.from_pose2d(self.sim_node.sim.pose.compose(odom_pose.inverse()))
        tfs = []
        if self._next_map_odom == 0.0:
            tfs.append(TransformStamped(Header(now, "map"), msg.header.frame_id, transform))
        tfs.append(TransformStamped(Header(now + 0.1, "map"), msg.header.frame_id, transform))
        self.pub_tf.publish(TFMessage(tuple(tfs)))
        self._next_map_odom = now + 0.1

    # --- figures -------------------------------------------------------------------------
    def latency_summary(self) -> dict[str, float]:
        """Command latency [ms]: count, median, p95, max (NaN when none was measured)."""
        if not self.latencies:
            return {"count": 0.0, "p50_ms": math.nan, "p95_ms": math.nan, "max_ms": math.nan}
        xs = sorted(self.latencies)
        pick = lambda q: 1000.0 * xs[min(len(xs) - 1, int(q * (len(xs) - 1) + 0.5))]  # noqa: E731
        return {"count": float(len(xs)), "p50_ms": pick(0.5), "p95_ms": pick(0.95),
                "max_ms": 1000.0 * xs[-1]}
