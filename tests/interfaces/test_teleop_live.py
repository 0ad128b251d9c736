"""``navstack teleop``: keys from a pseudo-terminal and js_event records from a pipe drive
the simulated robot through the twist_mux (the real stack, paced fast)."""

from __future__ import annotations

import io
import os
import pty
import termios
import tty

import pytest
from typer.testing import CliRunner

from navstack.app import app
from navstack.drivers.joystick import JS_EVENT, JS_EVENT_AXIS, JS_EVENT_BUTTON, LinuxJoystick
from navstack.interfaces.stack import NavStack
from navstack.interfaces.teleop_live import TeleopSession


def test_keyboard_drives_forward_through_the_mux_then_stops() -> None:
    # the key is in the terminal before the loop starts: the outcome does not depend on
    # how fast this machine steps the simulation
    master, slave = pty.openpty()
    try:
        stack = NavStack("office", seed=0)  # spawn (1.0, 7.5) facing +x down the corridor
        session = TeleopSession(stack, real_time_factor=10.0, status=io.StringIO())
        tty.setcbreak(slave, termios.TCSANOW)  # as the session sets it: keys one by one
        os.write(master, b"i")
        summary = session.keyboard(slave, duration=3.0)
    finally:
        os.close(master)
        os.close(slave)
    x, y, _ = summary.final_pose
    # one 'i' = 0.5 m/s forward, resent at 10 Hz until key_timeout (0.6 s) without
    # another key, then one zero: 8 commands, ~0.3 m with the acceleration limits
    assert summary.commands == 8
    assert 0.2 < x - 1.0 < 0.4 and abs(y - 7.5) < 0.02
    assert summary.mux_winners.get("keyboard", 0) > 0
    assert stack.sim.sim.state.vx == pytest.approx(0.0, abs=0.01)
    assert summary.collisions == 0


def test_joystick_pipe_drives_and_the_estop_button_stops() -> None:
    r, w = os.pipe()
    pad = LinuxJoystick("pipe", fd=r)
    stack = NavStack("office", seed=0)
    session = TeleopSession(stack, real_time_factor=10.0, status=io.StringIO())
    ev = JS_EVENT.pack
    # hold enable (button 0) and push the left stick forward (axis 1, raw negative) ...
    os.write(w, ev(0, 0, JS_EVENT_BUTTON, 0) + ev(0, 1, JS_EVENT_BUTTON, 0)
             + ev(0, 1, JS_EVENT_BUTTON, 0) + ev(0, 1, JS_EVENT_BUTTON, 0)
             + ev(0, -32767, JS_EVENT_AXIS, 1))
    try:
        session.joystick(pad, duration=2.0)
        moving = stack.sim.sim.pose.x - 1.0
        assert moving > 0.3  # teleop_twist_joy: 0.5 m/s x full stick
        assert stack.twist_mux.mux.winner(stack.now) == "joystick"
        # ... then the e-stop button (1): the twist_mux lock holds the base at zero
        os.write(w, ev(0, 1, JS_EVENT_BUTTON, 1))
        summary = session.joystick(pad, duration=2.0)
        assert session.node is not None and session.node.estop.holder == "joystick"
        assert stack.twist_mux.locked
        assert stack.sim.sim.state.vx == pytest.approx(0.0, abs=1e-6)
        assert summary.joy_messages >= 1
    finally:
        pad.close()
        os.close(w)


runner = CliRunner()


@pytest.mark.parametrize(("args", "message"), [
    ([], "error: choose one input: --keyboard or --joystick"),
    (["--keyboard", "--joystick"], "error: choose one input: --keyboard or --joystick"),
    (["--keyboard", "--device", "/dev/input/js0"],
     "error: --device is a joystick option; add --joystick"),
    (["--keyboard"], "error: --keyboard reads keys from a terminal; run it in one"),
    (["--joystick", "--device", "/dev/input/js7"],
     "error: cannot open joystick /dev/input/js7: No such file or directory (plug the pad "
     "in or pass --device)"),
])
def test_cli_errors_are_one_line(args: list[str], message: str) -> None:
    res = runner.invoke(app, ["teleop", *args])
    assert res.exit_code == 2
    assert res.output.strip().splitlines()[-1] == message
