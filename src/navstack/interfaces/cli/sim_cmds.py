"""``navstack worlds``, ``robots`` and ``sim``: the simulator on its own."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, parse_cmd, write_json
from navstack.interfaces.cli.options import check_out_file, duration_option, seed_option


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
    duration: Annotated[float, duration_option("Simulated seconds to run.")] = 10.0,
    cmd: Annotated[str, typer.Option(
        help="Constant command 'vx,wz' [m/s, rad/s], within the robot's velocity "
             "limits.")] = "0.3,0.0",
    seed: Annotated[int, seed_option()] = 0,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the report here.")] = None,
) -> None:
    """Drive a robot open-loop in a simulated world and report pose, collisions and speed."""
    from navstack.sim.open_loop import run_open_loop
    from navstack.sim.robot import load_robot

    vx, wz = parse_cmd(cmd)
    if json_out is not None:
        check_out_file(json_out, "--json")
    try:
        limits = load_robot(robot).kinematics
        low = limits.min_vel_x if limits.min_vel_x is not None else -limits.max_vel_x
        if not low <= vx <= limits.max_vel_x or abs(wz) > limits.max_vel_theta:
            raise fail(f"--cmd '{cmd}' is outside the limits of robot '{robot}': vx in "
                       f"[{low:g}, {limits.max_vel_x:g}] m/s, wz in "
                       f"[{-limits.max_vel_theta:g}, {limits.max_vel_theta:g}] rad/s")
        report = run_open_loop(world, robot, duration, vx, wz, seed)
    except NavstackError as exc:
        raise fail(str(exc)) from None
    p = report["final_pose"]
    typer.echo(f"world {world}, robot {robot}, {duration:.1f} s simulated in "
               f"{report['wall_time_s']:.3f} s (real-time factor {report['real_time_factor']:.0f})")
    typer.echo(f"final pose x={p['x']:.3f} y={p['y']:.3f} yaw={p['yaw']:.3f}; "
               f"collisions {report['collisions']}; scans {report['scans']}; "
               f"odometry {report['odom_msgs']}")
    write_json(json_out, report)
