"""The sender thread of a wall-clock :class:`~.zenoh_link.ZenohLink` (issue 21).

A Zenoh ``put`` on a loopback TCP session with a remote subscriber took 75 us at the
median and 0.5-5 ms at p99; on a robot that time was spent in the loop, inside the
simulator's scan tick ahead of the costmap update and controller cycle of the same
instant.  The loop now queues the (already encoded) put and goes on.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import zenoh

_log = logging.getLogger("navstack.transport")


class Outbox:
    """Zenoh puts handed off the loop thread: a FIFO run by one daemon thread, so the
    order of this process's messages is kept while the loop goes on at once."""

    def __init__(self, name: str) -> None:
        self._queue: deque[Callable[[], Any]] = deque()
        self._cond = threading.Condition()
        self._closing = False
        self.submitted = 0
        self.sent = 0
        self.put_s = 0.0  # time [s] the sender thread spent in the puts
        self._thread = threading.Thread(target=self._run, name=f"navstack-send-{name}",
                                        daemon=True)
        self._thread.start()

    def submit(self, put: Callable[[], Any]) -> None:
        with self._cond:
            self._queue.append(put)
            self.submitted += 1
            self._cond.notify_all()

    def _run(self) -> None:
        queue, cond = self._queue, self._cond
        while True:
            with cond:
                cond.wait_for(lambda: bool(queue) or self._closing)
                if not queue:
                    return  # closing, everything sent
                put = queue.popleft()
            t0 = time.perf_counter()
            try:
                put()
            except zenoh.ZError as exc:  # the session closing under us
                _log.debug("put failed: %s", exc)
            with cond:
                self.put_s += time.perf_counter() - t0
                self.sent += 1
                cond.notify_all()

    def flush(self, timeout: float = 1.0) -> bool:
        """Wait until everything submitted so far has been put."""
        with self._cond:
            target = self.submitted
            return self._cond.wait_for(lambda: self.sent >= target, timeout)

    def close(self, timeout: float = 2.0) -> None:
        """Send what is queued, then stop."""
        with self._cond:
            self._closing = True
            self._cond.notify_all()
        self._thread.join(timeout)
