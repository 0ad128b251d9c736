"""``navstack robot`` / ``navstack base``: the stack split over Zenoh, and
``navstack split-demo`` scoring the split office mission (docs/distributed.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, one_line, write_json

StackOpt = Annotated[Path, typer.Option("--stack", help="Stack YAML with a transport "
                                        "section for this process (docs/distributed.md).")]
NameOpt = Annotated[str | None, typer.Option("--name", help="This process's name in the "
                                             "stack file's transport section.")]
ListenOpt = Annotated[list[str] | None, typer.Option("--listen", help="Zenoh endpoint to "
                                                     "listen on, e.g. tcp/0.0.0.0:7447 "
                                                     "(replaces the stack file's).")]
ConnectOpt = Annotated[list[str] | None, typer.Option("--connect", help="Zenoh endpoint of "
                                                      "a peer or router (replaces the "
                                                      "stack file's).")]
RateOpt = Annotated[float | None, typer.Option("--rate", help="Accelerated wall clock "
                                               "(tests; every process the same).")]
OffsetOpt = Annotated[float | None, typer.Option("--clock-offset", help="Simulated error "
                                                 "of this process's clock [s].")]
CompOpt = Annotated[bool, typer.Option("--no-compensate", help="Do not correct received "
                                       "stamps by the estimated clock offset.")]
BlackoutOpt = Annotated[list[str] | None, typer.Option("--blackout", help="START:DURATION "
                                                       "seconds of link blackout after "
                                                       "the link opens (tests).")]
LockstepOpt = Annotated[bool, typer.Option("--lockstep", help="Stepped simulated time "
                                           "shared with the peer instead of the wall clock "
                                           "(reproducible on a loaded machine).")]
ReportOpt = Annotated[Path | None, typer.Option("--report", help="Write the process "
                                                "report (JSON) here.")]


def _overrides(listen: list[str] | None, connect: list[str] | None, rate: float | None,
               offset: float | None, no_compensate: bool,
               blackout: list[str] | None, lockstep: bool = False) -> dict[str, Any]:
    out: dict[str, Any] = {"clock.mode": "lockstep"} if lockstep else {}
    if listen:
        out["listen"] = listen
    if connect:
        out["connect"] = connect
    if rate is not None:
        out["clock.rate"] = rate
    if offset is not None:
        out["clock.offset"] = offset
    if no_compensate:
        out["clock.compensate"] = False
    if blackout:
        spans = []
        for text in blackout:
            start, sep, dur = text.partition(":")
            try:
                spans.append((float(start), float(dur)))
            except ValueError:
                raise fail(f"--blackout {text!r}: give START:DURATION in seconds, "
                           f"e.g. 20:2") from None
            if not sep:
                raise fail(f"--blackout {text!r}: give START:DURATION in seconds, e.g. 20:2")
        out["impairments.blackouts"] = spans
    return out


@app.command()
def robot(stack: StackOpt, name: NameOpt = None, listen: ListenOpt = None,
          connect: ConnectOpt = None, rate: RateOpt = None, clock_offset: OffsetOpt = None,
          no_compensate: CompOpt = False, blackout: BlackoutOpt = None,
          lockstep: LockstepOpt = False, report: ReportOpt = None,
          max_seconds: Annotated[float, typer.Option(help="Stop after this many seconds "
                                                     "(process clock).")] = 3600.0,
          keep_running: Annotated[bool, typer.Option(
              "--keep-running", help="Do not stop when the base leaves (only when "
                                     "the time limit is reached).")] = False) -> None:
    """The robot half: simulator, local costmap, controller, behaviors, collision monitor
    and the link watchdog; ends when the base has come and gone."""
    from navstack.interfaces.split import run_robot

    try:
        out = run_robot(stack, name or "robot", max_seconds,
                        _overrides(listen, connect, rate, clock_offset, no_compensate,
                                   blackout, lockstep), report,
                        stop_when_base_leaves=not keep_running)
    except NavstackError as exc:
        raise fail(one_line(exc)) from None
    typer.echo(f"[robot] done: {out['collisions']} collisions, link stops "
               f"{len(out['watchdog']['stops'])}, base clock offset "
               f"{out['base_offset_s']:+.4f} s")


@app.command()
def base(stack: StackOpt,
         waypoints: Annotated[Path | None, typer.Option(help="Waypoints YAML (default: the "
                                                        "office waypoints).")] = None,
         name: NameOpt = None, listen: ListenOpt = None, connect: ConnectOpt = None,
         rate: RateOpt = None, clock_offset: OffsetOpt = None, no_compensate: CompOpt = False,
         lockstep: LockstepOpt = False, report: ReportOpt = None,
         goal_timeout: Annotated[float, typer.Option(help="Seconds per goal.")] = 240.0
         ) -> None:
    """The base-station half: map server, global costmap, planner, BT navigator; sends
    each waypoint to the robot as a NavigateToPose goal."""
    from navstack.interfaces.demo import default_waypoints_path
    from navstack.interfaces.split import run_base

    try:
        out = run_base(stack, waypoints or default_waypoints_path(), name or "base",
                       _overrides(listen, connect, rate, clock_offset, no_compensate, None,
                                  lockstep),
                       report, goal_timeout)
    except NavstackError as exc:
        raise fail(one_line(exc)) from None
    typer.echo(f"[base] done: {out['succeeded']}/{len(out['goals'])} goals")
    if out["succeeded"] != len(out["goals"]):
        raise typer.Exit(1)


@app.command("split-demo")
def split_demo(
    stack: Annotated[Path | None, typer.Option("--stack", help="Stack YAML (default: the "
                                               "packaged split_office.yaml).")] = None,
    waypoints: Annotated[Path | None, typer.Option(help="Waypoints YAML (default: the "
                                                   "office waypoints).")] = None,
    rate: Annotated[float, typer.Option(help="Accelerated wall clock of both "
                                        "processes.")] = 2.0,
    clock_offset: Annotated[float, typer.Option("--clock-offset", help="Robot clock "
                                                "error [s].")] = 0.0,
    no_compensate: CompOpt = False,
    lockstep: LockstepOpt = False,
    blackout: Annotated[str | None, typer.Option(help="START:DURATION of a robot link "
                                                 "blackout [s].")] = None,
    reference: Annotated[bool, typer.Option(help="Also run the same stack in one process "
                                            "(same nodes, parameters and seed, simulated "
                                            "time) and compare trajectories.")] = True,
    in_process: Annotated[bool, typer.Option(
        "--in-process", help="Only run the same stack's robot and base halves in one "
                             "process on the in-process bus (the reference; with "
                             "--clock-offset on the clock a lockstep robot with that "
                             "offset runs on) and print its figures.")] = False,
    reference_csv: Annotated[Path | None, typer.Option(
        "--reference-csv", help="Compare with this t,x,y,theta trajectory CSV instead of "
                                "running the in-process reference.")]
    = None,
    port: Annotated[int, typer.Option(help="Loopback TCP port of the robot.")] = 7447,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the figures "
                                                  "here.")] = None,
) -> None:
    """Run the office mission as robot + base processes over Zenoh on loopback and print
    goals, collisions, trajectory deviation from the same stack run in one process,
    latencies, the estimated clock offset and (with --blackout) the time to a zero base
    command.  `navstack bench split` runs all of issue 21's cases."""
    from importlib import resources

    import numpy as np

    from navstack.interfaces.demo import default_waypoints_path
    from navstack.interfaces.split_demo import reference_run, run_split, score
    from navstack.interfaces.split_nodes import trajectory_array

    stack = stack or Path(str(resources.files("navstack") / "config" / "split_office.yaml"))
    wp = waypoints or default_waypoints_path()
    span = None
    if blackout is not None:
        ov = _overrides(None, None, None, None, False, [blackout])
        span = ov["impairments.blackouts"][0]
    figures: dict[str, Any]
    try:
        if in_process:
            ref_run = reference_run(stack, wp, clock_offset=clock_offset)
            samples = ref_run["scan_to_cmd_s"]
            figures = {"goals": f"{ref_run['succeeded']}/{len(ref_run['goals'])}",
                       "goal_times_s": [g["time_s"] for g in ref_run["goals"]],
                       "failures": [f"{g['name']}: {g['reason']}" for g in ref_run["goals"]
                                    if g["status"] != "SUCCEEDED"],
                       "collisions": ref_run["collisions"],
                       "sim_time_s": sum(g["time_s"] for g in ref_run["goals"]),
                       "scan_to_cmd_samples": len(samples)}
        else:
            robot_rep, base_rep = run_split(stack, wp, rate=rate, offset=clock_offset,
                                            compensate=not no_compensate, blackout=span,
                                            port=port, lockstep=lockstep)
            if reference_csv is not None:
                ref = np.loadtxt(reference_csv, delimiter=",", skiprows=1).reshape(-1, 4)
            elif reference:
                ref = trajectory_array(reference_run(stack, wp)["trajectory"])
            else:
                ref = None
            figures = score(robot_rep, base_rep, ref, clock_offset, span)
    except (NavstackError, RuntimeError, OSError, ValueError) as exc:
        raise fail(one_line(exc)) from None
    for key, value in figures.items():
        typer.echo(f"{key:32s} {value:.4f}" if isinstance(value, float)
                   else f"{key:32s} {value}")
    write_json(json_out, {"suite": "split_demo", "metrics": figures,
                          "args": json.loads(json.dumps({"rate": rate, "offset": clock_offset,
                                                         "compensate": not no_compensate,
                                                         "lockstep": lockstep,
                                                         "in_process": in_process,
                                                         "blackout": blackout}))})
