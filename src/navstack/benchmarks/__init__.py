"""Benchmark suites run by ``navstack bench SUITE [--quick] --json FILE``.

Each suite is a module here with ``run(quick: bool, data_dir: Path | None) -> BenchResult``;
suites register in :data:`SUITES`.  Metric names are the ones the issues give.
"""

from navstack.benchmarks.common import SUITES, BenchResult, median_ms, suite

__all__ = ["SUITES", "BenchResult", "median_ms", "suite"]
