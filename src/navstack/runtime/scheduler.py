"""One deterministic event loop of timers and deliveries, on a stepped or a wall clock.

In ``sim`` mode time jumps from event to event, so a simulation runs as fast as the CPU
allows and the same seed gives the same run; in ``wall`` mode the same loop sleeps until
each event is due (hardware).  Events at equal times run in the order they were scheduled
(a sequence number breaks ties), which is what makes runs bit-identical.
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
from collections.abc import Callable
from typing import Any, Literal

ClockMode = Literal["sim", "wall"]


class _Event:
    """One scheduled call; the heap holds ``(time, seq, event)`` tuples (fast compares)."""

    __slots__ = ("args", "cancelled", "fn", "time")

    def __init__(self, time: float, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
        self.time = time
        self.fn = fn
        self.args = args
        self.cancelled = False


class EventHandle:
    """Handle to one scheduled call; ``cancel()`` prevents it from running."""

    __slots__ = ("_event",)

    def __init__(self, event: _Event) -> None:
        self._event = event

    def cancel(self) -> None:
        self._event.cancelled = True

    @property
    def time(self) -> float:
        return self._event.time


class Timer:
    """A periodic callback.  Fire ``k`` happens at ``start + k * period`` (no drift)."""

    def __init__(self, scheduler: Scheduler, period: float, callback: Callable[[], Any],
                 start: float) -> None:
        if not period > 0.0 or not math.isfinite(period):
            raise ValueError(
                f"timer period must be a positive finite number of seconds, got {period}")
        self.period = period
        self.callback = callback
        self._scheduler = scheduler
        self._start = start
        self._k = 0
        self._handle: EventHandle | None = scheduler.call_at(start, self._fire)
        self.fire_count = 0

    def _fire(self) -> None:
        self._k += 1
        self._handle = self._scheduler.call_at(self._start + self._k * self.period, self._fire)
        self.fire_count += 1
        self.callback()

    def cancel(self) -> None:
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None

    @property
    def active(self) -> bool:
        return self._handle is not None


class Scheduler:
    """Priority queue of ``(time, seq)`` events driven by a simulated or a wall clock.

    ``rate`` (sim mode only) throttles simulated time to ``rate`` x real time; ``None``
    runs as fast as possible.
    """

    def __init__(self, mode: ClockMode = "sim", start_time: float = 0.0,
                 rate: float | None = None) -> None:
        if mode not in ("sim", "wall"):
            raise ValueError(f"clock mode must be 'sim' or 'wall', got {mode!r}")
        self.mode: ClockMode = mode
        self.rate = rate
        self._queue: list[tuple[float, int, _Event]] = []
        self._seq = itertools.count()
        self._stopped = False
        self.events_run = 0
        if mode == "wall":
            self._wall0 = time.monotonic()
            self._t0 = time.time() if start_time == 0.0 else start_time
            self._now = self._t0
        else:
            self._now = start_time
            self._wall0 = time.monotonic()
            self._t0 = start_time

    # --- time --------------------------------------------------------------------
    @property
    def now(self) -> float:
        """Current time [s]: simulated time, or wall time in ``wall`` mode."""
        return self._now

    def _wall_time_for(self, t: float) -> float | None:
        if self.mode == "wall":
            return self._wall0 + (t - self._t0)
        if self.rate:
            return self._wall0 + (t - self._t0) / self.rate
        return None

    # --- scheduling ------------------------------------------------------------
    def call_at(self, t: float, fn: Callable[..., Any], *args: Any) -> EventHandle:
        """Run ``fn(*args)`` at time ``t`` (not before ``now``)."""
        t = max(t, self._now)
        ev = _Event(t, fn, args)
        heapq.heappush(self._queue, (t, next(self._seq), ev))
        return EventHandle(ev)

    def call_soon(self, fn: Callable[..., Any], *args: Any) -> EventHandle:
        return self.call_at(self._now, fn, *args)

    def call_later(self, delay: float, fn: Callable[..., Any], *args: Any) -> EventHandle:
        return self.call_at(self._now + delay, fn, *args)

    def create_timer(self, period: float, callback: Callable[[], Any],
                     first_at: float | None = None) -> Timer:
        """Periodic ``callback``; the first call is at ``first_at`` (default ``now + period``)."""
        return Timer(self, period, callback, self._now + period if first_at is None else first_at)

    # --- running -------------------------------------------------------------------
    def stop(self) -> None:
        """Make the running ``run_*`` call return after the current event."""
        self._stopped = True

    def step(self) -> bool:
        """Run the next event; ``False`` if there is none."""
        while self._queue:
            ev = heapq.heappop(self._queue)[2]
            if ev.cancelled:
                continue
            wall = self._wall_time_for(ev.time)
            if wall is not None:
                delay = wall - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            self._now = ev.time
            self.events_run += 1
            ev.fn(*ev.args)
            return True
        return False

    def run_until(self, t_end: float, until: Callable[[], bool] | None = None) -> bool:
        """Run events up to time ``t_end`` (inclusive) or until ``until()`` is true.

        Returns ``True`` if ``until`` became true (or ``stop()`` was called), ``False``
        if time ran out.  The clock ends at ``t_end`` when time runs out.
        """
        self._stopped = False
        queue = self._queue
        while True:
            if until is not None and until():
                return True
            if self._stopped:
                return True
            while queue and queue[0][2].cancelled:
                heapq.heappop(queue)
            if not queue or queue[0][0] > t_end:
                break
            self.step()
        wall = self._wall_time_for(t_end)
        if wall is not None and math.isfinite(t_end):
            delay = wall - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        if math.isfinite(t_end):
            self._now = max(self._now, t_end)
        return False

    def run_for(self, duration: float, until: Callable[[], bool] | None = None) -> bool:
        return self.run_until(self._now + duration, until)

    def pending(self) -> int:
        return sum(1 for e in self._queue if not e[2].cancelled)
