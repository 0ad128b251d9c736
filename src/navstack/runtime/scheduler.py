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
import threading
import time
from collections import deque
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

    ``rate`` (sim mode) throttles simulated time to ``rate`` x real time; ``None`` runs
    as fast as possible.  In ``wall`` mode the clock reads
    ``clock_offset + epoch + rate * (time.time() - epoch)`` (``rate`` default 1: the
    system clock plus ``clock_offset``), so processes that share ``epoch`` and ``rate``
    share one time base up to their offsets -- an accelerated wall clock lets split
    stacks run faster than real time in tests; ``clock_offset`` simulates a robot whose
    clock is wrong (issue 21).

    Other threads (network transports) hand work to the loop with :meth:`post`; it runs
    at the clock's current reading, and a loop waiting for its next event wakes for it.
    """

    #: default ``epoch`` of an accelerated wall clock (2026-01-01T00:00:00Z)
    EPOCH = 1_767_225_600.0

    def __init__(self, mode: ClockMode = "sim", start_time: float = 0.0,
                 rate: float | None = None, *, clock_offset: float = 0.0,
                 epoch: float = EPOCH) -> None:
        if mode not in ("sim", "wall"):
            raise ValueError(f"clock mode must be 'sim' or 'wall', got {mode!r}")
        if rate is not None and not (rate > 0.0 and math.isfinite(rate)):
            raise ValueError(f"clock rate must be a positive finite number, got {rate}")
        self.mode: ClockMode = mode
        self.rate = rate
        self.clock_offset = clock_offset
        self.epoch = epoch
        self._queue: list[tuple[float, int, _Event]] = []
        self._seq = itertools.count()
        self._stopped = False
        self.events_run = 0
        #: posted work: (time to run at or ``None`` for the clock's reading, fn, args)
        self._inbox: deque[tuple[float | None, Callable[..., Any], tuple[Any, ...]]] = deque()
        #: wall/throttled modes: how late [real s] each event ran, when set to a deque
        self.lateness: deque[float] | None = None
        #: lockstep with other processes (:mod:`navstack.runtime.transports.lockstep`):
        #: no event later than ``horizon()`` runs; ``on_blocked()`` is called while the
        #: loop waits for the horizon to move (posted work still runs meanwhile)
        self.horizon: Callable[[], float] | None = None
        #: ``post_at`` work that arrived after the loop had passed its time (lockstep:
        #: a broken ordering guarantee; should stay 0)
        self.late_posts = 0
        self.on_blocked: Callable[[], None] | None = None
        self._wake = threading.Event()
        if mode == "wall":
            self._wall0 = time.monotonic()
            self._t0 = self.clock() if start_time == 0.0 else start_time
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

    def clock(self) -> float:
        """The clock's reading right now, from any thread (wall mode: the scaled system
        clock plus offset; sim mode: ``now``)."""
        if self.mode != "wall":
            return self._now
        rate = self.rate or 1.0
        return self.clock_offset + self.epoch + rate * (time.time() - self.epoch)

    def _wall_time_for(self, t: float) -> float | None:
        if self.mode == "wall":
            return self._wall0 + (t - self._t0) / (self.rate or 1.0)
        if self.rate:
            return self._wall0 + (t - self._t0) / self.rate
        return None

    # --- other threads -------------------------------------------------------------
    def post(self, fn: Callable[..., Any], *args: Any) -> None:
        """Thread-safe: run ``fn(*args)`` in the loop as soon as possible (at the
        clock's reading when the loop picks it up)."""
        self._inbox.append((None, fn, args))
        self._wake.set()

    def post_at(self, t: float, fn: Callable[..., Any], *args: Any) -> None:
        """Thread-safe: run ``fn(*args)`` in the loop at time ``t`` (or at once if the
        loop is already past it) -- lockstep transports deliver at a time fixed by the
        sender's stamp, not by when the network thread got the message."""
        self._inbox.append((t, fn, args))
        self._wake.set()

    def _drain_inbox(self) -> None:
        self._wake.clear()
        inbox = self._inbox
        if not inbox:
            return
        if self.mode == "wall":
            self._now = max(self._now, self.clock())
        while inbox:
            t, fn, args = inbox.popleft()
            if t is not None and t < self._now - 1e-9:
                self.late_posts += 1  # lockstep: arrived after the loop passed its time
            self.call_at(self._now if t is None else t, fn, *args)

    def _wait_for_horizon(self, limit: float) -> None:
        """Blocked by the horizon ``limit``: tell the peers, run posted work, wait to be
        woken (a wake-up from before this wait does not count: no busy loop)."""
        self._wake.clear()
        if self.horizon is not None and self.horizon() > limit:
            return  # it moved meanwhile
        if self.on_blocked is not None:
            self.on_blocked()
        if self._inbox:
            self._drain_inbox()
            return
        self._wake.wait(0.05)
        if self._inbox:
            self._drain_inbox()

    def wake(self) -> None:
        """Thread-safe: make a waiting loop look again (its horizon moved)."""
        self._wake.set()

    def _sleep_until(self, wall: float) -> bool:
        """Sleep until monotonic time ``wall``; ``True`` if posted work woke us first."""
        while True:
            if self._inbox:
                self._drain_inbox()
                return True
            delay = wall - time.monotonic()
            if delay <= 0:
                return False
            self._wake.wait(delay)

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
        # the horizon is read before the inbox is drained: a peer's messages reach the
        # inbox before the time announcement that lets the loop run past them
        limit = self.horizon() if self.horizon is not None else math.inf
        if self._inbox:
            self._drain_inbox()
        queue = self._queue
        while queue:
            if queue[0][2].cancelled:
                heapq.heappop(queue)
                continue
            if queue[0][0] > limit:
                self._wait_for_horizon(limit)
                limit = self.horizon() if self.horizon is not None else math.inf
                if self._inbox:
                    self._drain_inbox()
                continue
            wall = self._wall_time_for(queue[0][0])
            if wall is not None and self._sleep_until(wall):
                continue  # posted work arrived: it may now be the earliest event
            ev = heapq.heappop(queue)[2]
            if wall is not None and self.lateness is not None:
                self.lateness.append(time.monotonic() - wall)
            self._now = max(self._now, ev.time)
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
            if self._inbox:
                self._drain_inbox()
            while queue and queue[0][2].cancelled:
                heapq.heappop(queue)
            if queue and queue[0][0] <= t_end:
                self.step()
                continue
            wall = self._wall_time_for(t_end)
            if wall is None or not math.isfinite(t_end) or not self._sleep_until(wall):
                break
        if math.isfinite(t_end):
            # never past the horizon: work a peer posts for up to the horizon must not
            # find the clock already beyond its time
            limit = t_end if self.horizon is None else min(t_end, self.horizon())
            self._now = max(self._now, limit)
        return False

    def run_for(self, duration: float, until: Callable[[], bool] | None = None) -> bool:
        return self.run_until(self._now + duration, until)

    def idle_until(self, t: float) -> None:
        """Move the clock to ``t`` when no event before ``t`` is pending (a lockstep
        follower that acknowledged ``t``: its next work happens at ``t`` or later)."""
        head = min((e[0] for e in self._queue if not e[2].cancelled), default=math.inf)
        if head >= t:
            self._now = max(self._now, t)

    def pending(self) -> int:
        return sum(1 for e in self._queue if not e[2].cancelled)
