"""``TfMessageFilter``: hold a message until TF can place it (tf2_ros ``MessageFilter``).

A sensor message is only usable with the transforms at its stamp: a scan needs the
odometry pose at the scan's time (``odom -> base_link``) and the laser mount
(``base_link -> laser``).  The odometry of one instant may reach the TF buffer just after
the scan of that instant (the simulator publishes both in either order; on hardware the
odometry often lags the lidar), so a node must wait for it instead of failing.  Nav2's
AMCL and slam_toolbox both put a ``tf2_ros::MessageFilter`` in front of their scan
callback; this is the same filter for navstack nodes:

* messages queue in arrival order, at most ``queue_size``; one more pushes the oldest out
  (counted in ``dropped_queue_full``), as the tf2 filter's queue does;
* the oldest message is released, ``callback(msg, transforms)``, as soon as
  ``lookup(msg)`` succeeds; messages leave in arrival order (a message never overtakes an
  older one that is still waiting);
* while a message waits, the filter looks again every ``retry_period`` seconds (tf2
  re-checks on every TF update; on the in-process bus a short poll bounds the extra
  latency by one period) and whenever the owner calls :meth:`drain`; retries only run
  while the owner node is ACTIVE;
* a message whose transforms are still missing ``timeout`` seconds after its stamp is
  dropped (counted in ``dropped_timeout``; the reason, naming the frames and times TF
  had, in ``last_drop``) -- Nav2 AMCL's ``transform_tolerance``, slam_toolbox's
  ``transform_timeout``, rclcpp's ``buffer_timeout`` of the tf2 filter.

``lookup`` raises :class:`~navstack.core.errors.TransformError` while the transforms are
not available; any other exception propagates (a bug, not a wait).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any, Generic, TypeVar

from navstack.core.errors import ConfigError, TransformError
from navstack.runtime.node import LifecycleState, Node
from navstack.runtime.scheduler import EventHandle

M = TypeVar("M")
T = TypeVar("T")

__all__ = ["TfMessageFilter"]


def header_stamp(msg: Any) -> float:
    """``msg.header.stamp`` (every stamped message in :mod:`navstack.core.msgs`)."""
    return float(msg.header.stamp)


class TfMessageFilter(Generic[M, T]):
    """Queue messages of ``node`` until ``lookup(msg)`` can give their transforms."""

    def __init__(self, node: Node, lookup: Callable[[M], T],
                 callback: Callable[[M, T], None], *, queue_size: int, timeout: float,
                 retry_period: float = 0.02, what: str = "message",
                 on_drop: Callable[[M, str], None] | None = None,
                 stamp: Callable[[M], float] = header_stamp) -> None:
        """``what`` names the messages in drop reasons (``"scan at t=1.000 dropped:
        ..."``); ``on_drop(msg, reason)`` is told about every dropped message."""
        for key, value, ok, rule in (("queue_size", queue_size, queue_size >= 1, ">= 1"),
                                     ("timeout", timeout, timeout >= 0.0, ">= 0 s"),
                                     ("retry_period", retry_period, retry_period > 0.0, "> 0 s")):
            if not ok:
                raise ConfigError(f"the TF message filter's {key} must be {rule}, got {value}",
                                  key_path=f"{node.name}.{key}")
        self.node = node
        self.lookup = lookup
        self.callback = callback
        self.queue_size = queue_size
        self.timeout = timeout
        self.retry_period = retry_period
        self.what = what
        self.on_drop = on_drop
        self.stamp = stamp
        self.received = 0
        self.released = 0
        self.dropped_queue_full = 0
        self.dropped_timeout = 0
        self.last_drop = ""
        self._queue: deque[M] = deque()
        self._retry: EventHandle | None = None

    @property
    def pending(self) -> tuple[M, ...]:
        """The waiting messages, oldest first."""
        return tuple(self._queue)

    @property
    def dropped(self) -> int:
        return self.dropped_queue_full + self.dropped_timeout

    def add(self, msg: M) -> None:
        """Queue ``msg`` (bounded) and release whatever TF can now place."""
        self.received += 1
        self._queue.append(msg)
        while len(self._queue) > self.queue_size:
            old = self._queue.popleft()
            self.dropped_queue_full += 1
            self._drop(old, f"{self.what} at t={self.stamp(old):.3f} dropped: the queue of "
                            f"{self.queue_size} waiting for TF is full")
        self.drain()

    def drain(self) -> None:
        """Release queued messages in order while their transforms are available; drop the
        ones that waited longer than ``timeout``; schedule a retry if one still waits."""
        now = self.node.now
        queue = self._queue
        while queue:
            msg = queue[0]
            try:
                transforms = self.lookup(msg)
            except TransformError as exc:
                t = self.stamp(msg)
                if now - t <= self.timeout:
                    self._schedule_retry()  # the transforms of this instant may still come
                    return
                queue.popleft()
                self.dropped_timeout += 1
                self._drop(msg, f"{self.what} at t={t:.3f} dropped: {exc}")
                continue
            queue.popleft()
            self.released += 1
            self.callback(msg, transforms)

    def clear(self) -> None:
        """Forget the waiting messages and the pending retry (node cleanup)."""
        self._queue.clear()
        if self._retry is not None:
            self._retry.cancel()
            self._retry = None

    def _drop(self, msg: M, reason: str) -> None:
        self.last_drop = reason
        if self.on_drop is not None:
            self.on_drop(msg, reason)

    def _schedule_retry(self) -> None:
        if self._retry is None:
            self._retry = self.node.runtime.scheduler.call_later(self.retry_period,
                                                                 self._on_retry)

    def _on_retry(self) -> None:
        self._retry = None
        if self.node.state is LifecycleState.ACTIVE:
            self.drain()
