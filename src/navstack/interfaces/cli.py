"""The ``navstack`` command line (typer).

Every subcommand has ``--help``.  Errors that a user can fix (bad config, unknown world,
missing map file) print one line ``error: ...`` and exit with code 2 — never a traceback.
Heavy modules are imported inside the commands so ``navstack --help`` stays instant.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from navstack.core.errors import NavstackError

app = typer.Typer(help="navstack: autonomous navigation for mobile robots, with a built-in "
                  "simulator.", no_args_is_help=True, add_completion=False,
                  pretty_exceptions_enable=False)


def _fail(message: str) -> typer.Exit:
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(code=2)


def _write_json(path: Path | None, payload: dict[str, object]) -> None:
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(payload, indent=2, default=float) + "\n")


def _slam_overrides(params: Path | None) -> dict[str, Any] | None:
    """The ``slam_toolbox: ros__parameters:`` section of a parameter file, if given."""
    if params is None:
        return None
    from navstack.runtime.config import load_yaml, ros_parameters

    return dict(ros_parameters(load_yaml(params), "slam_toolbox", file=str(params),
                               required=True))


def _parse_cmd(text: str) -> tuple[float, float]:
    try:
        parts = [float(v) for v in text.split(",")]
    except ValueError:
        raise _fail(f"--cmd '{text}' must be two numbers 'vx,wz' (e.g. 0.3,0.2)") from None
    if len(parts) != 2:
        raise _fail(f"--cmd '{text}' must be two numbers 'vx,wz' (e.g. 0.3,0.2)")
    return parts[0], parts[1]


@app.command()
def worlds() -> None:
    """List the built-in worlds."""
    from navstack.sim.worlds import list_worlds, load_world

    for name in list_worlds():
        w = load_world(name)
        x0, y0, x1, y1 = w.bounds
        typer.echo(f"{name:12s} {x1 - x0:6.1f} x {y1 - y0:5.1f} m  "
                   f"waypoints: {', '.join(w.waypoints) or '-'}")


@app.command()
def robots() -> None:
    """List the built-in robot profiles."""
    from navstack.sim.robot import list_robots, load_robot

    for name in list_robots():
        r = load_robot(name)
        typer.echo(f"{name:12s} {r.kinematics.type:11s} max_vel_x {r.kinematics.max_vel_x:.2f} m/s")


@app.command()
def sim(
    world: Annotated[str, typer.Option(
        help="Built-in world name or a world/map YAML path.")] = "office",
    robot: Annotated[str, typer.Option(
        help="Built-in robot profile or a robot YAML path.")] = "diff_drive",
    duration: Annotated[float, typer.Option(help="Simulated seconds to run.")] = 10.0,
    cmd: Annotated[str, typer.Option(help="Constant command 'vx,wz' [m/s, rad/s].")] = "0.3,0.0",
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same run).")] = 0,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the report here.")] = None,
) -> None:
    """Drive a robot open-loop in a simulated world and report pose, collisions and speed."""
    from navstack.sim.open_loop import run_open_loop

    vx, wz = _parse_cmd(cmd)
    try:
        report = run_open_loop(world, robot, duration, vx, wz, seed)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
    p = report["final_pose"]
    typer.echo(f"world {world}, robot {robot}, {duration:.1f} s simulated in "
               f"{report['wall_time_s']:.3f} s (real-time factor {report['real_time_factor']:.0f})")
    typer.echo(f"final pose x={p['x']:.3f} y={p['y']:.3f} yaw={p['yaw']:.3f}; "
               f"collisions {report['collisions']}; scans {report['scans']}; "
               f"odometry {report['odom_msgs']}")
    _write_json(json_out, report)


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="Folder for report.json, report.md and "
                                      "trajectory.png.")] = Path("runs/demo"),
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same run).")] = 1,
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
    web: Annotated[bool, typer.Option("--web", help="Serve the web dashboard while the "
                                      "mission runs (paced at --rate).")] = False,
    port: Annotated[int, typer.Option(help="Dashboard port.")] = 8080,
    host: Annotated[str, typer.Option(help="Dashboard address (0.0.0.0 for a phone on "
                                      "the same network).")] = "127.0.0.1",
    token: Annotated[str | None, typer.Option(help="Dashboard command token (default: "
                                              "generated and printed).")] = None,
    foxglove: Annotated[bool, typer.Option("--foxglove", help="Serve Foxglove live on "
                                           "127.0.0.1 while the mission runs.")] = False,
    foxglove_port: Annotated[int, typer.Option(help="Foxglove WebSocket port.")] = 8765,
    rate: Annotated[float, typer.Option(help="Real-time factor with --web/--foxglove "
                                        "(simulated seconds per wall second).")] = 1.0,
) -> None:
    """Flagship mission: visit named waypoints in order in the simulator, write a report."""
    from navstack.interfaces.demo import run_demo
    from navstack.interfaces.live_cli import LiveOptions, attach_to_demo

    live = LiveOptions(web=web, host=host, port=port, token=token, foxglove=foxglove,
                       foxglove_port=foxglove_port, real_time_factor=rate)
    try:
        report = run_demo(out, seed, world, robot, waypoints, record=record,
                          attach=attach_to_demo(live) if live.enabled else None)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
    if "bag" in report:
        typer.echo(f"recorded {report['bag']['messages']} messages to {report['bag']['path']}")
    verdict = "SUCCESS" if report["success"] else "FAILURE"
    typer.echo(f"{verdict}: {sum(g['status'] == 'SUCCEEDED' for g in report['goals'])}/"
               f"{len(report['goals'])} goals, {report['collisions']} collisions, min clearance "
               f"{report['min_clearance_m']:.2f} m, {report['sim_time_s']:.0f} s simulated in "
               f"{report['wall_time_s']:.0f} s; report in {out}")
    if not report["success"]:
        raise typer.Exit(code=1)


@app.command()
def run(
    world: Annotated[str, typer.Option(help="World name or path.")] = "office",
    robot: Annotated[str, typer.Option(help="Robot profile.")] = "diff_drive",
    seed: Annotated[int, typer.Option(help="Random seed.")] = 1,
    stack_file: Annotated[Path | None, typer.Option(
        "--stack", help="Stack YAML (robot, world, navigation parameters) instead of "
                        "--world/--robot.")] = None,
    amcl: Annotated[bool, typer.Option("--amcl", help="Localize with AMCL.")] = False,
    slam: Annotated[bool, typer.Option("--slam", help="Map with SLAM while "
                                       "navigating.")] = False,
    web: Annotated[bool, typer.Option("--web", help="Serve the web dashboard.")] = False,
    port: Annotated[int, typer.Option(help="Dashboard port.")] = 8080,
    host: Annotated[str, typer.Option(help="Dashboard address (0.0.0.0 for a phone on "
                                      "the same network).")] = "127.0.0.1",
    token: Annotated[str | None, typer.Option(help="Dashboard command token (default: "
                                              "generated and printed).")] = None,
    foxglove: Annotated[bool, typer.Option("--foxglove", help="Serve Foxglove live on "
                                           "127.0.0.1.")] = False,
    foxglove_port: Annotated[int, typer.Option(help="Foxglove WebSocket port.")] = 8765,
    rate: Annotated[float, typer.Option(help="Real-time factor (simulated seconds per "
                                        "wall second).")] = 1.0,
    duration: Annotated[float | None, typer.Option(help="Stop after this many simulated "
                                                   "seconds (default: until Ctrl-C).")] = None,
) -> None:
    """Run the stack live in the simulator and watch or command it (--web, --foxglove)."""
    from navstack.interfaces.live_cli import LiveOptions, run_live
    from navstack.interfaces.stack import NavStack

    live = LiveOptions(web=web, host=host, port=port, token=token, foxglove=foxglove,
                       foxglove_port=foxglove_port, real_time_factor=rate)
    if not live.enabled:
        raise _fail("nothing to watch: add --web and/or --foxglove")
    try:
        stack = (NavStack.from_stack_file(stack_file) if stack_file is not None
                 else NavStack(world, robot, seed=seed, amcl=amcl, slam=slam))
        reached = run_live(stack, live, duration)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
    typer.echo(f"stopped at {reached:.1f} s simulated")


@app.command()
def slam(
    carmen: Annotated[Path, typer.Option(help="CARMEN log (plain text or .gz).")],
    out: Annotated[Path, typer.Option(help="Folder for map.yaml/.pgm/.png, trajectory.csv, "
                                      "map.posegraph, graph.g2o and summary.json.")],
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the summary here.")]
    = None,
    params: Annotated[Path | None, typer.Option(
        help="slam_toolbox parameter YAML (slam_toolbox: ros__parameters: ...), applied "
             "over the log profile.")] = None,
    max_scans: Annotated[int | None, typer.Option(min=1, help="Stop after N scans.")] = None,
) -> None:
    """Offline SLAM on a CARMEN log: map, trajectory, pose graph and its error (RPE)."""
    from navstack.mapping.offline import run_carmen, summary, write_outputs

    try:
        overrides = _slam_overrides(params)
        result = run_carmen(carmen, overrides, max_scans=max_scans,
                            params_file=str(params) if params is not None else "")
        files = write_outputs(result, out)
    except (NavstackError, OSError) as exc:
        raise _fail(str(exc)) from None
    report = summary(result, files)
    skipped = report["skipped_lines"]
    if skipped["count"]:
        shown = "; ".join(f"line {s['line']}: {s['reason']}" for s in skipped["first"])
        more = ", ..." if skipped["count"] > len(skipped["first"]) else ""
        typer.echo(f"warning: {skipped['count']} log line(s) skipped ({shown}{more})", err=True)
    stats = result.mapper.stats
    typer.echo(f"{result.scans} scans processed ({len(result.mapper.nodes)} nodes), "
               f"{stats.loop_closures} loop closures, {stats.match_failures} match failures")
    if result.rpe is not None:
        r = result.rpe
        line = (f"RPE over {r.pairs} consecutive pairs vs the corrected poses: trans "
                f"{r.trans_mean_m:.4f} ± {r.trans_std_m:.4f} m, rot {r.rot_mean_deg:.3f} ± "
                f"{r.rot_std_deg:.3f} deg")
        if result.odometry_rpe is not None:
            o = result.odometry_rpe
            line += f" (odometry alone: {o.trans_mean_m:.4f} m, {o.rot_mean_deg:.3f} deg)"
        typer.echo(line)
    else:
        typer.echo("RPE: not scored (the log has no corrected reference poses)")
    speed = (f"speedup {result.speedup:.0f}x over the log's {result.log_duration_s:.0f} s"
             if result.speedup is not None and result.log_duration_s is not None
             else "speedup unknown (log timestamps too coarse)")
    typer.echo(f"{result.ms_per_scan:.1f} ms/scan (median), {result.wall_s:.2f} s wall, {speed}")
    typer.echo(f"wrote {', '.join(Path(p).name for p in files.values())} to {out}")
    _write_json(json_out, report)


@app.command()
def bench(
    suite: Annotated[str, typer.Argument(help="Suite name (see `navstack bench list`).")],
    quick: Annotated[bool, typer.Option("--quick", help="Smaller, faster run (CI).")] = False,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results here.")] = None,
    data_dir: Annotated[Path | None, typer.Option(help="Shared data folder.")] = None,
    controller: Annotated[str | None, typer.Option(
        "--controller", help="FollowPath controller of the navigation suite: dwb "
                             "(default), mppi or rpp.")] = None,
) -> None:
    """Run a benchmark suite; prints a table of metrics and writes JSON."""
    from navstack.benchmarks.runner import available_suites, run_suite

    if suite == "list":
        for name in available_suites():
            typer.echo(name)
        return
    try:
        options = {"controller": controller} if controller is not None else {}
        result = run_suite(suite, quick, data_dir, options)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
    from rich.console import Console
    from rich.table import Table

    label = f" --controller {controller}" if controller is not None else ""
    table = Table(title=f"navstack bench {suite}{label}{' (quick)' if quick else ''}")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, value in result.metrics.items():
        table.add_row(key, f"{value:.4g}" if isinstance(value, float) else str(value))
    Console().print(table)
    if result.show_cases and result.cases:
        rows = Table(title=f"{suite}: runs")
        columns = list(result.cases[0])
        for column in columns:
            rows.add_column(column, justify="left" if column == "parameter" else "right")
        for case in result.cases:
            rows.add_row(*(f"{case.get(c, '')}" for c in columns))
        Console(width=200).print(rows)
    for note in result.notes:
        typer.echo(f"note: {note}")
    _write_json(json_out, result.to_json())


@app.command()
def replay(
    bag: Annotated[Path, typer.Argument(help="rosbag2 folder, .mcap/.db3 file or ROS 1 .bag.")],
    rate: Annotated[float, typer.Option(
        min=0.0, help="Playback speed as a multiple of real time (0: as fast as "
                      "possible).")] = 1.0,
    loop: Annotated[bool, typer.Option("--loop", help="Start again after the last message "
                                       "(end with --duration or Ctrl-C).")] = False,
    topic: Annotated[list[str] | None, typer.Option(
        help="Play only this topic (repeatable; default: every convertible topic).")] = None,
    echo: Annotated[list[str] | None, typer.Option(
        help="Print each message of this topic, one line each (repeatable).")] = None,
    duration: Annotated[float | None, typer.Option(
        min=0.0, help="Stop after this many seconds of bag time.")] = None,
) -> None:
    """Play a bag onto a bus in timestamp order and print what was played per topic."""
    from navstack.interfaces.bag_cli import replay as play

    try:
        counts, loops = play(bag, rate or None, loop, topic, echo or (), duration, typer.echo)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
    typer.echo(f"played {sum(counts.values())} messages ({loops} complete pass"
               f"{'es' if loops != 1 else ''}):")
    for name, n in sorted(counts.items()):
        typer.echo(f"  {name:40s} {n:8d}")


bag_app = typer.Typer(help="Inspect, import and map ROS bags (ROS 1 .bag, rosbag2 MCAP or "
                      "sqlite3).", no_args_is_help=True)
app.add_typer(bag_app, name="bag")


@bag_app.command("info")
def bag_info(bag: Annotated[Path, typer.Argument(help="The bag.")]) -> None:
    """Topics, types, message counts and time span of a bag."""
    from navstack.interfaces.bag_cli import info_lines

    try:
        lines = info_lines(bag)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
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

    try:
        result = import_bag(bag, out, topic, replace=force)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
    s = result.summary
    typer.echo(f"imported {s.messages} messages on {len(s.counts)} topics from "
               f"{'ROS 1' if result.ros1 else 'ROS 2'} bag {bag} into {out}")
    for name, n in sorted(s.counts.items()):
        typer.echo(f"  {name:40s} {n:8d}")
    for name, why in sorted(s.skipped.items()):
        typer.echo(f"warning: skipped {name}: {why}", err=True)


@bag_app.command("slam")
def bag_slam(
    bag: Annotated[Path, typer.Argument(help="Bag with /scan, /odom and /tf_static.")],
    out: Annotated[Path, typer.Option(help="Folder for map.yaml/.pgm/.png, trajectory.csv, "
                                      "map.posegraph, graph.g2o and summary.json.")],
    params: Annotated[Path | None, typer.Option(
        help="slam_toolbox parameter YAML (slam_toolbox: ros__parameters: ...).")] = None,
    max_scans: Annotated[int | None, typer.Option(min=1, help="Stop after N scans.")] = None,
) -> None:
    """Offline SLAM on a recorded bag's scans and odometry (scored if it has ground truth)."""
    from navstack.interfaces.bag_slam import run_bag, write_bag_outputs

    try:
        overrides = _slam_overrides(params)
        result = run_bag(bag, overrides, max_scans=max_scans,
                         params_file=str(params) if params is not None else "")
        files = write_bag_outputs(result, out)
    except (NavstackError, OSError) as exc:
        raise _fail(str(exc)) from None
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
    braking_decel: Annotated[float, typer.Option(
        min=0.0, help="Braking deceleration a [m/s^2] of the safe-speed bound.")] = 2.5,
    latency: Annotated[float | None, typer.Option(
        min=0.0, help="End-to-end latency L [s] (default: measured, scan -> cmd_vel).")]
    = None,
    robot_radius: Annotated[float, typer.Option(
        min=0.0, help="Subtracted from clearances and free distances [m].")] = 0.0,
) -> None:
    """Report a recorded run: path length, speeds, curvature, goals, safe-speed bound."""
    from navstack.interfaces.report import ReportParams, write_report

    try:
        params = ReportParams.from_mapping({"braking_decel": braking_decel, "latency": latency,
                                            "robot_radius": robot_radius})
        rep = write_report(bag, out, params)
    except NavstackError as exc:
        raise _fail(str(exc)) from None
    traj = rep["trajectory"]
    if traj is not None:
        typer.echo(f"path length {traj['path_length_m']:.3f} m from {traj['topic']} over "
                   f"{rep['duration_s']:.1f} s")
    for g in rep["goals"]:
        typer.echo(f"goal {g['index']}: {g['status']} in {g['time_s']} s, "
                   f"{g['path_length_m']} m, closest {g['min_goal_dist_m']} m")
    s = rep["safety"]
    typer.echo(f"safe speed bound {s['v_max_p5_m_s']} m/s (a={s['braking_decel_m_s2']} m/s^2, "
               f"L={s['latency_s']} s, d_free p5={s['d_free_p5_m']} m); report in {out}")


@app.command()
def version() -> None:
    """Print the navstack version."""
    from navstack import __version__

    typer.echo(__version__)


def _one_line(exc: Exception) -> str:
    return "; ".join(line for line in str(exc).splitlines() if line)


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
        raise _fail(_one_line(exc)) from None
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
                raise _fail("--bag diagnoses a recording; do not combine it with --world, "
                            "--robot, --fault or --record")
            report = diagnose_bag(bag)
        else:
            session = HealthSession(build_stack(None, world or "office", robot or "diff_drive",
                                                seed), fault=fault or "healthy", record=record)
            session.run(seconds)
            report = session.diagnose()
            session.close()
    except NavstackError as exc:
        raise _fail(_one_line(exc)) from None
    for line in report.lines():
        typer.echo(line)
    if not report.healthy:
        raise typer.Exit(code=1)


def main() -> None:
    """Console entry point."""
    try:
        app()
    except NavstackError as exc:  # last line of defence: one line, no traceback
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)


if __name__ == "__main__":
    main()
