"""``navstack teleop --keyboard|--joystick``: drive the simulated robot by hand.

The commands go through the stack's twist_mux (keyboard input priority 90, joystick 100,
over navigation's 10) and its e-stop lock, as on the rover (docs/command_path.md).
"""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail
from navstack.interfaces.cli.options import (
    MAX_LIVE_SECONDS,
    duration_option,
    rate_option,
    seed_option,
)


@app.command()
def teleop(
    keyboard: Annotated[bool, typer.Option("--keyboard", help="Drive with the keys of this "
                                           "terminal (teleop_twist_keyboard's).")] = False,
    joystick: Annotated[bool, typer.Option("--joystick", help="Drive with a game pad "
                                           "(teleop_twist_joy; hold button 0).")] = False,
    device: Annotated[str | None, typer.Option(
        help="Joystick device (Linux joystick API, e.g. /dev/input/js0); default: the "
             "pygame backend if installed, else /dev/input/js0.")] = None,
    world: Annotated[str, typer.Option(help="World name or path.")] = "office",
    robot: Annotated[str, typer.Option(help="Robot profile.")] = "diff_drive",
    seed: Annotated[int, seed_option("Random seed.")] = 1,
    rate: Annotated[float, rate_option("Real-time factor (simulated seconds per wall "
                                       "second).")] = 1.0,
    duration: Annotated[float | None, duration_option(
        "Stop after this many simulated seconds (default: until Ctrl-C).",
        high=MAX_LIVE_SECONDS)] = None,
) -> None:
    """Drive the simulated robot with the keyboard or a joystick through the twist_mux."""
    from navstack.drivers.joystick import open_joystick
    from navstack.interfaces.stack import NavStack
    from navstack.interfaces.teleop_live import KEY_HELP, TeleopSession

    if keyboard == joystick:
        raise fail("choose one input: --keyboard or --joystick")
    if device is not None and not joystick:
        raise fail("--device is a joystick option; add --joystick")
    try:
        session = TeleopSession(NavStack(world, robot, seed=seed), rate, status=sys.stdout)
        if keyboard:
            if not sys.stdin.isatty():
                raise fail("--keyboard reads keys from a terminal; run it in one")
            typer.echo(KEY_HELP)
            summary = session.keyboard(sys.stdin.fileno(), duration)
        else:
            reader = open_joystick(device)
            typer.echo(f"joystick {reader.name}: hold button 0 and move the left stick; "
                       "button 7 toggles teleop/auto, button 1 latches the e-stop; Ctrl-C "
                       "quits")
            try:
                summary = session.joystick(reader, duration)
            finally:
                reader.close()
    except NavstackError as exc:
        raise fail(str(exc)) from None
    x, y, yaw = summary.final_pose
    typer.echo(f"{summary.sim_time_s:.1f} s simulated, {summary.distance_m:.2f} m driven, "
               f"final pose ({x:.2f}, {y:.2f}, {yaw:+.2f}), collisions {summary.collisions}")
