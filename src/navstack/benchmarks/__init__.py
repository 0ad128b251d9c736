"""Benchmark suites run by ``navstack bench SUITE [--quick] --json FILE``.

Each suite is a module here with ``run(quick: bool, data_dir: Path | None) -> BenchResult``,
listed in :data:`navstack.benchmarks.runner.SUITE_MODULES`.  Metric names are the ones the
issues give.
"""
