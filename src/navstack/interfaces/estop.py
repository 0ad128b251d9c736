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
    the simulation thread."""

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
        self._pub = runtime.bus.publisher(topic, Twist, QoS(depth=1))
        self._seen = False  # lock state as last recorded in the audit trail
        self._reason = ""
        runtime.bus.subscribe(LOCK_TOPIC, Bool, self._on_lock, QoS(depth=10))
        with contextlib.suppress(BusError):  # a TwistStamped base: the mux alone acts
            runtime.bus.subscribe(topic, Twist, self._on_cmd, QoS(depth=10))

    # --- state: the lock as every client sees it on the bus --------------------------------
    @property
    def latched(self) -> bool:
        return self.client.latched

    @property
    def latched_at(self) -> float | None:
        return self.client.latched_at

    @property
    def released_at(self) -> float | None:
        return self.client.released_at

    @property
    def reason(self) -> str:
        """Why the latch was set (by whichever authority latched last)."""
        return self._reason if self.latched else ""

    @property
    def holder(self) -> str:
        """Authority holding the latch ("" when released or latched by a raw publisher)."""
        return self.client.holder

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
        was = self.latched
        t = self.client_for(source).latch(reason)
        self._pub.publish(Twist())
        self._seen, self._reason = True, reason
        if not was:
            self.events.append(EStopEvent("latch", source, self.runtime.now, reason,
                                          requested_at))
            _log.info("e-stop latched by %s: %s", source, reason or "-")
        return t

    def release(self, source: str | None = None) -> float:
        """Release as ``source`` -- an authenticated requester.  Raises
        :class:`EStopReleaseRefused` (recorded) unless ``source`` holds the latch."""
        source = source or self.authority
        was = self.latched
        if was and self.holder != source:
            # judged on the gate's own client, which has seen every change of the lock (a
            # client created just now has not yet had the latched messages delivered)
            held = (f"held by '{self.holder}'" if self.holder
                    else f"latched by a publisher on {LOCK_TOPIC}")
            where = "release it there" if self.holder else f"release it with false on {LOCK_TOPIC}"
            exc = EStopReleaseRefused(f"the e-stop is {held}, not by '{source}'; {where}")
            self.refuse_release(source, str(exc))
            raise exc
        t = self.client_for(source).release() if was else self.runtime.now
        self._seen = False
        if was:
            self.events.append(EStopEvent("release", source, self.runtime.now))
            _log.info("e-stop released by %s", source)
        return t

    def refuse_release(self, source: str, why: str) -> None:
        """Record a release attempt that was refused (the latch stays)."""
        self.refused_releases += 1
        self.events.append(EStopEvent("refused_release", source, self.runtime.now, why))
        _log.warning("e-stop release refused (%s): %s", source, why)

    # --- bus ---------------------------------------------------------------------------
    def _on_lock(self, _msg: Bool) -> None:
        """A change of the lock made by another publisher (a switch, a joystick node, a
        raw ``false``): zero the base at once on a latch, and record it."""
        if self.latched == self._seen:
            return
        self._seen = self.latched
        who = self.holder or f"lock topic {LOCK_TOPIC}"
        self._reason = ""
        if self.latched:
            self._pub.publish(Twist())
            self.events.append(EStopEvent("latch", who, self.runtime.now, "",
                                          self.runtime.now))
        else:
            self.events.append(EStopEvent("release", who, self.runtime.now))
        _log.info("e-stop %s by %s", "latched" if self.latched else "released", who)

    def _on_cmd(self, msg: Twist) -> None:
        if self.latched and not _is_zero(msg):
            self.overrides += 1
            self._pub.publish(Twist())

    def state(self) -> dict[str, Any]:
        return {"latched": self.latched, "latched_at": self.latched_at,
                "released_at": self.released_at, "reason": self.reason,
                "holder": self.holder, "overrides": self.overrides,
                "refused_releases": self.refused_releases}

    def history(self) -> list[dict[str, Any]]:
        """The audit trail, oldest first (plain JSON-able dicts)."""
        return [asdict(e) for e in self.events]
