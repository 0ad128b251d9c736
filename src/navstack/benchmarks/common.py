"""Shared benchmark machinery: timing with medians, result records, where the data is."""

from __future__ import annotations

import os
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from navstack.core.errors import NavstackError

Progress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: suites that take ``progress=`` report their stages."""


def no_progress(stage: str, done: int, total: int) -> None:
    """The default :data:`Progress`: says nothing."""


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


SHIPPED_DATA = Path(__file__).resolve().parent.parent / "data"
"""The small public data sets shipped in the package (``navstack/data``, see its README)."""

DATA_SOURCES: dict[str, str] = {
    "carmen": "the Radish robotics data set repository (radish.sourceforge.net), 'corrected' "
              "CARMEN logs of the Freiburg SLAM benchmark",
    "g2o": "the 2D pose-graph benchmark graphs distributed with g2o "
           "(github.com/RainerKuemmerle/g2o) and L. Carlone's 2D data sets",
    "movingai": "the MovingAI grid benchmarks (movingai.com/benchmarks)",
}
"""Where to download each data folder's files (named in the missing-file error)."""


class BenchDataMissing(NavstackError, FileNotFoundError):
    """A benchmark's input data is not where it was looked for."""


def shared_data_dir() -> Path | None:
    """``../shared/data`` beside the project checkout (development machines), if present."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        cand = parent.parent / "shared" / "data"
        if (parent / "pyproject.toml").exists() and cand.is_dir():
            return cand
    cand = Path.cwd().parent / "shared" / "data"
    return cand if cand.is_dir() else None


def data_roots(data_dir: Path | None = None) -> list[tuple[str, Path]]:
    """The data folders searched for benchmark inputs, in order, as ``(label, folder)``.

    ``data_dir`` (``navstack bench --data-dir``), then ``$NAVSTACK_DATA``, then the data
    shipped in the package, then ``../shared/data`` beside the checkout.  An explicit
    folder (option or variable) that does not exist raises :class:`BenchDataMissing`
    rather than falling through to the next one, so a typo is never silently ignored.
    """
    roots: list[tuple[str, Path]] = []
    env = os.environ.get("NAVSTACK_DATA")
    for label, given in (("--data-dir", data_dir), ("NAVSTACK_DATA", env or None)):
        if given is None:
            continue
        folder = Path(given)
        if not folder.is_dir():
            raise BenchDataMissing(f"{label} {folder}: no such folder (it should hold "
                                   "carmen/, g2o/ or movingai/ like navstack/data)")
        roots.append((label, folder))
    roots.append(("shipped", SHIPPED_DATA))
    shared = shared_data_dir()
    if shared is not None:
        roots.append(("../shared/data", shared))
    return roots


def data_file(relative: str, data_dir: Path | None = None) -> Path:
    """The first of :func:`data_roots` that holds ``relative`` (``"carmen/x.log.gz"``).

    Raises :class:`BenchDataMissing` naming the file, every folder searched and where
    the file can be downloaded.
    """
    roots = data_roots(data_dir)
    for _, root in roots:
        path = root / relative
        if path.is_file():
            return path
    searched = ", ".join(f"{root} ({label})" for label, root in roots)
    source = DATA_SOURCES.get(Path(relative).parts[0], "")
    raise BenchDataMissing(
        f"benchmark data file {relative} not found; searched {searched}. "
        + (f"Download it from {source}, save it" if source else "Save it")
        + f" as DIR/{relative} and pass --data-dir DIR or set NAVSTACK_DATA=DIR")
