"""``navstack version``, ``check`` and ``doctor``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, one_line


@app.command()
def version() -> None:
    """Print the navstack version."""
    from navstack import __version__

    typer.echo(__version__)


@app.command()
def check(
    stack_file: Annotated[Path | None, typer.Argument(
        help="Stack YAML (robot, world, navigation); default: --world and --robot.")] = None,
    world: Annotated[str, typer.Option(help="World, when no stack file is given.")] = "office",
    robot: Annotated[str, typer.Option(help="Robot profile, when no stack file is given.")]
    = "diff_drive",
    seconds: Annotated[float, typer.Option(
        min=0.5, help="Simulated seconds to run with a short goal.")] = 5.0,
    seed: Annotated[int, typer.Option(help="Random seed, when no stack file is given.")] = 0,
) -> None:
    """Run the stack in simulation with a short goal and check its health contracts.

    Prints one row per check (ok/FAIL, what was measured, how to fix it); exits 0 when
    every check passes, 1 when one fails, 2 when the stack cannot be built.
    """
    from navstack.interfaces.health.session import HealthSession, build_stack

    try:
        session = HealthSession(build_stack(stack_file, world, robot, seed))
        session.run(seconds)
        results = session.report()
        session.close()
    except NavstackError as exc:
        raise fail(one_line(exc)) from None
    from rich.console import Console
    from rich.table import Table

    source = str(stack_file) if stack_file is not None else f"{world} / {robot}"
    table = Table(title=f"navstack check {source} ({seconds:g} s simulated)")
    for column in ("check", "status", "detail", "fix"):
        table.add_column(column)
    for r in results:
        table.add_row(r.name, "ok" if r.ok else "FAIL", r.detail, r.fix)
    Console(width=200).print(table)
    failed = [r.name for r in results if not r.ok]
    typer.echo(f"{len(results) - len(failed)}/{len(results)} checks passed"
               + (f"; failed: {', '.join(failed)}" if failed else ""))
    if failed:
        raise typer.Exit(code=1)


@app.command()
def doctor(
    bag: Annotated[Path | None, typer.Option(
        help="Diagnose this recorded run (rosbag2 folder or .mcap) instead of a simulation.")]
    = None,
    world: Annotated[str | None, typer.Option(help="World to simulate (default office).")]
    = None,
    robot: Annotated[str | None, typer.Option(help="Robot profile (default diff_drive).")]
    = None,
    fault: Annotated[str | None, typer.Option(
        help="Fault to inject: healthy, tf_map_odom, tf_odom_base, controller_inactive, "
             "cmd_vel_ignored, costmap_lethal, progress_blocked, velocity_limits_zero.")]
    = None,
    seconds: Annotated[float, typer.Option(
        min=1.0, help="Simulated seconds (the progress checker needs its 10 s allowance).")]
    = 15.0,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    record: Annotated[Path | None, typer.Option(
        help="Also record the simulated run here (diagnose it later with --bag).")] = None,
) -> None:
    """Walk the textbook decision tree on a simulated or recorded run and name the broken
    contract (exit 0: none broken, 1: one broken, 2: bad input)."""
    from navstack.interfaces.health.session import HealthSession, build_stack, diagnose_bag

    try:
        if bag is not None:
            if world is not None or robot is not None or fault is not None or record:
                raise fail("--bag diagnoses a recording; do not combine it with --world, "
                            "--robot, --fault or --record")
            report = diagnose_bag(bag)
        else:
            session = HealthSession(build_stack(None, world or "office", robot or "diff_drive",
                                                seed), fault=fault or "healthy", record=record)
            session.run(seconds)
            report = session.diagnose()
            session.close()
    except NavstackError as exc:
        raise fail(one_line(exc)) from None
    for line in report.lines():
        typer.echo(line)
    if not report.healthy:
        raise typer.Exit(code=1)
