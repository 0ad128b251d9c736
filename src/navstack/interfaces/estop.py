"""The live stack's e-stop hub: every operator interface latches the one twist_mux lock.

The contract is ``docs/command_path.md``: the latch is twist_mux's ``e_stop_lock`` on
``/emergency_stop`` (``std_msgs/Bool``, true = stop), driven by
:class:`~navstack.nodes.estop.EStopClient` objects that each carry an *authority*
(``web``, ``phone``, ``telegram:<chat_id>``, ``joystick``); the authority that latched
releases, a latch by a raw publisher on the lock topic is released only by a raw false
there.  :class:`EStopGate` (``LiveRunner.estop``) keeps one client per authority, so the
dashboard, the phone endpoint and the Telegram bot all go through the same lock:

* :meth:`EStopGate.latch` -- open to every authenticated source and idempotent;
* :meth:`EStopGate.release` -- for an authenticated requester; refused
  (:class:`~navstack.nodes.estop.EStopReleaseRefused`) unless its authority holds the
  latch; requesters that fail authentication are recorded with :meth:`refuse_release`.

Where it acts: the mux publishes zero at the instant the lock engages and masks every
input below priority 255.  As a second layer at the last stage before the base, while the
lock is engaged every non-zero command that still reaches ``/cmd_vel`` (a publisher that
bypasses the mux) is answered at the same simulated instant by a zero on that topic, and
latching publishes a zero at once: the bus delivers in order and no simulated time passes
in between, so the base integrates zero velocity only.  Every latch, release and refusal
is kept in an audit trail (:meth:`EStopGate.history`).

Navigation is not cancelled: as with a hardware e-stop under Nav2, the running task
resumes after release (or fails through its progress checker).
"""

from __future__ import annotations

import contextlib
import logging
from collections import deque
from dataclasses import asdict, dataclass
from typing import Any, Literal

from navstack.core.errors import BusError
from navstack.core.msgs import Bool, Twist
from navstack.nodes.estop import LOCK_TOPIC, SOURCE_TOPIC, EStopClient, EStopReleaseRefused
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime

__all__ = ["LOCK_TOPIC", "SOURCE_TOPIC", "EStopEvent", "EStopGate", "EStopReleaseRefused"]
_log = logging.getLogger("navstack.estop")


def _is_zero(msg: Twist) -> bool:
    return (msg.linear.x == 0.0 and msg.linear.y == 0.0 and msg.linear.z == 0.0
            and msg.angular.x == 0.0 and msg.angular.y == 0.0 and msg.angular.z == 0.0)


@dataclass(frozen=True)
class EStopEvent:
    """One entry of the e-stop audit trail (simulated times [s])."""

    kind: Literal["latch", "release", "refused_release"]
    source: str
    time: float
    reason: str = ""
    requested_at: float | None = None


class EStopGate:
    """One :class:`EStopClient` per authority on the shared lock, plus the ``/cmd_vel``
    backstop.  ``authority`` is the default source (the dashboard's ``web``).  Use it in
    the simulation thread.

    The gate's state changes at once when it latches or releases (what a reply to the
    operator must reflect), and follows the lock topic for changes made elsewhere (a
    switch, a joystick node): the values it published itself are recognised in delivery
    order and not counted twice."""

    def __init__(self, runtime: Runtime, topic: str = "/cmd_vel",
                 authority: str = "web") -> None:
        self.runtime = runtime
        self.topic = topic
        self.authority = authority
        self.client = EStopClient(runtime, authority)
        self._clients: dict[str, EStopClient] = {authority: self.client}
        self.overrides = 0
        self.refused_releases = 0
        self.events: deque[EStopEvent] = deque(maxlen=200)
        self.latched = False
        self.holder = ""
        """Authority holding the latch ("" when released or latched by a raw publisher)."""
        self.latched_at: float | None = None
        self.released_at: float | None = None
        self._reason = ""
        self._expected: deque[bool] = deque()  # own lock values not yet delivered back
        self._pub = runtime.bus.publisher(topic, Twist, QoS(depth=1))
        # subscribed after self.client: its holder is up to date when _on_lock runs
        runtime.bus.subscribe(LOCK_TOPIC, Bool, self._on_lock, QoS(depth=100))
        with contextlib.suppress(BusError):  # a TwistStamped base: the mux alone acts
            runtime.bus.subscribe(topic, Twist, self._on_cmd, QoS(depth=10))

    @property
    def reason(self) -> str:
        """Why the latch was set (by whichever authority latched last)."""
        return self._reason if self.latched else ""

    def client_for(self, authority: str) -> EStopClient:
        """The lock client of ``authority`` (created on first use)."""
        client = self._clients.get(authority)
        if client is None:
            client = self._clients[authority] = EStopClient(self.runtime, authority)
        return client

    # --- the policy ----------------------------------------------------------------------
    def latch(self, reason: str = "", source: str | None = None,
              requested_at: float | None = None) -> float:
        """Latch as ``source`` (default: this gate's authority) and command zero now;
        returns the time [s] the lock was first latched.  ``requested_at`` is when the
        request reached the simulation queue (for latency accounting)."""
        source = source or self.authority
        self.client_for(source).latch(reason)
        self._expected.append(True)
        self._pub.publish(Twist())
        now = self.runtime.now
        if not self.latched:
            self.latched, self.latched_at = True, now
            self.events.append(EStopEvent("latch", source, now, reason, requested_at))
            _log.info("e-stop latched by %s: %s", source, reason or "-")
        self.holder, self._reason = source, reason
        assert self.latched_at is not None
        return self.latched_at

    def release(self, source: str | None = None) -> float:
        """Release as ``source`` -- an authenticated requester.  Raises
        :class:`EStopReleaseRefused` (recorded) unless ``source`` holds the latch."""
        source = source or self.authority
        now = self.runtime.now
        if not self.latched:
            return now
        if self.holder != source:
            held = (f"held by '{self.holder}'" if self.holder
                    else f"latched by a publisher on {LOCK_TOPIC}")
            where = "release it there" if self.holder else f"release it with false on {LOCK_TOPIC}"
            exc = EStopReleaseRefused(f"the e-stop is {held}, not by '{source}'; {where}")
            self.refuse_release(source, str(exc))
            raise exc
        client = self.client_for(source)
        if not client.latched:  # latched through another client of this authority
            client.latch(self._reason)
            self._expected.append(True)
        client.release()
        self._expected.append(False)
        self._released(now)
        self.events.append(EStopEvent("release", source, now))
        _log.info("e-stop released by %s", source)
        return now

    def refuse_release(self, source: str, why: str) -> None:
        """Record a release attempt that was refused (the latch stays)."""
        self.refused_releases += 1
        self.events.append(EStopEvent("refused_release", source, self.runtime.now, why))
        _log.info("e-stop release refused (%s): %s", source, why)

    def _released(self, now: float) -> None:
        self.latched, self.holder, self._reason = False, "", ""
        self.released_at = now

    # --- bus ---------------------------------------------------------------------------
    def _on_lock(self, msg: Bool) -> None:
        """A value on the lock topic: our own coming back, or a change made elsewhere (a
        switch, a joystick node, a raw release): zero the base at once on a latch, and
        record it."""
        if self._expected and self._expected[0] == msg.data:
            self._expected.popleft()
            return
        now = self.runtime.now
        if msg.data:
            who = self.client.holder or f"lock topic {LOCK_TOPIC}"
            self._pub.publish(Twist())
            if not self.latched:
                self.latched, self.latched_at = True, now
                self.events.append(EStopEvent("latch", who, now, "", now))
                _log.info("e-stop latched by %s", who)
            self.holder, self._reason = self.client.holder, ""
        elif self.latched:
            who = self.holder or f"lock topic {LOCK_TOPIC}"
            self._released(now)
            self.events.append(EStopEvent("release", who, now))
            _log.info("e-stop released on %s (held by %s)", LOCK_TOPIC, who)

    def _on_cmd(self, msg: Twist) -> None:
        if not self.latched:
            return
        if _is_zero(msg):
            self.overrides += 1  # a zero the base got while latched (the mux's, or ours)
        else:  # a command that bypassed the mux: answered at once
            self._pub.publish(Twist())

    def state(self) -> dict[str, Any]:
        return {"latched": self.latched, "latched_at": self.latched_at,
                "released_at": self.released_at, "reason": self.reason,
                "holder": self.holder, "overrides": self.overrides,
                "refused_releases": self.refused_releases}

    def history(self) -> list[dict[str, Any]]:
        """The audit trail, oldest first (plain JSON-able dicts)."""
        return [asdict(e) for e in self.events]
