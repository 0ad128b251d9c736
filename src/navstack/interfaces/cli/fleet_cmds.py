"""``navstack fleet``: several robots, one namespace and one route each, in one simulated
world (docs/fleet.md)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, one_line, write_json

if TYPE_CHECKING:
    from navstack.interfaces.fleet import Fleet


@app.command("fleet")
def fleet(
    fleet_file: Annotated[Path | None, typer.Option("--fleet", help="Fleet YAML (default: "
                                                    "the packaged warehouse_fleet.yaml).")]
    = None,
    world: Annotated[str | None, typer.Option("--world", help="Must match the fleet file's "
                                              "world (a check; routes belong to a "
                                              "world).")] = None,
    robots: Annotated[int | None, typer.Option("--robots", help="Use the first N robots "
                                               "of the fleet file.")] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Instead of the file's "
                                             "seed.")] = None,
    out: Annotated[Path, typer.Option("--out", help="Directory for report.json, report.md "
                                      "and fleet.png.")] = Path("runs/fleet"),
    json_path: Annotated[Path | None, typer.Option("--json", help="Also write the report "
                                                   "here.")] = None,
    dashboard: Annotated[bool, typer.Option("--dashboard", help="Serve the fleet view (every "
                                            "robot's pose, plan, trail and goal on one map) "
                                            "while the mission runs.")] = False,
    host: Annotated[str, typer.Option(help="Fleet view address.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Fleet view port (0: a free one).")] = 8080,
    real_time_factor: Annotated[float, typer.Option(
        "--real-time-factor", help="With --dashboard: simulated seconds per wall second "
        "(0: as fast as possible).")] = 1.0,
) -> None:
    """Run every robot's route at once; print each robot's goals and the fleet's
    collisions (robot-robot included) and closest approach.  Exit 1 unless every goal
    succeeded with 0 collisions."""
    from navstack.interfaces.fleet import Fleet, load_fleet
    from navstack.interfaces.fleet_mission import format_summary, run_fleet

    try:
        params = load_fleet(fleet_file)
        if world is not None and world != params.world:
            raise fail(f"--world {world}: the fleet '{params.name}' is defined in world "
                       f"'{params.world}' (its spawns and routes belong to it); pass "
                       f"--fleet FILE for another world")
        if seed is not None:
            params = params.updated(seed=seed)
        fleet_ = Fleet(params, robots=robots)
        if dashboard:
            report = _with_view(fleet_, out, host, port, real_time_factor)
        else:
            report = run_fleet(fleet_, out)
    except NavstackError as exc:
        raise fail(one_line(exc)) from None
    for line in format_summary(report):
        typer.echo(line)
    typer.echo(f"report in {out}")
    write_json(json_path, report)
    if not report["success"]:
        raise typer.Exit(code=1)


def _with_view(fleet: Fleet, out: Path, host: str, port: int,
               real_time_factor: float) -> dict[str, Any]:
    """Run the mission with the fleet view served, paced to ``real_time_factor``."""
    from navstack.interfaces.fleet_mission import FleetMission, run_fleet
    from navstack.interfaces.web.fleet_view import FleetView, serve_fleet_view

    views: list[FleetView] = []
    wall0 = time.monotonic()

    def progress(mission: FleetMission) -> None:
        if not views:
            views.append(FleetView(mission))
            handle = serve_fleet_view(views[0], host, port)
            handles.append(handle)
            typer.echo(f"navstack fleet view: {handle.url}")
        views[0].update()
        if real_time_factor > 0:
            ahead = mission.fleet.now / real_time_factor - (time.monotonic() - wall0)
            if ahead > 0:
                time.sleep(ahead)

    handles: list[Any] = []
    try:
        return run_fleet(fleet, out, progress=progress)
    finally:
        for h in handles:
            h.stop()
