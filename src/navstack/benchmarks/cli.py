"""``navstack bench``: the benchmark suites on the command line.

Benchmarks drive the whole stack (they import ``interfaces``), so their command lives
here, above the interfaces layer, and :mod:`navstack.app` adds it to the CLI.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, stop_on_sigterm, write_json
from navstack.interfaces.cli.options import check_out_file


@app.command()
def bench(
    suite: Annotated[str, typer.Argument(help="Suite name (see `navstack bench list`).")],
    quick: Annotated[bool, typer.Option("--quick", help="Smaller, faster run (CI).")] = False,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results here.")] = None,
    data_dir: Annotated[Path | None, typer.Option(help=(
        "Folder searched first for benchmark data (then NAVSTACK_DATA, the data shipped "
        "in navstack/data, ../shared/data)."))] = None,
    controller: Annotated[str | None, typer.Option(
        "--controller", help="FollowPath controller of the navigation suite: dwb "
                             "(default), mppi or rpp.")] = None,
    scenarios: Annotated[int | None, typer.Option(
        "--scenarios", help="Navigation suite: run this many chaos scenarios (random trips "
                            "with injected faults) instead of the fixed suite.")] = None,
    executor: Annotated[str | None, typer.Option(
        "--executor", help="Navigation suite: where scenarios run: serial (default), "
                           "local (processes) or ray.")] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", help="Parallel workers for --executor local/ray (default: one per "
                          "CPU); exploration: cases run at a time (default 1).")] = None,
    address: Annotated[str | None, typer.Option(
        "--address", help="Running Ray cluster to use (e.g. auto or ray://host:10001); "
                          "default: start a local one.")] = None,
    faults: Annotated[str | None, typer.Option(
        "--faults", help="Chaos faults drawn with --scenarios: all (default), none or a "
                         "comma list (lidar_dropout, odom_slip, scan_latency, tf_delay, "
                         "kidnap, blocked, crowd).")] = None,
    seed: Annotated[int | None, typer.Option(
        "--seed", help="Seed of the chaos scenarios (default 7).")] = None,
    report: Annotated[Path | None, typer.Option(
        "--report", help="Folder for the sweep report (sweep.json, sweep.md, "
                         "time_to_goal.png).")] = None,
) -> None:
    """Run a benchmark suite; prints a table of metrics and writes JSON.

    Shows progress per stage on stderr (a bar on a terminal, one line per stage
    otherwise)."""
    from navstack.benchmarks.runner import available_suites, run_suite
    from navstack.interfaces.cli.progress import StageProgress

    if suite == "list":
        for name in available_suites():
            typer.echo(name)
        return
    if json_out is not None:
        check_out_file(json_out, "--json")
    try:
        given = {"controller": controller, "scenarios": scenarios, "executor": executor,
                 "workers": workers, "address": address, "faults": faults, "seed": seed,
                 "report": report}
        options = {k: v for k, v in given.items() if v is not None}
        with stop_on_sigterm(), StageProgress(f"bench {suite}") as progress:
            result = run_suite(suite, quick, data_dir, options, progress=progress)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    label = f" --controller {controller}" if controller is not None else ""
    table = Table(title=f"navstack bench {suite}{label}{' (quick)' if quick else ''}")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, value in result.metrics.items():
        table.add_row(Text(key), f"{value:.4g}" if isinstance(value, float) else str(value))
    Console().print(table)
    if result.show_cases and result.cases:
        rows = Table(title=f"{suite}: runs")
        columns = list(result.cases[0])
        for column in columns:
            rows.add_column(column, justify="left" if column == "parameter" else "right")
        for case in result.cases:
            rows.add_row(*(Text(f"{case.get(c, '')}") for c in columns))
        Console(width=200).print(rows)
    for note in result.notes:
        typer.echo(f"note: {note}")
    write_json(json_out, result.to_json())
