"""Lockstep simulated time between processes: a split simulation that is reproducible on
a loaded machine and matches the same stack run in one process (issue 21).

On a wall clock, a starved process runs late and a split run diverges from the
in-process run with the same seed.  In lockstep both processes run stepped simulated time
(as fast as they can) and never drift apart by more than one ``quantum``: the robot (the
*master*, which owns the simulator) announces its elapsed simulated time every
``quantum``; the base (the *follower*) runs up to what was announced and acknowledges;
the master runs at most one quantum past the last acknowledgement (conservative
parallel discrete-event simulation, Chandy & Misra 1979, with a lookahead of one quantum).

Deterministic delivery.  Every message between the two carries its sender's elapsed
simulated time (:meth:`Lockstep.mark`) and is delivered at a time fixed by it, never at
whenever the network thread handed it over: master -> follower at the same elapsed
time (the follower is never past the master's last announcement), follower -> master one
quantum later (the master is never more than a quantum past the follower's last
acknowledgement).  Heartbeats count as heard at that time too.  A follower that blocks
on a call to the master (an action goal, a service) first acknowledges its own time, so
the master can run up to the call and answer it.  Start: neither side runs past the first
quantum until both know each other's clock and have read the peer's latched topics
(``/map``, ``/tf_static``), so no message is lost or dropped depending on who started
first.

Clocks.  Each process keeps its own clock offset: elapsed time, not clock readings, is
what is shared -- the clocks still disagree by their offsets and stamps are still
compensated.  The barrier messages carry (elapsed, clock reading at that elapsed time), an
NTP exchange on the shared simulated time with no transit time in the model: the offset
estimate is exact, and the threaded NTP probes (whose stepped clocks would be read from
another thread) are off.  The wall-clock link is where the NTP estimate is measured.
The barrier messages are simulation machinery, not radio traffic: impairments do not
touch them.
"""

from __future__ import annotations

import math
import struct
import threading
import time
from collections.abc import Callable
from typing import Literal

import zenoh

from navstack.core.errors import BusError
from navstack.runtime.transports.clock_sync import exchange_sample
from navstack.runtime.transports.keys import navstack_key
from navstack.runtime.transports.zenoh_link import MARK, ZenohLink, direct

_ELAPSED = struct.Struct("<dd")  # elapsed simulated time, sender's clock at that time

#: where lockstep clocks start (plus each process's offset): not at the wall-clock epoch,
#: where a float second keeps only 0.24 us -- the same stack run in one process from
#: 1.77e9 s failed a goal of the office mission that it reaches from 1000 s
SIM_EPOCH = 1000.0


class Lockstep:
    """Couples ``link``'s scheduler (sim mode) to ``peer``'s (module docstring).

    ``gate()``: whether this side may start (default: the link's
    :meth:`~ZenohLink.started`)."""

    def __init__(self, link: ZenohLink, role: Literal["master", "follower"], peer: str,
                 quantum: float = 0.005, stall_timeout: float = 30.0,
                 gate: Callable[[], bool] | None = None) -> None:
        if link.scheduler.mode != "sim" or link.scheduler.rate is not None:
            raise ValueError("lockstep needs an unthrottled 'sim' scheduler")
        if not quantum > 0.0:
            raise ValueError(f"lockstep quantum must be > 0, got {quantum}")
        self.link, self.role, self.quantum, self.peer = link, role, quantum, peer
        self.stall_timeout = stall_timeout
        self.gate = gate or link.started
        self.open = False
        self._stalled_since = math.inf
        self._seen_peer = False
        self.scheduler = sched = link.scheduler
        self.t0 = sched.now
        #: delivery delay of the peer's messages in simulated time (module docstring)
        self.lag = quantum if role == "master" else 0.0
        self.peer_elapsed = 0.0
        self.acked = -1.0
        self._lock = threading.Lock()
        master = link.params.name if role == "master" else peer
        d = link.params.domain_id
        self._tick_key = navstack_key(d, "lockstep", master, "tick")
        self._ack_key = navstack_key(d, "lockstep", master, "ack")
        listen = self._ack_key if role == "master" else self._tick_key
        link.lockstep = self
        link.probing = False  # the barrier exchanges the clocks (module docstring)
        link._entities.append(link.session.declare_subscriber(listen, direct(self._on_peer)))
        sched.horizon = self._horizon
        sched.on_blocked = self._blocked
        if role == "master":
            sched.create_timer(quantum, self._tick, first_at=self.t0 + quantum)
        self.barriers = 0

    # --- time stamps of messages --------------------------------------------------------
    def elapsed(self) -> float:
        """Simulated seconds since this side started."""
        return self.scheduler.now - self.t0

    def mark(self) -> bytes:
        """This loop's elapsed time, attached to every message it sends."""
        return MARK.pack(self.elapsed())

    def arrival(self, mark: bytes | None) -> float | None:
        """This process's time at which a peer message carrying ``mark`` is delivered
        (``None`` without a mark)."""
        if mark is None or len(mark) < MARK.size:
            return None
        (elapsed,) = MARK.unpack(mark[-MARK.size:])
        return self.t0 + elapsed + self.lag

    # --- the barrier ------------------------------------------------------------------------
    def _horizon(self) -> float:
        if self.role == "master":
            ahead = self.peer_elapsed if self.open else 0.0
            return self.t0 + ahead + self.quantum + 1e-9
        return self.t0 + self.peer_elapsed + 1e-9

    def _on_peer(self, sample: zenoh.Sample) -> None:
        elapsed, their_clock = _ELAPSED.unpack(sample.payload.to_bytes())
        mine = self.t0 + elapsed  # my clock at the same elapsed time
        with self._lock:
            state = self.link.peer(self.peer)
            state.estimator.add(exchange_sample(mine, their_clock, their_clock, mine))
            state.answered += 1
            if elapsed > self.peer_elapsed:
                self.peer_elapsed = elapsed
                self._stalled_since = math.inf
        self.scheduler.wake()

    def _tick(self) -> None:
        self.barriers += 1
        now = self.scheduler.now
        self.link.session.put(self._tick_key, _ELAPSED.pack(now - self.t0, now))

    def _blocked(self) -> None:
        """The loop waits at the horizon: acknowledge (follower); give up on a peer that
        left (master: run on alone) or is silent for ``stall_timeout`` (follower)."""
        now = time.monotonic()
        self._stalled_since = min(self._stalled_since, now)
        present = self.peer in self.link.present
        self._seen_peer = self._seen_peer or present
        self.open = self.open or self.gate()
        if self.role == "master":
            if self._seen_peer and not present and now - self._stalled_since > 1.0:
                self.close()  # the base is gone: the robot runs on (and stops) alone
                return
            self._tick()  # (again: a follower that joined late missed the first one)
            return
        if now - self._stalled_since > self.stall_timeout:
            raise BusError(f"lockstep: no time from '{self.peer}' for "
                           f"{self.stall_timeout:g} s (is it running?)")
        self._ack(self.peer_elapsed if self.open else 0.0)

    def release(self) -> None:
        """Before a blocking call to the master: acknowledge this loop's own time so the
        master can run up to the call and answer it (follower; no-op on the master)."""
        if self.role == "follower" and self.open:
            self._ack(max(self.acked, self.elapsed()))

    def _ack(self, elapsed: float) -> None:
        """Acknowledge ``elapsed`` (again while still blocked: acks can be lost while
        the master's session is still connecting)."""
        elapsed = max(self.acked, elapsed)
        if elapsed > self.acked:
            self.acked = elapsed
            self.barriers += 1
        self.link.session.put(self._ack_key, _ELAPSED.pack(elapsed, self.t0 + elapsed))

    def close(self) -> None:
        self.scheduler.horizon = None
        self.scheduler.on_blocked = None
        self.link.lockstep = None
