"""Shared benchmark machinery: timing with medians, result records, suite registry."""

from __future__ import annotations

import os
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


@dataclass
class BenchResult:
    """What a suite measured: named metrics (numbers) plus per-case rows."""

    suite: str
    metrics: dict[str, float] = field(default_factory=dict)
    cases: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: print ``cases`` as a table too (suites whose rows are the result, e.g. a sweep)
    show_cases: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"suite": self.suite, "machine": machine_info(), "metrics": self.metrics,
                "cases": self.cases, "notes": self.notes}


def machine_info() -> dict[str, Any]:
    return {"platform": platform.platform(), "python": platform.python_version(),
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count()}


def time_ms(fn: Callable[[], object], repeats: int, warmup: int = 1) -> list[float]:
    """Wall times [ms] of ``repeats`` calls of ``fn`` after ``warmup`` untimed calls."""
    for _ in range(warmup):
        fn()
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append((time.perf_counter() - t0) * 1e3)
    return out


def median_ms(fn: Callable[[], object], repeats: int, warmup: int = 1) -> float:
    """Median wall time [ms] of ``fn`` over ``repeats`` calls."""
    return float(statistics.median(time_ms(fn, repeats, warmup)))


def default_data_dir() -> Path:
    """``../shared/data`` next to the project root (or ``../../shared/data``, for a
    checkout one folder deeper, e.g. a git worktree), or ``NAVSTACK_DATA`` if set."""
    env = os.environ.get("NAVSTACK_DATA")
    if env:
        return Path(env)
    here = Path(__file__).resolve()
    for parent in here.parents:
        if not (parent / "pyproject.toml").exists():
            continue
        for up in (parent.parent, parent.parent.parent):
            cand = up / "shared" / "data"
            if cand.exists():
                return cand
    return Path.cwd().parent / "shared" / "data"
