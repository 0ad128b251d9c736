"""Typed in-process publish/subscribe with ROS-like QoS, plus services.

* ``keep_last(depth)``: each subscription queues at most ``depth`` undelivered messages;
  older ones are dropped (and counted) when a subscriber falls behind.
* ``latched`` (ROS transient-local durability): the topic keeps its last ``depth``
  messages and hands them to subscribers that join later (``/map``, ``/tf_static``).
* Deliveries go through the scheduler (``call_soon``), never re-entrantly from
  ``publish``, so ordering is deterministic and callbacks may publish freely.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from navstack.core.errors import BusError, UnknownNameError
from navstack.runtime.scheduler import Scheduler

M = TypeVar("M")
Req = TypeVar("Req")
Resp = TypeVar("Resp")


@dataclass(frozen=True, slots=True)
class QoS:
    """Quality of service: queue ``depth`` (keep_last) and ``latched`` durability."""

    depth: int = 10
    latched: bool = False

    def __post_init__(self) -> None:
        if self.depth < 1:
            raise ValueError(f"QoS depth must be >= 1, got {self.depth}")


def keep_last(depth: int) -> QoS:
    return QoS(depth=depth)


DEFAULT_QOS = QoS()
LATCHED = QoS(depth=1, latched=True)
SENSOR_DATA = QoS(depth=5)


class Subscription(Generic[M]):
    """A callback attached to a topic with its own bounded queue."""

    __slots__ = ("_bus", "_pending", "callback", "dropped", "enabled", "qos", "received", "topic")

    def __init__(self, bus: Bus, topic: Topic[M], callback: Callable[[M], Any], qos: QoS) -> None:
        self._bus = bus
        self.topic = topic
        self.callback = callback
        self.qos = qos
        self.enabled = True
        self._pending: deque[M] = deque()
        self.dropped = 0
        self.received = 0

    def _enqueue(self, msg: M) -> None:
        was_idle = not self._pending
        if len(self._pending) >= self.qos.depth:
            self._pending.popleft()
            self.dropped += 1
        self._pending.append(msg)
        if was_idle:
            self._bus.scheduler.call_soon(self._drain)

    def _drain(self) -> None:
        pending = self._pending
        while pending and self.enabled:
            msg = pending.popleft()
            self.received += 1
            self.callback(msg)

    def unsubscribe(self) -> None:
        self.enabled = False
        self._pending.clear()
        self.topic.subscriptions.remove(self)


class Topic(Generic[M]):
    """A named channel of one message type with its subscriptions and statistics."""

    def __init__(self, name: str, msg_type: type[M]) -> None:
        self.name = name
        self.msg_type = msg_type
        self.subscriptions: list[Subscription[M]] = []
        self.latched: deque[M] | None = None
        self.count = 0
        self.first_time: float | None = None
        self.last_time: float | None = None

    def rate_hz(self) -> float:
        """Mean publish rate over the topic's life (0 with fewer than two messages)."""
        if self.count < 2 or self.first_time is None or self.last_time is None:
            return 0.0
        span = self.last_time - self.first_time
        return (self.count - 1) / span if span > 0 else 0.0


class Publisher(Generic[M]):
    """Publishes messages of one type on one topic."""

    __slots__ = ("_bus", "qos", "topic")

    def __init__(self, bus: Bus, topic: Topic[M], qos: QoS) -> None:
        self._bus = bus
        self.topic = topic
        self.qos = qos
        if qos.latched and topic.latched is None:
            topic.latched = deque(maxlen=qos.depth)

    def publish(self, msg: M) -> None:
        topic = self.topic
        if not isinstance(msg, topic.msg_type):
            raise BusError(f"topic '{topic.name}' carries {topic.msg_type.__name__}, "
                           f"not {type(msg).__name__}")
        now = self._bus.scheduler.now
        topic.count += 1
        if topic.first_time is None:
            topic.first_time = now
        topic.last_time = now
        if topic.latched is not None:
            topic.latched.append(msg)
        for sub in topic.subscriptions:
            sub._enqueue(msg)
        for tap in self._bus.taps:
            tap(topic.name, msg, now)

    def subscription_count(self) -> int:
        return len(self.topic.subscriptions)


class Bus:
    """The in-process message bus of one running stack."""

    def __init__(self, scheduler: Scheduler) -> None:
        self.scheduler = scheduler
        self.topics: dict[str, Topic[Any]] = {}
        self.services: dict[str, Callable[[Any], Any]] = {}
        self.taps: list[Callable[[str, Any, float], None]] = []
        self.action_servers: dict[str, Any] = {}

    def _topic(self, name: str, msg_type: type[M]) -> Topic[M]:
        if not name.startswith("/"):
            name = "/" + name
        topic = self.topics.get(name)
        if topic is None:
            topic = Topic(name, msg_type)
            self.topics[name] = topic
        elif topic.msg_type is not msg_type:
            raise BusError(f"topic '{name}' already carries {topic.msg_type.__name__}; "
                           f"cannot use it for {msg_type.__name__}")
        return topic

    def publisher(self, name: str, msg_type: type[M], qos: QoS = DEFAULT_QOS) -> Publisher[M]:
        return Publisher(self, self._topic(name, msg_type), qos)

    def subscribe(self, name: str, msg_type: type[M], callback: Callable[[M], Any],
                  qos: QoS = DEFAULT_QOS) -> Subscription[M]:
        topic = self._topic(name, msg_type)
        sub = Subscription(self, topic, callback, qos)
        topic.subscriptions.append(sub)
        if topic.latched:
            for msg in topic.latched:
                sub._enqueue(msg)
        return sub

    def add_tap(self, tap: Callable[[str, Any, float], None]) -> Callable[[], None]:
        """Observe every published message (recording, dashboards); returns a remover."""
        self.taps.append(tap)
        return lambda: self.taps.remove(tap)

    # --- services ------------------------------------------------------------------
    def advertise_service(self, name: str, handler: Callable[[Req], Resp]) -> None:
        if name in self.services:
            raise BusError(f"service '{name}' is already advertised")
        self.services[name] = handler

    def remove_service(self, name: str) -> None:
        self.services.pop(name, None)

    def call(self, name: str, request: Any) -> Any:
        """Call a service synchronously (in-process services answer at once)."""
        handler = self.services.get(name)
        if handler is None:
            raise UnknownNameError("service", name, self.services)
        return handler(request)
