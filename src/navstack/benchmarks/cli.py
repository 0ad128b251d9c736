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


def _comma_list(value: str | None, option: str) -> list[str] | None:
    """``a,b`` -> ``["a", "b"]`` (None when the option was not given)."""
    if value is None:
        return None
    items = [v.strip() for v in value.split(",") if v.strip()]
    if not items:
        raise fail(f"{option} needs at least one name (a comma list), got {value!r}")
    return items


def _seed_list(value: str | None) -> list[int] | None:
    items = _comma_list(value, "--seeds")
    if items is None:
        return None
    try:
        return [int(v) for v in items]
    except ValueError:
        raise fail(f"--seeds takes a comma list of integers, got {value!r}") from None


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
    worlds: Annotated[str | None, typer.Option(
        "--worlds", help="Exploration: comma list of worlds (default office,warehouse,"
                         "arena).")] = None,
    seeds: Annotated[str | None, typer.Option(
        "--seeds", help="Exploration: comma list of seeds (default 1,2,3,4,5).")] = None,
    strategies: Annotated[str | None, typer.Option(
        "--strategies", help="Exploration: comma list of strategies (default "
                             "explore_lite,information_gain).")] = None,
    localization: Annotated[str | None, typer.Option(
        "--localization", help="Exploration: slam (default) or perfect (given poses, "
                               "no SLAM error).")] = None,
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
        given: dict[str, object] = {
            "controller": controller, "scenarios": scenarios, "executor": executor,
            "workers": workers, "address": address, "faults": faults, "seed": seed,
            "report": report, "worlds": _comma_list(worlds, "--worlds"),
            "seeds": _seed_list(seeds), "strategies": _comma_list(strategies, "--strategies"),
            "localization": localization}
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
        columns = [c for c, v in result.cases[0].items() if not isinstance(v, list)]
        for column in columns:
            rows.add_column(column, justify="left" if column == "parameter" else "right")
        for case in result.cases:
            rows.add_row(*(Text(f"{case.get(c, '')}") for c in columns))
        Console(width=200).print(rows)
    for note in result.notes:
        typer.echo(f"note: {note}")
    write_json(json_out, result.to_json())
