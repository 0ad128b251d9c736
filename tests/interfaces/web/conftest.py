"""Fixtures: a live dashboard on a free port over the office world, and polling helpers."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import httpx
import pytest

from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack
from navstack.interfaces.web import DashboardHandle, serve_dashboard

TOKEN = "test-token-0123456789"


def wait_until(predicate: Callable[[], Any], timeout: float, what: str,
               period: float = 0.05) -> Any:
    """Poll ``predicate`` until truthy; fail naming ``what`` after ``timeout`` wall seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(period)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


@dataclass
class Base:
    """Samples at the base (simulator) every 10 ms of simulated time, in the sim thread:
    ``(t, commanded vx, commanded wz, actual vx, x, y)``."""

    rows: list[tuple[float, float, float, float, float, float]] = field(default_factory=list)

    def install(self, runner: LiveRunner) -> None:
        def setup(stack: NavStack) -> None:
            sim = stack.sim.sim

            def sample() -> None:
                stack.sim.advance()
                p = sim.pose
                self.rows.append((stack.now, sim.command.vx, sim.command.wz, sim.state.vx,
                                  p.x, p.y))

            stack.runtime.scheduler.create_timer(0.01, sample)

        runner.call(setup)

    def speed(self) -> float:
        rows = self.rows
        return abs(rows[-1][3]) if rows else 0.0


@dataclass
class Live:
    handle: DashboardHandle
    client: httpx.Client
    base: Base

    @property
    def runner(self) -> LiveRunner:
        return self.handle.runner

    def auth(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.handle.token}"}

    def state(self) -> dict[str, Any]:
        data: dict[str, Any] = self.client.get("/api/state").json()
        return data


def start_live(real_time_factor: float | None) -> Live:
    stack = NavStack("office", seed=1)
    handle = serve_dashboard(stack, "127.0.0.1", 0, TOKEN, real_time_factor=real_time_factor,
                             announce=lambda _: None)
    base = Base()
    base.install(handle.runner)
    return Live(handle, httpx.Client(base_url=handle.url, timeout=15.0), base)


@pytest.fixture
def live(navigation_compiled: None) -> Iterator[Live]:
    """Dashboard over an unthrottled simulation (tests measure simulated time)."""
    lv = start_live(None)
    try:
        yield lv
    finally:
        lv.client.close()
        lv.handle.stop()
