"""``EStopClient``: one e-stop source driving twist_mux's lock (``docs/command_path.md``).

Every e-stop source -- the dashboard, the phone endpoint, the Telegram bot, the joystick --
latches and releases the same lock, ``/emergency_stop`` (``std_msgs/Bool``; the rover's
``e_stop_lock``), through a client that knows its **authority** (``web``, ``phone``,
``telegram:<chat_id>``, ``joystick``).  Before each value it publishes the authority on
``/emergency_stop/source`` (``std_msgs/String``; empty before a release), both latched, so
every client (and a dashboard that joins later) knows whether the lock is held and by
whom.  A release is refused (:class:`EStopReleaseRefused`) unless this client's authority
holds the latch: the authority that latched releases it.  A latch by a raw publisher on
the lock topic has no authority and is released only by a raw ``False`` on the topic.

Authentication (token, chat whitelist, physical presence) is the interface's job before it
calls :meth:`EStopClient.release`; the client enforces "same authority".
"""

from __future__ import annotations

from navstack.core.errors import NavstackError
from navstack.core.msgs import Bool, String
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Runtime

__all__ = ["LOCK_TOPIC", "SOURCE_TOPIC", "EStopClient", "EStopReleaseRefused"]

LOCK_TOPIC = "/emergency_stop"
"""twist_mux lock ``e_stop_lock`` (priority 255, timeout 0) -- the one e-stop latch."""
SOURCE_TOPIC = "/emergency_stop/source"
"""The authority of the last value on :data:`LOCK_TOPIC` ("" for a release or raw)."""


class EStopReleaseRefused(NavstackError):
    """A release from an authority that does not hold the e-stop latch."""


class EStopClient:
    """Latch / release the e-stop lock as ``authority``; tracks the lock's state from the
    bus, whichever source set it.  Use it in the thread that runs the stack."""

    def __init__(self, runtime: Runtime, authority: str, *, lock_topic: str = LOCK_TOPIC,
                 source_topic: str = SOURCE_TOPIC) -> None:
        if not authority or not authority.strip():
            raise ValueError("an e-stop client needs an authority name (web, phone, "
                             "telegram:<chat_id>, joystick)")
        self.runtime = runtime
        self.authority = authority
        self.lock_topic = lock_topic
        self._lock = runtime.bus.publisher(lock_topic, Bool, LATCHED)
        self._source = runtime.bus.publisher(source_topic, String, LATCHED)
        self.latched = False
        self.holder = ""
        """Authority holding the latch ("" when released, or latched by a raw publisher)."""
        self.latched_at: float | None = None
        self.released_at: float | None = None
        self.reason = ""
        self._pending = ""
        self._own: list[object] = []  # messages published here, skipped when they echo back
        runtime.bus.subscribe(source_topic, String, self._on_source, QoS(depth=10))
        runtime.bus.subscribe(lock_topic, Bool, self._on_lock, QoS(depth=10))

    def latch(self, reason: str = "") -> float:
        """Latch the e-stop now (idempotent: an existing latch keeps its time, the holder
        becomes this authority).  Returns the time [s] the lock was first latched."""
        now = self.runtime.now
        self._publish(String(self.authority), Bool(True))
        if not self.latched:
            self.latched_at = now
        self.latched, self.holder, self._pending = True, self.authority, ""
        self.reason = reason
        assert self.latched_at is not None
        return self.latched_at

    def release(self) -> float:
        """Release the latch if this authority holds it; returns the time [s].  Raises
        :class:`EStopReleaseRefused` naming the holder otherwise; a release with no latch
        does nothing."""
        now = self.runtime.now
        if not self.latched:
            return now
        if self.holder != self.authority:
            held = (f"held by '{self.holder}'" if self.holder
                    else f"latched by a publisher on {self.lock_topic}")
            where = ("release it there" if self.holder
                     else f"release it with false on {self.lock_topic}")
            raise EStopReleaseRefused(f"the e-stop is {held}, not by '{self.authority}'; "
                                      f"{where}")
        self._publish(String(""), Bool(False))
        self._released(now)
        return now

    def _publish(self, source: String, value: Bool) -> None:
        self._own += [source, value]
        self._source.publish(source)
        self._lock.publish(value)

    def _echo(self, msg: object) -> bool:
        """True (and forgotten) if ``msg`` is one this client published: its state was
        updated when it published."""
        for i, own in enumerate(self._own):
            if own is msg:
                del self._own[i]
                return True
        return False

    def _released(self, now: float) -> None:
        if self.latched:
            self.released_at = now
        self.latched, self.holder, self.reason = False, "", ""

    def _on_source(self, msg: String) -> None:
        if not self._echo(msg):
            self._pending = msg.data

    def _on_lock(self, msg: Bool) -> None:
        if self._echo(msg):
            return
        now = self.runtime.now
        if msg.data:
            if not self.latched:
                self.latched_at = now
                self.reason = ""
            self.latched = True
            self.holder = self._pending
        else:
            self._released(now)
        self._pending = ""

    def state(self) -> dict[str, object]:
        return {"latched": self.latched, "holder": self.holder, "latched_at": self.latched_at,
                "released_at": self.released_at, "reason": self.reason}
