"""Nodes with a managed lifecycle, and the ``Runtime`` context they share.

Lifecycle follows ROS 2 managed nodes / Nav2: ``UNCONFIGURED --configure--> INACTIVE
--activate--> ACTIVE --deactivate--> INACTIVE --cleanup--> UNCONFIGURED``; ``shutdown``
from any state goes to ``FINALIZED``.  Subclasses override the ``on_*`` hooks.  Timers
made with :meth:`Node.create_timer` only run while the node is ACTIVE, and subscription
callbacks are only delivered while ACTIVE (messages arriving otherwise are counted in
``dropped_inactive``), so a deactivated node is truly quiet.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from enum import Enum
from typing import Any, TypeVar

from navstack.core.errors import ConfigError, FrameConflictError, InvalidMessage, LifecycleError
from navstack.core.msgs import TFMessage
from navstack.core.tf import TransformTree
from navstack.runtime.bus import DEFAULT_QOS, LATCHED, Bus, Publisher, QoS, Subscription
from navstack.runtime.scheduler import Scheduler, Timer

M = TypeVar("M")
_log = logging.getLogger("navstack.runtime")


class LifecycleState(Enum):
    UNCONFIGURED = "UNCONFIGURED"
    INACTIVE = "INACTIVE"
    ACTIVE = "ACTIVE"
    FINALIZED = "FINALIZED"


class Runtime:
    """What the nodes of one running stack share: scheduler (clock), bus and TF buffer.

    The TF buffer is fed from ``/tf`` and ``/tf_static`` like a tf2 listener.
    """

    def __init__(self, scheduler: Scheduler | None = None, tf_cache_time: float = 10.0) -> None:
        self.scheduler = scheduler or Scheduler()
        self.bus = Bus(self.scheduler)
        self.tf = TransformTree(cache_time=tf_cache_time)
        self.nodes: dict[str, Node] = {}
        self.tf_rejections = 0
        self.last_tf_rejection = ""
        self.bus.subscribe("/tf", TFMessage, lambda m: self._ingest_tf(m, False), QoS(depth=100))
        self.bus.subscribe("/tf_static", TFMessage, lambda m: self._ingest_tf(m, True),
                           QoS(depth=100, latched=True))

    def _ingest_tf(self, msg: TFMessage, is_static: bool) -> None:
        """Feed the TF buffer; a bad transform is counted and logged, the rest still land."""
        try:
            self.tf.apply_tf_message(msg, is_static)
        except (InvalidMessage, FrameConflictError, ConfigError) as exc:
            self.tf_rejections += 1
            self.last_tf_rejection = str(exc)
            _log.warning("rejected transform on %s: %s", "/tf_static" if is_static else "/tf", exc)

    @property
    def now(self) -> float:
        return self.scheduler.now

    def add(self, node: Node) -> Node:
        if node.name in self.nodes:
            raise LifecycleError(f"a node named '{node.name}' already exists")
        self.nodes[node.name] = node
        return node

    def bring_up(self) -> None:
        """Configure then activate every node, in the order they were added."""
        for node in self.nodes.values():
            if node.state is LifecycleState.UNCONFIGURED:
                node.configure()
        for node in self.nodes.values():
            if node.state is LifecycleState.INACTIVE:
                node.activate()

    def shut_down(self) -> None:
        for node in reversed(list(self.nodes.values())):
            node.shutdown()


class Node:
    """Base class for a lifecycle-managed component."""

    def __init__(self, name: str, runtime: Runtime) -> None:
        self.name = name
        self.runtime = runtime
        self.state = LifecycleState.UNCONFIGURED
        self.log = logging.getLogger(f"navstack.{name}")
        self._timers: list[tuple[float, Callable[[], Any], Timer | None]] = []
        self._subs: list[Subscription[Any]] = []
        self.dropped_inactive = 0
        runtime.add(self)

    # --- conveniences ----------------------------------------------------------------
    @property
    def bus(self) -> Bus:
        return self.runtime.bus

    @property
    def tf(self) -> TransformTree:
        return self.runtime.tf

    @property
    def now(self) -> float:
        return self.runtime.scheduler.now

    def create_publisher(self, topic: str, msg_type: type[M],
                         qos: QoS = DEFAULT_QOS) -> Publisher[M]:
        return self.bus.publisher(topic, msg_type, qos)

    def create_latched_publisher(self, topic: str, msg_type: type[M]) -> Publisher[M]:
        return self.bus.publisher(topic, msg_type, LATCHED)

    def create_subscription(self, topic: str, msg_type: type[M], callback: Callable[[M], Any],
                            qos: QoS = DEFAULT_QOS) -> Subscription[M]:
        def gated(msg: M) -> None:
            if self.state is LifecycleState.ACTIVE:
                callback(msg)
            else:
                self.dropped_inactive += 1

        sub = self.bus.subscribe(topic, msg_type, gated, qos)
        self._subs.append(sub)
        return sub

    def destroy_subscription(self, sub: Subscription[Any]) -> None:
        """Stop a subscription made with :meth:`create_subscription` (rclpy's name)."""
        if sub in self._subs:
            self._subs.remove(sub)
            sub.unsubscribe()

    def create_timer(self, period: float, callback: Callable[[], Any]) -> None:
        """A periodic callback that runs while the node is ACTIVE."""
        timer = self.runtime.scheduler.create_timer(period, callback) \
            if self.state is LifecycleState.ACTIVE else None
        self._timers.append((period, callback, timer))

    # --- lifecycle ---------------------------------------------------------------------
    def _transition(self, expected: LifecycleState, target: LifecycleState, name: str,
                    hook: Callable[[], None]) -> None:
        if self.state is not expected:
            raise LifecycleError(f"node '{self.name}': cannot {name} from {self.state.value} "
                                 f"(needs {expected.value})")
        hook()
        self.state = target

    def configure(self) -> None:
        self._transition(LifecycleState.UNCONFIGURED, LifecycleState.INACTIVE, "configure",
                         self.on_configure)

    def activate(self) -> None:
        self._transition(LifecycleState.INACTIVE, LifecycleState.ACTIVE, "activate",
                         self.on_activate)
        sched = self.runtime.scheduler
        self._timers = [(p, cb, sched.create_timer(p, cb)) for p, cb, _ in self._timers]

    def deactivate(self) -> None:
        self._transition(LifecycleState.ACTIVE, LifecycleState.INACTIVE, "deactivate",
                         self.on_deactivate)
        for _, _, timer in self._timers:
            if timer is not None:
                timer.cancel()
        self._timers = [(p, cb, None) for p, cb, _ in self._timers]

    def cleanup(self) -> None:
        self._transition(LifecycleState.INACTIVE, LifecycleState.UNCONFIGURED, "cleanup",
                         self.on_cleanup)
        for sub in self._subs:
            sub.unsubscribe()
        self._subs.clear()
        self._timers.clear()

    def shutdown(self) -> None:
        if self.state is LifecycleState.ACTIVE:
            self.deactivate()
        if self.state is LifecycleState.INACTIVE:
            self.cleanup()
        self.on_shutdown()
        self.state = LifecycleState.FINALIZED

    # --- hooks for subclasses ----------------------------------------------------------
    def on_configure(self) -> None:
        """Create publishers/subscriptions, allocate from params."""

    def on_activate(self) -> None:
        """Start producing output."""

    def on_deactivate(self) -> None:
        """Stop producing output."""

    def on_cleanup(self) -> None:
        """Release what configure made."""

    def on_shutdown(self) -> None:
        """Final release."""
