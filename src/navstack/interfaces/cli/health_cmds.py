"""``navstack version``, ``check`` and ``doctor``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, one_line, stop_on_sigterm, warn
from navstack.interfaces.cli.options import (
    check_out_dir,
    duration_option,
    prefer,
    seconds_alias,
    seed_option,
)


@app.command()
def version() -> None:
    """Print the navstack version."""
    from navstack import __version__

    typer.echo(__version__)


@app.command()
def check(
    stack_file: Annotated[Path | None, typer.Option(
        "--stack", help="Stack YAML (robot, world, navigation); default: --world and "
                        "--robot.")] = None,
    world: Annotated[str, typer.Option(help="World, when no stack file is given.")] = "office",
    robot: Annotated[str, typer.Option(help="Robot profile, when no stack file is given.")]
    = "diff_drive",
    duration: Annotated[float, duration_option(
        "Simulated seconds to run with a short goal.", low=0.5, low_open=False)] = 5.0,
    seed: Annotated[int, seed_option("Random seed, when no stack file is given.")] = 0,
    old_stack: Annotated[Path | None, typer.Argument(
        hidden=True, metavar="[STACK_FILE]", help="Deprecated: use --stack.")] = None,
    old_seconds: Annotated[float | None, seconds_alias(low=0.5, low_open=False)] = None,
    link: Annotated[str | None, typer.Option(
        "--link", help="Join the split stack as this process of the stack file's transport "
                       "section (e.g. base) and check the clock contract with its peers "
                       "instead of simulating.")] = None,
    no_compensate: Annotated[bool, typer.Option(
        "--no-compensate", help="With --link: judge as if stamps were not compensated.")]
    = False,
) -> None:
    """Run the stack in simulation with a short goal and check its health contracts.

    With ``--link NAME`` (a split stack over Zenoh): join as NAME for --duration seconds
    and check the ``clock`` contract with every peer (offset, round trip, compensation).
    Prints one row per check (ok/FAIL, what was measured, how to fix it); exits 0 when
    every check passes, 1 when one fails, 2 when the stack cannot be built.
    """
    from navstack.interfaces.health.session import HealthSession, build_stack

    stack_file = prefer("--stack", stack_file, "a positional STACK_FILE", old_stack, warn)
    seconds = prefer("--duration", duration, "--seconds", old_seconds, warn)
    try:
        with stop_on_sigterm():
            if link is not None:
                if stack_file is None:
                    raise fail("--link needs --stack (the file with the transport section)")
                results = _link_checks(stack_file, link, seconds, no_compensate)
            else:
                session = HealthSession(build_stack(stack_file, world, robot, seed))
                try:
                    session.run(seconds)
                    results = session.report()
                finally:
                    session.close()
    except NavstackError as exc:
        raise fail(one_line(exc)) from None
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    source = str(stack_file) if stack_file is not None else f"{world} / {robot}"
    span = f"link as '{link}', {seconds:g} s" if link else f"{seconds:g} s simulated"
    table = Table(title=Text(f"navstack check {source} ({span})"))
    for column in ("check", "status", "detail", "fix"):
        table.add_column(column)
    for r in results:  # Text: brackets in details ("[m/s]") are not markup
        table.add_row(Text(r.name), "ok" if r.ok else "FAIL", Text(r.detail), Text(r.fix))
    Console(width=200).print(table)
    failed = [r.name for r in results if not r.ok]
    typer.echo(f"{len(results) - len(failed)}/{len(results)} checks passed"
               + (f"; failed: {', '.join(failed)}" if failed else ""))
    if failed:
        raise typer.Exit(code=1)


def _link_checks(stack_file: Path, name: str, seconds: float,
                 no_compensate: bool) -> list[Any]:
    """The clock contract of process ``name`` of a split stack with each of its peers."""
    from navstack.interfaces.health.checks import clock_contract
    from navstack.interfaces.split import transport_for, wall_runtime
    from navstack.runtime.transports.zenoh_link import ZenohLink

    t = transport_for(stack_file, name,
                      {"clock.compensate": False} if no_compensate else None)
    rt = wall_runtime(t)
    zlink = ZenohLink(rt, t, peers=t.peers)
    try:  # wait (at most 30 s) for every peer to answer, then observe for `seconds`
        rt.scheduler.run_for(30.0 * t.clock.rate,
                             until=lambda: all(zlink.ready(p) for p in t.peers))
        rt.scheduler.run_for(seconds * t.clock.rate)
        health = zlink.health()
    finally:
        zlink.close()
    return [clock_contract(peer, health[peer], t.clock.tolerance) for peer in t.peers]


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
    duration: Annotated[float, duration_option(
        "Simulated seconds (the progress checker needs its 10 s allowance).", low=1.0,
        low_open=False)] = 15.0,
    seed: Annotated[int, seed_option("Random seed.")] = 0,
    stack_file: Annotated[Path | None, typer.Option(
        "--stack", help="Stack YAML to simulate instead of --world/--robot.")] = None,
    record: Annotated[Path | None, typer.Option(
        help="Also record the simulated run here (diagnose it later with --bag).")] = None,
    force: Annotated[bool, typer.Option(
        "--force", help="With --record: replace a bag already there.")] = False,
    old_seconds: Annotated[float | None, seconds_alias(low=1.0, low_open=False)] = None,
) -> None:
    """Walk the textbook decision tree on a simulated or recorded run and name the broken
    contract (exit 0: none broken, 1: one broken, 2: bad input)."""
    from navstack.interfaces.health.session import HealthSession, build_stack, diagnose_bag

    seconds = prefer("--duration", duration, "--seconds", old_seconds, warn)
    if bag is not None and (world is not None or robot is not None or fault is not None
                            or record or stack_file is not None):
        raise fail("--bag diagnoses a recording; do not combine it with --world, --robot, "
                   "--stack, --fault or --record")
    if stack_file is not None and (world is not None or robot is not None):
        raise fail("--stack names the world and robot; do not combine it with --world or "
                   "--robot")
    if record is not None:
        check_out_dir(record.parent, "--record")
        if record.exists() and not force:
            raise fail(f"--record: {record} already exists; add --force to replace it, or "
                       "choose another path")
    try:
        if bag is not None:
            report = diagnose_bag(bag)
        else:
            with stop_on_sigterm():
                session = HealthSession(build_stack(stack_file, world or "office",
                                                    robot or "diff_drive", seed),
                                        fault=fault or "healthy", record=record,
                                        replace=force)
                try:
                    session.run(seconds)
                    report = session.diagnose()
                finally:
                    session.close()
    except NavstackError as exc:
        raise fail(one_line(exc)) from None
    for line in report.lines():
        typer.echo(line)
    if not report.healthy:
        raise typer.Exit(code=1)
