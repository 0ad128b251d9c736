"""Joy-level tests: teleop_twist_joy mapping, the rover's mode switch, the e-stop button."""

from __future__ import annotations

import pytest

from navstack.control.teleop_joy import TeleopJoy, TeleopJoyParams
from navstack.core.msgs import Bool, Joy, String, Twist, Twist2D
from navstack.nodes.teleop import TeleopNode
from navstack.runtime.actions import ActionServer, GoalStatus
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime


def joy(axes: tuple[float, ...] = (0.0, 0.0), **buttons: int) -> Joy:
    b = [0] * 8
    for k, v in buttons.items():
        b[int(k[1:])] = v
    return Joy(axes=axes, buttons=tuple(b))


def test_enable_turbo_and_one_zero_on_release() -> None:
    t = TeleopJoy(TeleopJoyParams(enable_turbo_button=5))
    assert t.joy(joy((0.5, 1.0))) == Twist2D()  # not enabled: one zero...
    assert t.joy(joy((0.5, 1.0))) is None  # ...then nothing
    assert t.joy(joy((0.5, 1.0), b0=1)) == Twist2D(0.5, 0.0, 0.25)
    assert t.joy(joy((0.5, 1.0), b5=1)) == Twist2D(1.0, 0.0, 0.5)  # turbo
    assert t.joy(joy((0.5, 1.0))) == Twist2D()
    free = TeleopJoy(TeleopJoyParams(require_enable_button=False))
    assert free.joy(joy((-1.0, 0.4))) == Twist2D(0.2, 0.0, -0.5)


class Rig:
    def __init__(self) -> None:
        self.rt = Runtime()
        self.server: ActionServer[object] = ActionServer(
            self.rt.bus, "navigate_to_pose", lambda h: (h.execute(), True)[1])
        self.node = TeleopNode(self.rt)
        self.rt.bring_up()
        self.modes: list[str] = []
        self.twists: list[float] = []
        self.lock: list[bool] = []
        self.rt.bus.subscribe("/rover/mode", String, lambda m: self.modes.append(m.data))
        self.rt.bus.subscribe("/joy_vel", Twist, lambda m: self.twists.append(m.linear.x),
                              QoS(depth=10))
        self.rt.bus.subscribe("/emergency_stop", Bool, lambda m: self.lock.append(m.data))
        self.pub = self.rt.bus.publisher("/joy", Joy)

    def send(self, msg: Joy) -> None:
        self.pub.publish(msg)
        self.rt.scheduler.run_for(0.05)


def test_switch_to_teleop_cancels_the_goal_and_sets_the_status() -> None:
    r = Rig()
    r.send(joy((0.0, 1.0), b0=1))
    assert r.modes == ["teleop"] and r.twists == [0.5]
    r.send(joy(b7=1))  # mode button: autonomy
    r.send(joy())
    goal = r.server.submit(object())
    assert r.modes[-1] == "auto" and not goal.done
    r.send(joy((0.0, 1.0), b0=1))
    assert r.twists == [0.5]  # no teleop twists in auto mode
    r.send(joy(b7=1))  # back to teleop: the active goal is cancelled
    assert goal.status is GoalStatus.CANCELED and r.node.cancelled == 1
    assert r.modes[-1] == "teleop"


def test_auto_goal_success_sets_success() -> None:
    r = Rig()
    goal = r.server.submit(object())
    r.send(joy(b7=1))
    goal.succeed()
    r.rt.scheduler.run_for(0.05)
    assert r.modes == ["teleop", "auto", "success"]


def test_estop_button_latches_the_lock_and_enable_plus_release_releases_it() -> None:
    r = Rig()
    r.send(joy(b1=1))
    assert r.lock == [True] and r.node.estop.latched and r.node.estop.holder == "joystick"
    r.send(joy())
    r.send(joy(b6=1))  # release without the enable button: refused
    assert r.node.estop.latched
    r.send(joy())
    r.send(joy(b0=1, b6=1))
    assert r.lock == [True, False] and not r.node.estop.latched


@pytest.mark.parametrize("mode", ["teleop", "auto"])
def test_set_mode_publishes(mode: str) -> None:
    r = Rig()
    r.node.set_mode(mode)
    r.rt.scheduler.run_for(0.05)
    assert r.modes[-1] == mode
