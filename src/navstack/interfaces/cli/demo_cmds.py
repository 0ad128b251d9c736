"""``navstack demo`` and ``run``: the flagship mission and the live stack."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, stop_on_sigterm
from navstack.interfaces.cli.options import (
    MAX_LIVE_SECONDS,
    check_out_dir,
    duration_option,
    port_option,
    rate_option,
    seed_option,
)


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="Folder for report.json, report.md and "
                                      "trajectory.png.")] = Path("runs/demo"),
    seed: Annotated[int, seed_option()] = 1,
    world: Annotated[str | None, typer.Option(
        help="World name or path (default: office; campus for --robot golf_cart).")] = None,
    robot: Annotated[str, typer.Option(help="Robot profile (golf_cart: the campus route "
                                       "with Hybrid-A* + MPPI).")] = "diff_drive",
    waypoints: Annotated[Path | None, typer.Option(
        help="Waypoints YAML (default: the office waypoints, order Goal_3, Goal_4, "
             "Goal_2, Goal_1; the campus route for golf_cart).")] = None,
    record: Annotated[bool, typer.Option(
        "--record", help="Also record the run as a rosbag2 (MCAP) in OUT/bag (read it "
                         "with `navstack report OUT/bag`).")] = False,
    force: Annotated[bool, typer.Option(
        "--force", help="With --record: replace a bag an earlier run left in "
                        "OUT/bag.")] = False,
    web: Annotated[bool, typer.Option("--web", help="Serve the web dashboard while the "
                                      "mission runs (paced at --rate).")] = False,
    port: Annotated[int, port_option("--port", help="Dashboard port.")] = 8080,
    host: Annotated[str, typer.Option(help="Dashboard address (0.0.0.0 for a phone on "
                                      "the same network).")] = "127.0.0.1",
    token: Annotated[str | None, typer.Option(help="Dashboard command token (visible to "
                                              "every user in `ps`: prefer --token-file "
                                              "or $NAVSTACK_DASHBOARD_TOKEN; default: "
                                              "generated and printed).")] = None,
    token_file: Annotated[Path | None, typer.Option(help="File holding the dashboard "
                                                    "token (first line).")] = None,
    tls_cert: Annotated[Path | None, typer.Option(help="TLS certificate (PEM): serve "
                                                  "HTTPS/WSS.")] = None,
    tls_key: Annotated[Path | None, typer.Option(help="TLS private key (PEM).")] = None,
    foxglove: Annotated[bool, typer.Option("--foxglove", help="Serve Foxglove live on "
                                           "127.0.0.1 while the mission runs.")] = False,
    foxglove_port: Annotated[int, port_option("--foxglove-port",
                                              help="Foxglove WebSocket port.")] = 8765,
    rate: Annotated[float, rate_option("Real-time factor with --web/--foxglove "
                                       "(simulated seconds per wall second).")] = 1.0,
    link: Annotated[str | None, typer.Option(
        help="Drive the simulator through the robot's vehicle link: udp (rover VCU on "
             "loopback) or serial (golf cart Arduinos on ptys).  The rover's mission "
             "always runs through its UDP VCU link.")] = None,
    course: Annotated[Path | None, typer.Option(
        help="With --robot rover: the course YAML whose demo legs run (default: the mars "
             "yard course, one GNSS, gate and post leg).")] = None,
) -> None:
    """Flagship mission: visit named waypoints in order in the simulator, write a report.

    With ``--robot rover`` (and no --world/--waypoints): the rover's mission -- one GNSS,
    gate and post leg of the course YAML, run by the rover's behaviour tree through the
    UDP VCU link.  Every goal has a time limit, so the mission always ends.  SIGTERM
    ends it like Ctrl-C: a recording is closed and stays readable.
    """
    from navstack.interfaces.demo import run_demo
    from navstack.interfaces.live_cli import LiveOptions, attach_to_demo

    check_out_dir(out, "--out")
    if robot == "rover" and world is None and waypoints is None:
        if link not in (None, "udp"):
            raise fail(f"the rover talks to its vehicle over udp, not {link}; use --link udp")
        if record or web or foxglove:
            raise fail("--record, --web and --foxglove are not available for the rover "
                       "mission; give --world/--waypoints for the waypoint demo")
        _rover_demo(out, seed, course)
        return
    if course is not None:
        raise fail("--course is for --robot rover's mission")
    bag = out / "bag"
    if record and bag.exists() and not force:
        raise fail(f"--record: {bag} already exists (from an earlier run); add --force to "
                   "replace it, or choose another --out")
    live = LiveOptions(web=web, host=host, port=port, token=token, foxglove=foxglove,
                       foxglove_port=foxglove_port, real_time_factor=rate,
                       token_file=token_file, tls_cert=tls_cert, tls_key=tls_key)
    if link not in (None, "udp", "serial"):
        raise fail(f"--link must be udp or serial, got {link!r}")
    try:
        with stop_on_sigterm():
            report = run_demo(out, seed, world, robot, waypoints, record=record,
                              replace_bag=force,
                              attach=attach_to_demo(live) if live.enabled else None,
                              link=link)  # type: ignore[arg-type]
    except NavstackError as exc:
        raise fail(str(exc)) from None
    if "bag" in report:
        typer.echo(f"recorded {report['bag']['messages']} messages to {report['bag']['path']}")
    if "link" in report:
        lat = report["link"]["command_latency"]
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        verdict = "within" if lat["p95_ms"] <= 5.0 else "over"
        typer.echo(f"vehicle link ({report['link']['kind']}, {report['link']['vehicle']}): "
                   f"{report['link']['commands_sent']} commands, added command latency p50 "
                   f"{lat['p50_ms']:.3f} ms, p95 {lat['p95_ms']:.3f} ms ({verdict} the 5 ms "
                   f"budget; wall-clock, 1-minute load average {load:.1f} on "
                   f"{os.cpu_count()} CPUs), max {lat['max_ms']:.3f} ms; link losses "
                   f"{report['link']['link_losses']}")
    verdict = "SUCCESS" if report["success"] else "FAILURE"
    moving = report["min_clearance_moving_m"]
    walkers = f", to walkers {moving:.2f} m" if moving is not None else ""
    typer.echo(f"{verdict}: {sum(g['status'] == 'SUCCEEDED' for g in report['goals'])}/"
               f"{len(report['goals'])} goals, {report['collisions']} collisions, min clearance "
               f"to static obstacles {report['min_clearance_static_m']:.2f} m{walkers}, "
               f"{report['sim_time_s']:.0f} s simulated in {report['wall_time_s']:.0f} s; "
               f"report in {out}")
    if not report["success"]:
        raise typer.Exit(code=1)


@app.command()
def run(
    world: Annotated[str, typer.Option(help="World name or path.")] = "office",
    robot: Annotated[str, typer.Option(help="Robot profile.")] = "diff_drive",
    seed: Annotated[int, seed_option("Random seed.")] = 1,
    stack_file: Annotated[Path | None, typer.Option(
        "--stack", help="Stack YAML (robot, world, navigation parameters) instead of "
                        "--world/--robot.")] = None,
    amcl: Annotated[bool, typer.Option("--amcl", help="Localize with AMCL.")] = False,
    slam: Annotated[bool, typer.Option("--slam", help="Map with SLAM while "
                                       "navigating.")] = False,
    web: Annotated[bool, typer.Option("--web", help="Serve the web dashboard.")] = False,
    port: Annotated[int, port_option("--port", help="Dashboard port.")] = 8080,
    host: Annotated[str, typer.Option(help="Dashboard address (0.0.0.0 for a phone on "
                                      "the same network).")] = "127.0.0.1",
    token: Annotated[str | None, typer.Option(help="Dashboard command token (visible to "
                                              "every user in `ps`: prefer --token-file "
                                              "or $NAVSTACK_DASHBOARD_TOKEN; default: "
                                              "generated and printed).")] = None,
    token_file: Annotated[Path | None, typer.Option(help="File holding the dashboard "
                                                    "token (first line).")] = None,
    tls_cert: Annotated[Path | None, typer.Option(help="TLS certificate (PEM): serve "
                                                  "HTTPS/WSS.")] = None,
    tls_key: Annotated[Path | None, typer.Option(help="TLS private key (PEM).")] = None,
    foxglove: Annotated[bool, typer.Option("--foxglove", help="Serve Foxglove live on "
                                           "127.0.0.1.")] = False,
    foxglove_port: Annotated[int, port_option("--foxglove-port",
                                              help="Foxglove WebSocket port.")] = 8765,
    rate: Annotated[float, rate_option("Real-time factor (simulated seconds per wall "
                                       "second).")] = 1.0,
    duration: Annotated[float | None, duration_option(
        "Stop after this many simulated seconds (default: until Ctrl-C or SIGTERM).",
        high=MAX_LIVE_SECONDS)] = None,
) -> None:
    """Run the stack live in the simulator and watch or command it (--web, --foxglove)."""
    from navstack.interfaces.live_cli import LiveOptions, run_live
    from navstack.interfaces.stack import NavStack
    from navstack.interfaces.stack_description import LocalizationName

    live = LiveOptions(web=web, host=host, port=port, token=token, foxglove=foxglove,
                       foxglove_port=foxglove_port, real_time_factor=rate,
                       token_file=token_file, tls_cert=tls_cert, tls_key=tls_key)
    if not live.enabled:
        raise fail("nothing to watch: add --web and/or --foxglove")
    if stack_file is not None and (amcl or slam):
        raise fail("--stack describes the whole stack; do not combine it with --amcl or "
                   "--slam")
    if amcl and slam:
        raise fail("--amcl and --slam exclude each other: SLAM localizes on its own map")
    localization: LocalizationName = "slam" if slam else "amcl" if amcl else "perfect"
    try:
        stack = (NavStack.from_stack_file(stack_file) if stack_file is not None
                 else NavStack(world, robot, seed=seed, localization=localization))
        with stop_on_sigterm():
            reached = run_live(stack, live, duration)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    typer.echo(f"stopped at {reached:.1f} s simulated")


def _rover_demo(out: Path, seed: int, course: Path | None) -> None:
    from navstack.interfaces.rover import run_rover_demo

    try:
        with stop_on_sigterm():
            report = run_rover_demo(out, seed, course, link="udp")
    except NavstackError as exc:
        raise fail(str(exc)) from None
    link = report.get("link", {})
    lat = link.get("command_latency", {})
    typer.echo(f"vehicle link (udp, {link.get('vehicle', '?')}): "
               f"{link.get('commands_sent', 0)} commands, added command latency p95 "
               f"{lat.get('p95_ms', float('nan')):.3f} ms, link losses "
               f"{link.get('link_losses', '?')}")
    passed = sum(leg["passed"] for leg in report["legs"])
    typer.echo(f"{'SUCCESS' if report['success'] else 'FAILURE'}: {passed}/"
               f"{len(report['legs'])} legs, {report['collisions']} collisions, "
               f"{report['sim_time_s']:.0f} s simulated in {report['wall_time_s']:.0f} s; "
               f"report in {out}")
    if not report["success"]:
        raise typer.Exit(1)
