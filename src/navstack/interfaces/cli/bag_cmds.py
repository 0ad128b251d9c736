"""``navstack replay``, ``bag info|import|slam`` and ``report``: recorded runs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import (
    app,
    command_group,
    fail,
    slam_overrides,
    stop_on_sigterm,
)
from navstack.interfaces.cli.options import (
    MAX_LIVE_SECONDS,
    MAX_RATE,
    check_out_dir,
    duration_option,
    number_option,
)


@app.command()
def replay(
    bag: Annotated[Path, typer.Argument(help="rosbag2 folder, .mcap/.db3 file or ROS 1 .bag.")],
    rate: Annotated[float, number_option(
        "--rate", help="Playback speed as a multiple of real time (0: as fast as "
                       "possible).", low=0.0, high=MAX_RATE)] = 1.0,
    loop: Annotated[bool, typer.Option("--loop", help="Start again after the last message "
                                       "(end with --duration or Ctrl-C).")] = False,
    topic: Annotated[list[str] | None, typer.Option(
        help="Play only this topic (repeatable; default: every convertible topic).")] = None,
    echo: Annotated[list[str] | None, typer.Option(
        help="Print each message of this topic, one line each (repeatable).")] = None,
    duration: Annotated[float | None, duration_option(
        "Stop after this many seconds of bag time.", high=MAX_LIVE_SECONDS)] = None,
) -> None:
    """Play a bag onto a bus in timestamp order and print what was played per topic.

    Ends at the end of the bag, after --duration, or on Ctrl-C / SIGTERM (with --loop
    only the last two end it)."""
    from navstack.interfaces.bag_cli import replay as play

    try:
        with stop_on_sigterm():
            counts, loops = play(bag, rate or None, loop, topic, echo or (), duration,
                                 typer.echo)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    typer.echo(f"played {sum(counts.values())} messages ({loops} complete pass"
               f"{'es' if loops != 1 else ''}):")
    for name, n in sorted(counts.items()):
        typer.echo(f"  {name:40s} {n:8d}")


bag_app = command_group("Inspect, import and map ROS bags (ROS 1 .bag, rosbag2 MCAP or "
                        "sqlite3).")
app.add_typer(bag_app, name="bag")


@bag_app.command("info")
def bag_info(bag: Annotated[Path, typer.Argument(help="The bag.")]) -> None:
    """Topics, types, message counts and time span of a bag."""
    from navstack.interfaces.bag_cli import info_lines

    try:
        lines = info_lines(bag)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    for line in lines:
        typer.echo(line)


@bag_app.command("import")
def bag_import(
    bag: Annotated[Path, typer.Argument(help="ROS 1 .bag, rosbag2 folder or .mcap/.db3.")],
    out: Annotated[Path, typer.Option(help="Output rosbag2 folder (MCAP).")],
    topic: Annotated[list[str] | None, typer.Option(
        help="Import only this topic (repeatable; default: every convertible topic).")] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace OUT if it is a bag.")] = False,
) -> None:
    """Convert a ROS 1 / ROS 2 bag into a navstack rosbag2 (MCAP, ROS 2 Humble types)."""
    from navstack.runtime.recording import import_bag

    check_out_dir(out.parent, "--out")
    try:
        result = import_bag(bag, out, topic, replace=force)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    s = result.summary
    typer.echo(f"imported {s.messages} messages on {len(s.counts)} topics from "
               f"{'ROS 1' if result.ros1 else 'ROS 2'} bag {bag} into {out}")
    for name, n in sorted(s.counts.items()):
        typer.echo(f"  {name:40s} {n:8d}")
    for name, why in sorted(s.skipped.items()):
        typer.echo(f"warning: skipped {name}: {why}", err=True)


@bag_app.command("recover")
def bag_recover(
    bag: Annotated[Path, typer.Argument(help="A truncated .mcap file, or the rosbag2 folder "
                                        "holding it.")],
    out: Annotated[Path, typer.Option(help="Output rosbag2 folder (MCAP).")],
    force: Annotated[bool, typer.Option("--force", help="Replace OUT if it is a bag.")] = False,
) -> None:
    """Copy every complete message of a truncated MCAP recording into a new bag."""
    from navstack.runtime.recording.recover import recover_mcap

    check_out_dir(out.parent, "--out")
    try:
        rep = recover_mcap(bag, out, replace=force)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    state = "complete file" if rep.complete else f"cut off: {rep.stopped}"
    typer.echo(f"recovered {rep.messages} messages on {len(rep.counts)} topics from {bag} "
               f"({state}) into {out}")
    for name, n in sorted(rep.counts.items()):
        typer.echo(f"  {name:40s} {n:8d}")
    for name, why in sorted(rep.skipped.items()):
        typer.echo(f"warning: skipped {name}: {why}", err=True)


@bag_app.command("slam")
def bag_slam(
    bag: Annotated[Path, typer.Argument(help="Bag with /scan, /odom and /tf_static.")],
    out: Annotated[Path, typer.Option(help="Folder for map.yaml/.pgm/.png, trajectory.csv, "
                                      "map.posegraph, graph.g2o and summary.json.")],
    params: Annotated[Path | None, typer.Option(
        help="slam_toolbox parameter YAML (slam_toolbox: ros__parameters: ...).")] = None,
    max_scans: Annotated[int | None, number_option(
        "--max-scans", help="Stop after N scans.", low=1, high=10**9, integer=True)] = None,
) -> None:
    """Offline SLAM on a recorded bag's scans and odometry (scored if it has ground truth)."""
    from navstack.interfaces.bag_slam import run_bag, write_bag_outputs

    check_out_dir(out, "--out")
    try:
        overrides = slam_overrides(params)
        result = run_bag(bag, overrides, max_scans=max_scans,
                         params_file=str(params) if params is not None else "")
        files = write_bag_outputs(result, out)
    except (NavstackError, OSError) as exc:
        raise fail(str(exc)) from None
    stats = result.mapper.stats
    typer.echo(f"{result.scans} scans ({len(result.mapper.nodes)} nodes), "
               f"{stats.loop_closures} loop closures, {stats.match_failures} match failures")
    if result.rpe is not None:
        r = result.rpe
        typer.echo(f"RPE vs /ground_truth over {r.pairs} node pairs: trans "
                   f"{r.trans_mean_m:.4f} m, rot {r.rot_mean_deg:.3f} deg")
    typer.echo(f"wrote {', '.join(Path(p).name for p in files.values())} to {out}")


@app.command()
def report(
    bag: Annotated[Path, typer.Argument(help="The recorded bag (e.g. runs/demo/bag).")],
    out: Annotated[Path, typer.Option(help="Folder for report.md, report.json and plots.")],
    braking_decel: Annotated[float, number_option(
        "--braking-decel", help="Braking deceleration a [m/s^2] of the safe-speed bound.",
        low=0.0, high=100.0, low_open=True, unit="m/s^2")] = 2.5,
    latency: Annotated[float | None, number_option(
        "--latency", help="End-to-end latency L [s] (default: measured, scan -> cmd_vel).",
        low=0.0, high=60.0, unit="s")] = None,
    robot_radius: Annotated[float, number_option(
        "--robot-radius", help="Robot radius [m]: the footprint when the bag does not "
                               "record one; also subtracted from free distances.",
        low=0.0, high=100.0, unit="m")] = 0.0,
) -> None:
    """Report a recorded run: path length, speeds, curvature, goals, safe-speed bound."""
    from navstack.interfaces.report import ReportParams, write_report

    check_out_dir(out, "--out")
    try:
        params = ReportParams.from_mapping({"braking_decel": braking_decel, "latency": latency,
                                            "robot_radius": robot_radius})
        rep = write_report(bag, out, params)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    traj = rep["trajectory"]
    if traj is not None:
        typer.echo(f"path length {traj['path_length_m']:.3f} m from {traj['topic']} over "
                   f"{rep['duration_s']:.1f} s")
    if rep["min_clearance_m"] is not None:
        static, moving = rep["min_clearance_static_m"], rep["min_clearance_moving_m"]
        typer.echo("min clearance to static obstacles "
                   + (f"{static:.2f} m" if static is not None else "- (no /map)")
                   + ", to walkers "
                   + (f"{moving:.2f} m" if moving is not None else "- (none recorded)"))
    for g in rep["goals"]:
        typer.echo(f"goal {g['index']}: {g['status']} in {g['time_s']} s, "
                   f"{g['path_length_m']} m, closest {g['min_goal_dist_m']} m")
    s = rep["safety"]
    typer.echo(f"safe speed bound {s['v_max_p5_m_s']} m/s (a={s['braking_decel_m_s2']} m/s^2, "
               f"L={s['latency_s']} s, d_free p5={s['d_free_p5_m']} m); report in {out}")
