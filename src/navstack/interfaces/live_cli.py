"""Live viewers for the command line: ``--web`` and ``--foxglove`` on ``navstack run`` and
``navstack demo``.

Both viewers share one :class:`~navstack.interfaces.live_runner.LiveRunner` (one simulation
thread, one e-stop latch).  ``navstack run`` lets the runner step the stack in a background
thread until Ctrl-C (or ``--duration``); ``navstack demo`` keeps stepping from its own
mission loop and the runner serves the viewers from scheduler ticks
(:meth:`LiveRunner.start_in_caller`).

A session whose operator sends the goals (``navstack run``, ``navstack telegram``) first
warms the navigation kernels on a twin of the stack (:func:`warm_up`), so the first goal
does not wait for their compilation.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack
from navstack.interfaces.warm_up import warm_up_navigation


@dataclass(frozen=True)
class LiveOptions:
    """What the user asked for on the command line."""

    web: bool = False
    host: str = "127.0.0.1"
    port: int = 8080
    token: str | None = None
    foxglove: bool = False
    foxglove_port: int = 8765
    real_time_factor: float | None = 1.0
    token_file: Path | None = None
    tls_cert: Path | None = None
    tls_key: Path | None = None

    @property
    def enabled(self) -> bool:
        return self.web or self.foxglove


def open_viewers(runner: LiveRunner, options: LiveOptions) -> list[Any]:
    """Start the requested viewers on ``runner``; returns their handles (``.stop()``).

    Raises ``DashboardError`` / ``FoxgloveLiveError`` (a busy port, with the fix); any
    viewer already started is stopped first.
    """
    handles: list[Any] = []
    try:
        if options.web:
            from navstack.interfaces.web.dashboard import serve_dashboard

            if options.token is not None:
                print("warning: --token is visible to every user of this machine in `ps`; "
                      "use --token-file or $NAVSTACK_DASHBOARD_TOKEN", file=sys.stderr)
            handles.append(serve_dashboard(
                runner, options.host, options.port, options.token,
                token_file=None if options.token_file is None else str(options.token_file),
                ssl_certfile=None if options.tls_cert is None else str(options.tls_cert),
                ssl_keyfile=None if options.tls_key is None else str(options.tls_key)))
        if options.foxglove:
            from navstack.interfaces.foxglove_live import start_foxglove

            handle = start_foxglove(runner, "127.0.0.1", options.foxglove_port)
            print(f"Foxglove: open {handle.url} in Foxglove (Open connection -> "
                  f"Foxglove WebSocket)", flush=True)
            handles.append(handle)
    except Exception:
        close_viewers(handles)
        raise
    return handles


def close_viewers(handles: list[Any]) -> None:
    for handle in reversed(handles):
        handle.stop()


def attach_to_demo(options: LiveOptions) -> Callable[[NavStack], Callable[[], None]]:
    """The ``attach`` hook of :func:`~navstack.interfaces.demo.run_demo`: viewers served
    from the demo's own stepping, paced at ``options.real_time_factor``."""
    def attach(stack: NavStack) -> Callable[[], None]:
        runner = LiveRunner(stack, real_time_factor=options.real_time_factor)
        handles = open_viewers(runner, options)
        runner.start_in_caller()

        def detach() -> None:
            close_viewers(handles)
            runner.stop()

        return detach

    return attach


def warm_up(stack: NavStack) -> None:
    """Compile (or load) the navigation kernels on a twin of ``stack`` before the live
    session opens (:mod:`navstack.interfaces.warm_up`); says so on stderr."""
    print("navstack: warming up navigation (the first run after an install compiles it: "
          "up to a minute)", file=sys.stderr, flush=True)
    result = warm_up_navigation(stack)
    if result.reached:
        print(f"navstack: navigation warm in {result.seconds:.1f} s", file=sys.stderr,
              flush=True)
    else:
        print(f"warning: the warm-up drive did not reach its goal ({result.reason}); the "
              f"first goal may start late", file=sys.stderr, flush=True)


def run_live(stack: NavStack, options: LiveOptions, duration: float | None = None) -> float:
    """Run ``stack`` in real time with the requested viewers until Ctrl-C or ``duration``
    simulated seconds, after :func:`warm_up`; returns the simulated time reached."""
    warm_up(stack)
    runner = LiveRunner(stack, real_time_factor=options.real_time_factor)
    handles = open_viewers(runner, options)
    end = None if duration is None else stack.now + duration
    try:
        runner.start()
        while runner.running:
            runner.wait(0.2)
            if end is not None and runner.now >= end:
                break
    except KeyboardInterrupt:
        pass
    finally:
        close_viewers(handles)
        runner.stop()
    if runner.error is not None:
        raise runner.error
    return runner.now
