"""Look up and run benchmark suites by name (lazy imports)."""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from navstack.benchmarks.common import BenchResult, Progress
from navstack.core.errors import ConfigError, UnknownNameError

# suite name -> module exposing run(quick, data_dir, **options) -> BenchResult
SUITE_MODULES: dict[str, str] = {
    "sim": "navstack.benchmarks.sim",
    "planners": "navstack.benchmarks.planners",
    "costmap": "navstack.benchmarks.costmap",
    "dwb": "navstack.benchmarks.dwb",
    "navigation": "navstack.benchmarks.navigation",
    "slam": "navstack.benchmarks.slam",
    "slam-params": "navstack.benchmarks.slam_params",
    "slam-robust": "navstack.benchmarks.slam_robust",
    "localization": "navstack.benchmarks.localization",
    "recording": "navstack.benchmarks.recording",
    "mppi": "navstack.benchmarks.mppi",
    "hybrid": "navstack.benchmarks.hybrid",
    "camera": "navstack.benchmarks.camera",
    "aruco": "navstack.benchmarks.aruco",
    "marker-frame": "navstack.benchmarks.marker_frame",
    "retrieval": "navstack.benchmarks.retrieval",
    "gripper": "navstack.benchmarks.gripper",
    "exploration": "navstack.benchmarks.exploration",
    "link": "navstack.benchmarks.link",
    "split": "navstack.benchmarks.split",
    "safety": "navstack.benchmarks.safety",
    "rover": "navstack.benchmarks.rover",
}


class SuiteOptionError(ConfigError):
    """A suite was given an option its ``run`` does not take (e.g. ``--controller`` for
    a suite that runs no controller)."""


def available_suites() -> list[str]:
    return sorted(SUITE_MODULES)


def run_suite(name: str, quick: bool = False, data_dir: Path | None = None,
              options: Mapping[str, Any] | None = None,
              progress: Progress | None = None) -> BenchResult:
    """Run suite ``name``; ``options`` are passed to its ``run`` as keyword arguments.

    An option the suite's ``run`` does not accept is a :class:`SuiteOptionError` naming
    the suites that do, rather than silently ignored.  ``progress`` hears the suite's
    stages when its ``run`` takes ``progress=``, else the suite as one stage.
    """
    module = SUITE_MODULES.get(name)
    if module is None:
        raise UnknownNameError("benchmark suite", name, SUITE_MODULES)
    run = importlib.import_module(module).run
    kwargs = dict(options or {})
    accepted = set(inspect.signature(run).parameters)
    for key in kwargs:
        if key not in accepted:
            takers = [s for s, m in SUITE_MODULES.items()
                      if key in inspect.signature(importlib.import_module(m).run).parameters]
            raise SuiteOptionError(
                f"benchmark suite '{name}' has no option '{key}'", key_path=key,
                suggestion=f"suites that take it: {', '.join(takers)}" if takers
                else "no suite takes it")
    if progress is not None and "progress" in accepted:
        kwargs["progress"] = progress
    elif progress is not None:
        progress(name, 0, 1)
    result: BenchResult = run(quick, data_dir, **kwargs)
    if progress is not None and "progress" not in accepted:
        progress(name, 1, 1)
    return result
