"""Benchmark suites run by ``navstack bench SUITE [--quick] --json FILE``.

Each suite is a module here with ``run(quick: bool, data_dir: Path | None) -> BenchResult``,
listed in :data:`navstack.benchmarks.runner.SUITE_MODULES`.  Metric names are the ones the
issues give.  Input data (CARMEN logs, g2o graphs, MovingAI maps) is found by
:func:`navstack.benchmarks.common.data_file`: ``--data-dir``, then ``NAVSTACK_DATA``, then
the data shipped in ``navstack/data``, then ``../shared/data``.
"""
