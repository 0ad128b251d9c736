"""Driving the simulated robot by hand: ``navstack teleop --keyboard|--joystick``.

A :class:`TeleopSession` steps a started :class:`~navstack.interfaces.stack.NavStack`
in the caller's thread, paced at ``real_time_factor`` x the wall clock, and between
steps reads the operator's input:

* **keyboard** -- keys from a terminal (cbreak mode, restored on exit) through
  :class:`~navstack.control.teleop_keyboard.KeyboardTeleop` to the twist_mux's
  ``keyboard`` input (``/key_vel``, priority 90: over navigation, under the joystick);
* **joystick** -- a :class:`~navstack.drivers.joystick.JoystickReader` publishing
  ``sensor_msgs/Joy`` on ``/joy`` for the rover's
  :class:`~navstack.nodes.teleop.TeleopNode` (teleop_twist_joy mapping to the mux's
  ``joystick`` input, the teleop/auto mode button, the e-stop button on the lock).

Everything goes through the command chain's mux, so the e-stop lock and its authority
rules hold for the hand controller too (docs/command_path.md).
"""

from __future__ import annotations

import os
import select
import sys
import termios
import time
import tty
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TextIO

from navstack.control.teleop_keyboard import KeyboardTeleop, KeyboardTeleopParams
from navstack.core.errors import ConfigError
from navstack.core.msgs import Header, Joy, Twist
from navstack.drivers.joystick import JoystickReader
from navstack.interfaces.stack import NavStack
from navstack.nodes.teleop import TeleopNode, TeleopNodeParams
from navstack.runtime.bus import QoS

__all__ = ["KEY_HELP", "TeleopSession", "TeleopSummary", "cbreak", "mux_input_topic"]

KEY_HELP = ("keys: u i o / j k l / m , .  move (k or space: stop); q/z speed +-10 %, "
            "w/x linear, e/c angular; Ctrl-C quits")
STEP = 0.05
"""[s] simulated time per step between input reads (the controller's period)."""


def mux_input_topic(stack: NavStack, name: str) -> str:
    """The topic of the twist_mux input called ``name``; a :class:`ConfigError` naming the
    inputs there are if it has none."""
    for entry in stack.description.twist_mux.topics:
        if entry.name == name:
            return entry.topic
    names = ", ".join(e.name for e in stack.description.twist_mux.topics)
    raise ConfigError(f"the twist_mux has no '{name}' input (it has {names})",
                      key_path="twist_mux.ros__parameters.topics",
                      suggestion=f"add a '{name}' input to drive the robot by hand")


@contextmanager
def cbreak(fd: int) -> Iterator[None]:
    """Keys arrive one by one without echo (a terminal only; Ctrl-C still interrupts)."""
    if not os.isatty(fd):
        yield
        return
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd, termios.TCSANOW)  # keep keys typed ahead (TCSAFLUSH drops them)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


@dataclass
class TeleopSummary:
    """What happened: commands published, the distance driven, the final pose."""

    sim_time_s: float = 0.0
    commands: int = 0
    joy_messages: int = 0
    distance_m: float = 0.0
    final_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    collisions: int = 0
    mux_winners: dict[str, int] = field(default_factory=dict)


class TeleopSession:
    """Steps ``stack`` in real time while an input source drives it."""

    def __init__(self, stack: NavStack, real_time_factor: float = 1.0,
                 status: TextIO | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not real_time_factor > 0.0:
            raise ValueError(f"real_time_factor must be > 0, got {real_time_factor}")
        self.stack = stack.start()
        self.rtf = real_time_factor
        self.status = status
        self.clock = clock
        self.summary = TeleopSummary()
        self._last_status = -1e300
        self.node: TeleopNode | None = None
        """The joystick node, once :meth:`joystick` ran."""
        self._last_joy: Joy | None = None
        self._joy_at = -1e300

    # --- input sources ---------------------------------------------------------------------
    def keyboard(self, fd: int, duration: float | None = None,
                 params: KeyboardTeleopParams | None = None) -> TeleopSummary:
        """Drive from the keys readable on ``fd`` (a terminal, or a pty in tests)."""
        k = self.stack.robot.kinematics
        base = params or KeyboardTeleopParams()
        teleop = KeyboardTeleop(base.updated(
            speed=min(base.speed, k.max_vel_x), turn=min(base.turn, k.max_vel_theta),
            speed_limit=min(base.speed_limit, k.max_vel_x),
            turn_limit=min(base.turn_limit, k.max_vel_theta)))
        pub = self.stack.runtime.bus.publisher(mux_input_topic(self.stack, "keyboard"), Twist,
                                               QoS(depth=1))

        def read(now: float, wait: float) -> None:
            ready, _, _ = select.select([fd], [], [], wait)
            chars = os.read(fd, 64).decode(errors="ignore") if ready else ""
            out = None
            for ch in chars:
                out = teleop.key(ch, now)
            if out is None:
                out = teleop.tick(now)
            if out is not None:
                pub.publish(out.to_twist())
                self.summary.commands += 1

        with cbreak(fd):
            return self._loop(read, duration)

    def joystick(self, reader: JoystickReader, duration: float | None = None,
                 params: TeleopNodeParams | None = None,
                 autorepeat_rate: float = 20.0) -> TeleopSummary:
        """Drive from a joystick through the rover's joystick node; the last state is
        republished at ``autorepeat_rate`` [Hz] while nothing changes (ROS ``joy``'s
        parameter), so a held stick keeps the mux input alive."""
        if self.node is None:
            p = (params or TeleopNodeParams()).updated(
                twist_topic=mux_input_topic(self.stack, "joystick"))
            self.node = TeleopNode(self.stack.runtime, p)
            self.node.configure()
            self.node.activate()
            self._joy_pub = self.stack.runtime.bus.publisher(p.joy_topic, Joy, QoS(depth=10))
        pub = self._joy_pub
        period = 1.0 / autorepeat_rate if autorepeat_rate > 0.0 else float("inf")

        def read(now: float, wait: float) -> None:
            time.sleep(wait)
            msg = reader.poll(now)
            if msg is None and self._last_joy is not None and now - self._joy_at >= period - 1e-9:
                msg = Joy(Header(now, self._last_joy.header.frame_id), self._last_joy.axes,
                          self._last_joy.buttons)
            if msg is not None:
                pub.publish(msg)
                self._last_joy, self._joy_at = msg, now
                self.summary.joy_messages += 1

        return self._loop(read, duration)

    # --- the loop ---------------------------------------------------------------------------
    def _loop(self, read: Callable[[float, float], None],
              duration: float | None) -> TeleopSummary:
        stack = self.stack
        sim = stack.sim.sim
        start_pose = sim.pose
        last = (start_pose.x, start_pose.y)
        t0, wall0 = stack.now, self.clock()
        try:
            while duration is None or stack.now - t0 < duration - 1e-9:
                ahead = (stack.now - t0) / self.rtf - (self.clock() - wall0)
                read(stack.now, max(0.0, ahead))
                stack.run_for(STEP)
                p = sim.pose
                self.summary.distance_m += ((p.x - last[0]) ** 2 + (p.y - last[1]) ** 2) ** 0.5
                last = (p.x, p.y)
                winner = stack.twist_mux.mux.winner(stack.now) or "-"
                self.summary.mux_winners[winner] = self.summary.mux_winners.get(winner, 0) + 1
                self._show()
        except KeyboardInterrupt:
            pass
        finally:
            if self.status is not None and getattr(self.status, "isatty", lambda: False)():
                self.status.write("\n")
        p = sim.pose
        self.summary.sim_time_s = stack.now - t0
        self.summary.final_pose = (p.x, p.y, p.theta)
        self.summary.collisions = sim.collisions
        return self.summary

    def _show(self) -> None:
        if self.status is None or self.clock() - self._last_status < 0.5:
            return
        self._last_status = self.clock()
        s = self.stack
        p = s.sim.sim.pose
        odom = s.sim.sim.state
        mux = s.twist_mux
        line = (f"t {s.now:7.1f} s  pose ({p.x:6.2f}, {p.y:6.2f}, {p.theta:+.2f})  "
                f"v {odom.vx:+.2f} m/s  w {odom.wz:+.2f} rad/s  mux "
                f"{mux.mux.winner(s.now) or '-'}  e-stop {'ON' if mux.locked else 'off'}")
        tty_out = getattr(self.status, "isatty", lambda: False)()
        self.status.write(("\r\033[K" + line) if tty_out else line + "\n")
        self.status.flush()


def default_status() -> TextIO:
    return sys.stdout
