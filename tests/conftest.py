"""Test-wide settings: numba caches inside the project, headless matplotlib; the
navigation kernels compiled before wall-clock tests."""

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".cache" / "numba"))
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def navigation_compiled() -> None:
    """Drive the office robot to one goal in plain simulated time, so that the planner,
    controller and costmap kernels (``numba.njit(cache=True)``) are compiled -- or loaded
    from the cache -- before a test that waits on the wall clock.  On a fresh clone the
    first goal's compilation took longer than ``LiveRunner.call``'s 10 s in a live-runner
    test (CI, eighth session: the Telegram goal test timed out there)."""
    from navstack.core.msgs import Pose2D
    from navstack.interfaces.stack import NavStack
    from navstack.missions import (
        Mission,
        MissionContext,
        MissionRunner,
        MissionStatus,
        NavigateToPose,
    )

    stack = NavStack("office", seed=1).start()
    ctx = MissionContext(stack.runtime)
    spawn = stack.description.spawn
    goal = NavigateToPose(ctx, Pose2D(spawn.x + 0.5, spawn.y, spawn.theta), name="warm-up")
    result = MissionRunner(stack.runtime, Mission("warm-up", goal, ctx)).run(timeout=60.0)
    # a warm-up that failed to drive would leave the kernels uncompiled: say so here
    # rather than as a wall-clock timeout in the test that depends on it
    assert result.status is MissionStatus.SUCCEEDED, f"navigation warm-up: {result.reason}"
