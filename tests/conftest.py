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
    """Drive a twin of the office robot half a metre in plain simulated time (what
    ``navstack run`` does before it serves), so that the planner, controller and costmap
    kernels (``numba.njit(cache=True)``) are compiled -- or loaded from the cache --
    before a test that waits on the wall clock.  On a fresh clone the
    first goal's compilation took longer than ``LiveRunner.call``'s 10 s in a live-runner
    test (CI, eighth session: the Telegram goal test timed out there)."""
    from navstack.interfaces.stack import NavStack
    from navstack.interfaces.warm_up import warm_up_navigation

    result = warm_up_navigation(NavStack("office", seed=1))
    # a warm-up that failed to drive would leave the kernels uncompiled: say so here
    # rather than as a wall-clock timeout in the test that depends on it
    assert result.reached, f"navigation warm-up: {result.reason}"
