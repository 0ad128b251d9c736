"""Lockstep simulated time between processes: a split simulation that is reproducible on
a loaded machine (issue 21).

On a wall clock, a starved process runs late and a split run diverges from the
in-process run with the same seed.  In lockstep both processes run stepped simulated time
(as fast as they can) and never drift apart by more than one ``quantum``: the robot (the
*master*, which owns the simulator) announces its elapsed simulated time every
``quantum``; the base (the *follower*) runs up to what was announced and acknowledges;
the master runs at most one quantum past the last acknowledgement.  While a loop waits
its posted work (remote goals, service calls) still runs, so blocking calls across the
link cannot deadlock.  Each process keeps its own clock offset: elapsed time, not clock
readings, is what is shared -- the clocks still disagree by their offsets and the link
still has to estimate and compensate them.  The barrier messages are simulation
machinery, not radio traffic: impairments do not touch them.  The threaded NTP probes
still estimate the offset, but stepped clocks read from another thread are off by however
far the loop got in between: in lockstep the estimate is good to tens of milliseconds,
not to the 5 ms a wall-clock link achieves.
"""

from __future__ import annotations

import math
import struct
import time
from typing import Literal

import zenoh

from navstack.core.errors import BusError
from navstack.runtime.transports.keys import navstack_key
from navstack.runtime.transports.zenoh_link import ZenohLink

_ELAPSED = struct.Struct("<dd")  # elapsed simulated time, sender's clock at that time


class Lockstep:
    """Couples ``link``'s scheduler (sim mode) to ``peer``'s (module docstring)."""

    def __init__(self, link: ZenohLink, role: Literal["master", "follower"], peer: str,
                 quantum: float = 0.005, stall_timeout: float = 30.0) -> None:
        if link.scheduler.mode != "sim" or link.scheduler.rate is not None:
            raise ValueError("lockstep needs an unthrottled 'sim' scheduler")
        if not quantum > 0.0:
            raise ValueError(f"lockstep quantum must be > 0, got {quantum}")
        self.link, self.role, self.quantum, self.peer = link, role, quantum, peer
        self.stall_timeout = stall_timeout
        self._stalled_since = math.inf
        self._seen_peer = False
        self.scheduler = sched = link.scheduler
        self.t0 = sched.now
        self.peer_elapsed = 0.0
        self._announced = -1.0
        master = link.params.name if role == "master" else peer
        d = link.params.domain_id
        self._tick_key = navstack_key(d, "lockstep", master, "tick")
        self._ack_key = navstack_key(d, "lockstep", master, "ack")
        listen = self._ack_key if role == "master" else self._tick_key
        link._entities.append(link.session.declare_subscriber(listen, self._on_peer))
        sched.horizon = self._horizon
        sched.on_blocked = self._blocked
        if role == "master":
            sched.create_timer(quantum, self._tick, first_at=self.t0 + quantum)
        self.barriers = 0

    def _horizon(self) -> float:
        lookahead = self.quantum if self.role == "master" else 0.0
        return self.t0 + self.peer_elapsed + lookahead + 1e-9

    def _on_peer(self, sample: zenoh.Sample) -> None:
        elapsed, their_clock = _ELAPSED.unpack(sample.payload.to_bytes())
        del their_clock  # informational (the threaded NTP probes estimate the offset)
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
        if self.role == "master":
            if self._seen_peer and not present and now - self._stalled_since > 1.0:
                self.close()  # the base is gone: the robot runs on (and stops) alone
                return
            self._tick()  # (again: a follower that joined late missed the first one)
            return
        if now - self._stalled_since > self.stall_timeout:
            raise BusError(f"lockstep: no time from '{self.peer}' for "
                           f"{self.stall_timeout:g} s (is it running?)")
        self._ack()

    def _ack(self) -> None:
        """Acknowledge the announced time (again while still blocked: acks can be lost
        while the master's session is still connecting)."""
        if self.peer_elapsed > self._announced:
            self._announced = self.peer_elapsed
            self.barriers += 1
        self.link.session.put(self._ack_key, _ELAPSED.pack(self.peer_elapsed,
                                                           self.t0 + self.peer_elapsed))

    def close(self) -> None:
        self.scheduler.horizon = None
        self.scheduler.on_blocked = None
