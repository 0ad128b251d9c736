"""``navstack mission NAME``: run a mission (exploration, coverage search, map by poses,
or a user's mission file) in the simulator and write its report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail


def _targets(values: list[str] | None) -> tuple[tuple[float, float], ...]:
    out = []
    for text in values or []:
        try:
            x, y = (float(v) for v in text.split(","))
        except ValueError:
            raise fail(f"--target '{text}' must be two numbers 'x,y' (e.g. 3.2,1.5)") from None
        out.append((x, y))
    return tuple(out)


@app.command()
def mission(
    name: Annotated[str, typer.Argument(help="explore, coverage, map-poses, or a mission "
                                        "file (path/to/mission.py, see docs/missions.md).")],
    world: Annotated[str | None, typer.Option(help="World name or path (default: the "
                                              "mission's: arena, or office for "
                                              "map-poses).")] = None,
    robot: Annotated[str, typer.Option(help="Robot profile.")] = "turtlebot3_waffle_pi",
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same run).")] = 1,
    out: Annotated[Path, typer.Option(help="Folder for report.json, report.md and the "
                                      "figures.")] = Path("runs/mission"),
    strategy: Annotated[str | None, typer.Option(
        help="explore: explore_lite or information_gain (default) or nearest.")] = None,
    poses: Annotated[Path | None, typer.Option(
        help="map-poses: waypoints YAML with an 'order' (default: the packaged office "
             "poses).")] = None,
    target: Annotated[list[str] | None, typer.Option(
        "--target", help="coverage: stop early once the camera sees this x,y (repeat for "
                         "several).")] = None,
    localization: Annotated[str | None, typer.Option(
        help="Override the mission's localization: slam, amcl or perfect.")] = None,
    max_duration: Annotated[float | None, typer.Option(
        help="Fail the mission after this many simulated seconds.")] = None,
    nav2_params: Annotated[Path | None, typer.Option(
        "--nav2-params", help="Nav2 parameter file (default: the robot's own, e.g. "
                              "config/turtlebot3_waffle_pi_nav2_params.yaml).")] = None,
    record: Annotated[bool, typer.Option(
        "--record", help="Also record a rosbag2 (MCAP) in OUT/bag, with /mission/state and "
                         "the frontier markers.")] = False,
    web: Annotated[bool, typer.Option("--web", help="Serve the web dashboard while the "
                                      "mission runs (paced at --rate).")] = False,
    port: Annotated[int, typer.Option(help="Dashboard port.")] = 8080,
    host: Annotated[str, typer.Option(help="Dashboard address.")] = "127.0.0.1",
    token: Annotated[str | None, typer.Option(help="Dashboard command token.")] = None,
    foxglove: Annotated[bool, typer.Option("--foxglove", help="Serve Foxglove live on "
                                           "127.0.0.1 while the mission runs.")] = False,
    foxglove_port: Annotated[int, typer.Option(help="Foxglove WebSocket port.")] = 8765,
    rate: Annotated[float, typer.Option(help="Real-time factor with --web/--foxglove.")] = 1.0,
) -> None:
    """Run a mission in the simulator: report.json, report.md, trajectory.png."""
    from navstack.interfaces.live_cli import LiveOptions, attach_to_demo
    from navstack.interfaces.mission_catalog import MissionOptions
    from navstack.interfaces.mission_run import run_mission

    if strategy is not None and strategy not in ("explore_lite", "information_gain",
                                                 "nearest"):
        raise fail(f"--strategy '{strategy}': choose explore_lite, information_gain or "
                   "nearest")
    if localization is not None and localization not in ("slam", "amcl", "perfect"):
        raise fail(f"--localization '{localization}': choose slam, amcl or perfect")
    if max_duration is not None and not max_duration > 0:
        raise fail(f"--max-duration must be positive, got {max_duration}")
    options = MissionOptions(strategy=strategy, poses=poses,
                             localization=localization,  # type: ignore[arg-type]
                             max_duration=max_duration, targets=_targets(target),
                             nav2_params=nav2_params)
    live = LiveOptions(web=web, host=host, port=port, token=token, foxglove=foxglove,
                       foxglove_port=foxglove_port, real_time_factor=rate)
    try:
        report = run_mission(name, out, world, robot, seed, record, options,
                             attach=attach_to_demo(live) if live.enabled else None)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    if "bag" in report:
        typer.echo(f"recorded {report['bag']['messages']} messages to {report['bag']['path']}")
    verdict = "SUCCESS" if report["success"] else "FAILURE"
    parts = [f"{report['status']}" + (f" ({report['reason']})" if report["reason"] else ""),
             f"{report['duration_s']:.0f} s", f"{report['path_length_m']:.1f} m driven",
             f"{report['collisions']} collisions",
             f"home {report['home_distance_m']:.2f} m"]
    if "observed_fraction" in report and "completeness" not in report:
        parts.append(f"observed {100 * report['observed_fraction']:.1f} % "
                     f"(90 % at {report['time_to_90_s']:.0f} s)")
    map_poses = report.get("map_poses")
    visits = map_poses.get("poses", []) if isinstance(map_poses, dict) else []
    if visits:
        reached = sum(v["status"] == "REACHED" for v in visits)
        parts.append(f"poses reached {reached}/{len(visits)}")
    if "cells_total" in report:
        parts.append(f"cells visited {report['cells_visited']}/{report['cells_total']}")
    if "completeness" in report:
        parts.append(f"completeness {100 * report['completeness']:.1f} %")
    if "reload" in report:
        rl = report["reload"]
        parts.append(f"reload: map_server {'ok' if rl.get('map_server_ok') else 'FAILED'}, "
                     f"SLAM localization {'ok' if rl.get('slam_localization_ok') else 'FAILED'}")
    typer.echo(f"{verdict}: " + ", ".join(parts) + f"; report in {out}")
    if not report["success"]:
        raise typer.Exit(code=1)
