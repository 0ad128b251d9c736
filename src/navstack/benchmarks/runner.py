"""Look up and run benchmark suites by name (lazy imports)."""

from __future__ import annotations

import importlib
from pathlib import Path

from navstack.benchmarks.common import BenchResult, default_data_dir
from navstack.core.errors import UnknownNameError

# suite name -> module exposing run(quick, data_dir) -> BenchResult
SUITE_MODULES: dict[str, str] = {
    "sim": "navstack.benchmarks.sim",
    "planners": "navstack.benchmarks.planners",
    "costmap": "navstack.benchmarks.costmap",
    "navigation": "navstack.benchmarks.navigation",
    "slam": "navstack.benchmarks.slam",
    "slam-params": "navstack.benchmarks.slam_params",
    "localization": "navstack.benchmarks.localization",
    "recording": "navstack.benchmarks.recording",
    "mppi": "navstack.benchmarks.mppi",
}


def available_suites() -> list[str]:
    return sorted(SUITE_MODULES)


def run_suite(name: str, quick: bool = False, data_dir: Path | None = None) -> BenchResult:
    module = SUITE_MODULES.get(name)
    if module is None:
        raise UnknownNameError("benchmark suite", name, SUITE_MODULES)
    result: BenchResult = importlib.import_module(module).run(quick, data_dir or default_data_dir())
    return result
