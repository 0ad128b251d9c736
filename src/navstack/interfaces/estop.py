"""The operator e-stop latch every live client shares (dashboard, phone, Telegram, joystick).

One latch per running stack (:attr:`LiveRunner.estop`).  Every operator source -- the web
API and its page button, the phone endpoint, the Telegram bot, a joystick button, a
hardware switch on the lock topic -- drives this same latch, so one release policy holds
for all of them:

* **Latching** is open to every source and idempotent: :meth:`EStopGate.latch`.  A
  ``std_msgs/Bool`` ``true`` published by anyone on the lock topic latches too (a
  hardware e-stop switch or a joystick node publishing there).
* **Releasing** needs an authorised requester: the dashboard/phone token or a
  whitelisted Telegram chat.  The caller authenticates, then calls :meth:`release`.  A
  ``false`` published on the lock topic by anyone else is an *unauthorised release*: it
  is refused (counted, logged as an event) and the latch re-asserts ``true`` at the same
  simulated instant.  Requesters that fail authentication are recorded with
  :meth:`refuse_release`.

Where it acts, in two layers:

1. the **lock topic** (``/emergency_stop``, ``std_msgs/Bool``, true = stop): twist_mux's
   ``e_stop_lock`` of the rover's configuration (priority 255), which masks every input
   and publishes zero while locked.  :func:`publish_lock` is the one place that writes
   it; the state is re-sent every ``heartbeat`` seconds so a mux lock with a timeout
   (twist_mux's dead-man semantics: a silent lock counts as locked) sees a live
   publisher;
2. the **last stage before the base** (``/cmd_vel``): while latched, every non-zero
   command that reaches the base's topic is answered at once, at the same simulated
   instant, by a zero command on the same topic (the bus delivers in order and no
   simulated time passes in between), so the base integrates zero velocity only -- even
   for a command that bypasses the mux.

The latch state is also published latched on ``/e_stop`` (``std_msgs/Bool``) for
dashboards and recorders.  Navigation is not cancelled: as with a hardware e-stop under
Nav2, the running task resumes after release (or fails through its progress checker).
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import asdict, dataclass
from typing import Any, Literal

from navstack.core.msgs import Bool, Twist
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Runtime

__all__ = ["LOCK_TOPIC", "STATUS_TOPIC", "EStopEvent", "EStopGate", "publish_lock"]

LOCK_TOPIC = "/emergency_stop"
"""twist_mux lock topic of the rover's ``e_stop_lock`` (std_msgs/Bool, true = stop)."""
STATUS_TOPIC = "/e_stop"
"""Latched e-stop state for dashboards and recorders (std_msgs/Bool)."""
HEARTBEAT = 0.1
"""Seconds between re-sends of the lock state (well inside any sensible lock timeout)."""
_log = logging.getLogger("navstack.estop")


def _is_zero(msg: Twist) -> bool:
    return (msg.linear.x == 0.0 and msg.linear.y == 0.0 and msg.linear.z == 0.0
            and msg.angular.x == 0.0 and msg.angular.y == 0.0 and msg.angular.z == 0.0)


def publish_lock(publisher: Any, stop: bool) -> Bool:
    """Write the e-stop lock value (``true`` = stop) -- the single place that does.

    Returns the message object (the latch recognises its own messages by identity)."""
    msg = Bool(bool(stop))
    publisher.publish(msg)
    return msg


@dataclass(frozen=True)
class EStopEvent:
    """One entry of the e-stop audit trail (simulated times [s])."""

    kind: Literal["latch", "release", "refused_release"]
    source: str
    time: float
    reason: str = ""
    requested_at: float | None = None


class EStopGate:
    """The latched operator e-stop (see the module docstring for the policy)."""

    def __init__(self, runtime: Runtime, topic: str = "/cmd_vel",
                 status_topic: str = STATUS_TOPIC, lock_topic: str = LOCK_TOPIC,
                 heartbeat: float = HEARTBEAT) -> None:
        self.runtime = runtime
        self.topic = topic
        self.lock_topic = lock_topic
        self._pub = runtime.bus.publisher(topic, Twist, QoS(depth=1))
        self._status = runtime.bus.publisher(status_topic, Bool, LATCHED)
        self._lock = runtime.bus.publisher(lock_topic, Bool, LATCHED)
        self._sub = runtime.bus.subscribe(topic, Twist, self._on_cmd, QoS(depth=10))
        self._own: deque[Bool] = deque(maxlen=16)
        self._lock_sub = runtime.bus.subscribe(lock_topic, Bool, self._on_lock, QoS(depth=10))
        self.latched = False
        self.latched_at: float | None = None
        self.released_at: float | None = None
        self.reason = ""
        self.source = ""
        self.overrides = 0
        self.refused_releases = 0
        self.events: deque[EStopEvent] = deque(maxlen=200)
        self._status.publish(Bool(False))
        self._assert_lock()
        if heartbeat > 0.0:
            runtime.scheduler.create_timer(heartbeat, self._assert_lock)

    # --- the policy ----------------------------------------------------------------------
    def latch(self, reason: str = "", source: str = "api",
              requested_at: float | None = None) -> float:
        """Latch (idempotent) and command zero velocity now; returns the latch time [s].

        ``source`` names who asked (``web``, ``phone``, ``telegram:<chat>``, ...);
        ``requested_at`` is when the request reached the stack's queue (for latency
        accounting)."""
        if not self.latched:
            self.latched = True
            self.latched_at = self.runtime.now
            self.reason = reason
            self.source = source
            self._status.publish(Bool(True))
            self.events.append(EStopEvent("latch", source, self.runtime.now, reason,
                                          requested_at))
            _log.info("e-stop latched by %s: %s", source, reason or "-")
        self._assert_lock()
        self._pub.publish(Twist())
        assert self.latched_at is not None
        return self.latched_at

    def release(self, source: str = "api") -> float:
        """Release the latch -- call only for an authenticated requester.  Commands pass
        again from the next one.  Returns the time [s]."""
        if self.latched:
            self.latched = False
            self.released_at = self.runtime.now
            self.reason = ""
            self.source = ""
            self._status.publish(Bool(False))
            self.events.append(EStopEvent("release", source, self.runtime.now))
            _log.info("e-stop released by %s", source)
        self._assert_lock()
        return self.runtime.now

    def refuse_release(self, source: str, why: str) -> None:
        """Record a release attempt that failed authentication (the latch stays)."""
        self.refused_releases += 1
        self.events.append(EStopEvent("refused_release", source, self.runtime.now, why))
        _log.warning("e-stop release refused (%s): %s", source, why)

    # --- bus ---------------------------------------------------------------------------
    def _assert_lock(self) -> None:
        self._own.append(publish_lock(self._lock, self.latched))

    def _on_lock(self, msg: Bool) -> None:
        if any(msg is own for own in self._own):
            return
        if msg.data:
            self.latch("stop on the lock topic", source=f"lock topic {self.lock_topic}",
                       requested_at=self.runtime.now)
        elif self.latched:
            self.refuse_release(f"lock topic {self.lock_topic}",
                                "a false on the lock topic does not release the latch; "
                                "release from an authorised operator interface")
            self._assert_lock()

    def _on_cmd(self, msg: Twist) -> None:
        if self.latched and not _is_zero(msg):
            self.overrides += 1
            self._pub.publish(Twist())

    def state(self) -> dict[str, Any]:
        return {"latched": self.latched, "latched_at": self.latched_at,
                "released_at": self.released_at, "reason": self.reason,
                "source": self.source, "overrides": self.overrides,
                "refused_releases": self.refused_releases}

    def history(self) -> list[dict[str, Any]]:
        """The audit trail, oldest first (plain JSON-able dicts)."""
        return [asdict(e) for e in self.events]
