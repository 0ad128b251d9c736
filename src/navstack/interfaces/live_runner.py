"""``LiveRunner``: a :class:`NavStack` stepped in (scaled) real time in one background thread,
plus the latched emergency stop (:class:`EStopGate`) every live client shares.

The stack is single-threaded by design (ARCHITECTURE.md §4: one deterministic event loop),
so live clients -- the web dashboard, the Foxglove bridge, a chat bot -- never call into it
from their own threads.  They hand work to the simulation thread instead:

* :meth:`LiveRunner.submit` queues a function that runs in the simulation thread between two
  steps and returns a :class:`concurrent.futures.Future` with its result;
* :meth:`LiveRunner.add_observer` registers a function called in the simulation thread after
  every step (observers copy what they need into immutable snapshots for their clients).

Each step advances simulated time by ``step`` seconds (default 0.05 s: one cycle of Nav2's
``controller_frequency`` 20 Hz), so a command waits at most one control cycle of simulated
time before it takes effect.  Between steps the thread sleeps until wall time catches up
with ``real_time_factor`` x real time (``None``: as fast as the CPU allows); when the CPU
cannot keep up for more than ``max_lag`` wall seconds the schedule is re-anchored instead of
sprinting to catch up (counted in ``overruns``).
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any, TypeVar

from pydantic import Field

from navstack.core.errors import NavstackError
from navstack.core.params import Params
from navstack.interfaces.estop import EStopGate
from navstack.interfaces.stack import NavStack

T = TypeVar("T")
__all__ = ["EStopGate", "LiveRunner", "LiveRunnerParams", "RunnerError"]
_log = logging.getLogger("navstack.live")


class RunnerError(NavstackError):
    """The live runner cannot do what was asked (not running, stopped by an error)."""


class LiveRunnerParams(Params):
    """Pacing of the live simulation (no Nav2 counterpart: Nav2 runs on a real clock).

    ``real_time_factor``: simulated seconds per wall second (``None``: unthrottled);
    ``step``: simulated seconds per step, the latency bound of a command (one controller
    cycle at Nav2's ``controller_frequency`` 20 Hz); ``max_lag``: wall seconds behind
    schedule after which the pacing re-anchors rather than catching up.
    """

    real_time_factor: float | None = Field(1.0, gt=0.0)
    step: float = Field(0.05, gt=0.0, le=1.0)
    max_lag: float = Field(0.5, gt=0.0)


class LiveRunner:
    """Runs ``stack`` in a background thread at ``real_time_factor`` x real time."""

    def __init__(self, stack: NavStack, real_time_factor: float | None = 1.0, *,
                 step: float = 0.05, params: LiveRunnerParams | None = None) -> None:
        """``real_time_factor`` ``None`` runs unthrottled; ``params``, when given, replaces
        both keyword settings."""
        self.params = params or LiveRunnerParams.from_mapping(
            {"real_time_factor": real_time_factor, "step": step}, key_path="live_runner")
        self.stack = stack.start()  # idempotent: a stack built but not started runs here
        self.estop = EStopGate(stack.runtime)
        self.now = stack.now
        #: held while the simulation thread publishes :attr:`now` (see :meth:`estop_request`)
        self._clock_lock = threading.Lock()
        self.steps = 0
        self.overruns = 0
        self.observer_errors = 0
        self.error: BaseException | None = None
        self._commands: queue.SimpleQueue[tuple[Callable[[NavStack], Any], Future[Any]]] = (
            queue.SimpleQueue())
        self._urgent: queue.SimpleQueue[tuple[Callable[[NavStack], Any], Future[Any]]] = (
            queue.SimpleQueue())
        self._observers: list[Callable[[float], None]] = []
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._pace: deque[tuple[float, float]] = deque(maxlen=64)
        self._wall0 = self._sim0 = 0.0

    # --- lifecycle ---------------------------------------------------------------------------
    def start(self) -> None:
        """Start the simulation thread (once)."""
        if self._thread is not None:
            raise RunnerError("the live runner was already started; create a new one to "
                              "run again")
        self._thread = threading.Thread(target=self._loop, name="navstack-sim", daemon=True)
        self._thread.start()

    def start_in_caller(self) -> None:
        """Serve clients from a simulation the caller steps itself (``navstack demo --web``:
        the demo's Navigator advances the stack from the main thread).

        The calling thread becomes the simulation thread; a scheduler timer every ``step``
        of simulated time drains queued commands, notifies observers and sleeps to keep
        ``real_time_factor``, exactly as the background loop does between its steps.
        """
        if self._thread is not None:
            raise RunnerError("the live runner was already started; create a new one to "
                              "run again")
        self._thread = threading.current_thread()
        self._wall0, self._sim0 = time.monotonic(), self.stack.now
        self.stack.runtime.scheduler.create_timer(self.params.step, self._tick,
                                                  first_at=self.stack.now + self.params.step)

    def _tick(self) -> None:
        """One caller-driven step boundary (:meth:`start_in_caller`)."""
        if self._stop.is_set():
            return
        self._drain()
        with self._clock_lock:
            self.now = self.stack.now
        self.steps += 1
        self._pace.append((time.monotonic(), self.now))
        self._notify()
        rate = self.params.real_time_factor
        if rate is None:
            return
        due = self._wall0 + (self.now - self._sim0) / rate
        while (delay := due - time.monotonic()) > 0.0 and not self._stop.is_set():
            self._wake.wait(delay)
            self._wake.clear()
            self._drain()
        if time.monotonic() - due > self.params.max_lag:
            self._wall0, self._sim0 = time.monotonic(), self.now
            self.overruns += 1

    def stop(self, timeout: float = 5.0) -> None:
        """Stop after the current step and wait for the thread (idempotent)."""
        self._stop.set()
        self._wake.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
            if self._thread.is_alive():
                raise RunnerError(f"the simulation thread did not stop within {timeout:.1f} s")

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive() and not self._stop.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the simulation thread ends (``True``) or ``timeout`` passes."""
        if self._thread is None:
            return True
        self._thread.join(timeout)
        return not self._thread.is_alive()

    @property
    def real_time_factor(self) -> float:
        """Measured simulated seconds per wall second over the last ~64 steps."""
        if len(self._pace) < 2:
            return 0.0
        (w0, s0), (w1, s1) = self._pace[0], self._pace[-1]
        return (s1 - s0) / (w1 - w0) if w1 > w0 else 0.0

    # --- work from other threads ---------------------------------------------------------------
    def submit(self, fn: Callable[[NavStack], T], *, urgent: bool = False) -> Future[T]:
        """Run ``fn(stack)`` in the simulation thread before the next step.

        ``urgent`` work (the e-stop) runs before every queued ordinary command, so a
        latch never waits behind a burst of goals or other requests."""
        if not self.running:
            raise RunnerError(self._not_running())
        fut: Future[T] = Future()
        (self._urgent if urgent else self._commands).put((fn, fut))
        self._wake.set()
        if not self.running:  # the thread ended between the check and the put
            self._fail_pending()
        return fut

    def call(self, fn: Callable[[NavStack], T], timeout: float = 10.0) -> T:
        """Run ``fn(stack)`` where it is safe: in the simulation thread when it runs (and
        wait for the result), directly when no simulation thread is running (after waiting
        for a stopping thread to finish its step)."""
        thread = self._thread
        if thread is None or thread is threading.current_thread():
            return fn(self.stack)
        if self.running:
            # a RunnerError means it stopped in the meantime: run fn here once it has ended
            with contextlib.suppress(RunnerError):
                return self.submit(fn).result(timeout)
        thread.join(timeout)
        if thread.is_alive():
            raise RunnerError(f"the simulation thread did not stop within {timeout:.1f} s")
        return fn(self.stack)

    def add_observer(self, fn: Callable[[float], None]) -> Callable[[], None]:
        """Call ``fn(now)`` in the simulation thread after every step; returns a remover."""
        def add(_: NavStack) -> None:
            self._observers.append(fn)

        def remove() -> None:
            def drop(_: NavStack) -> None:
                if fn in self._observers:
                    self._observers.remove(fn)
            self.call(drop)

        self.call(add)
        return remove

    def _not_running(self) -> str:
        if self.error is not None:
            return f"the simulation stopped with an error: {self.error}"
        if self._thread is None:
            return "the simulation is not running yet; call LiveRunner.start() first"
        return "the simulation was stopped"

    # --- the simulation thread -------------------------------------------------------------------
    def request_estop(self, source: str, reason: str = "") -> Future[float]:
        """Latch the shared e-stop from any thread (urgent: ahead of queued commands);
        the future's result is the simulated latch time.  Every operator interface
        (web API and page, phone, Telegram) stops the robot through this one call."""
        return self.estop_request(source, reason)[1]

    def estop_request(self, source: str, reason: str = "") -> tuple[float, Future[float]]:
        """:meth:`request_estop`, with the simulated time the request was queued at.

        Read and queued under the lock the simulation thread publishes its time
        with, so the latch comes at most one step later whatever the caller's thread
        does meanwhile (a server thread preempted between reading the time and
        queueing once reported a latch two steps after the request)."""
        with self._clock_lock:
            requested_at = self.now
            fut = self.submit(lambda _s: self.estop.latch(reason, source, requested_at),
                              urgent=True)
        return requested_at, fut

    def _next(self) -> tuple[Callable[[NavStack], Any], Future[Any]] | None:
        for q in (self._urgent, self._commands):
            try:
                return q.get_nowait()
            except queue.Empty:
                continue
        return None

    def _drain(self) -> None:
        while True:
            item = self._next()
            if item is None:
                return
            fn, fut = item
            if not fut.set_running_or_notify_cancel():
                continue
            try:
                fut.set_result(fn(self.stack))
            except Exception as exc:
                fut.set_exception(exc)

    def _notify(self) -> None:
        for fn in list(self._observers):
            try:
                fn(self.now)
            except Exception:
                self.observer_errors += 1
                _log.exception("live observer %r failed", fn)

    def _loop(self) -> None:
        stack, p = self.stack, self.params
        rate = p.real_time_factor
        wall0, sim0 = time.monotonic(), stack.now
        try:
            while not self._stop.is_set():
                self._drain()
                stack.run_for(p.step)
                with self._clock_lock:
                    self.now = stack.now
                self.steps += 1
                self._pace.append((time.monotonic(), self.now))
                self._notify()
                if rate is None:
                    self._drain()
                    time.sleep(0)  # let server threads take the GIL
                    continue
                due = wall0 + (self.now - sim0) / rate
                while not self._stop.is_set():
                    delay = due - time.monotonic()
                    if delay <= 0.0:
                        break
                    self._wake.wait(delay)
                    self._wake.clear()
                    self._drain()
                if time.monotonic() - due > p.max_lag:
                    wall0, sim0 = time.monotonic(), self.now
                    self.overruns += 1
        except Exception as exc:
            self.error = exc
            _log.exception("the live simulation stopped")
        finally:
            self._stop.set()
            self._fail_pending()

    def _fail_pending(self) -> None:
        while True:
            item = self._next()
            if item is None:
                return
            _, fut = item
            if fut.set_running_or_notify_cancel():
                fut.set_exception(RunnerError(self._not_running()))

