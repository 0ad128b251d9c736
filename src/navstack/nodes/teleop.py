"""``TeleopNode``: the rover's joystick node (``docs/command_path.md``).

``/joy`` (``sensor_msgs/Joy``) -> :class:`navstack.control.teleop_joy.TeleopJoy` ->
``twist_topic`` (the twist_mux's joystick input) while in **teleop** mode.  The mode
button toggles teleop <-> **auto**; returning to teleop cancels every active goal of the
navigation actions (``cancel_actions``) and publishes the mode on ``mode_topic``
(``std_msgs/String``, latched: ``teleop`` / ``auto`` / ``success``, the LED colour of the
rover's VCU string); a goal that succeeds in auto mode sets ``success``.  The e-stop
button latches the twist_mux lock as authority ``joystick``; holding the enable button
and pressing the release button releases it (only a joystick latch).
"""

from __future__ import annotations

from pydantic import Field

from navstack.control.teleop_joy import TeleopJoy, TeleopJoyParams
from navstack.core.msgs import Joy, String, Twist
from navstack.core.params import Params
from navstack.nodes.estop import EStopClient, EStopReleaseRefused
from navstack.runtime.actions import GoalStatus
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["TeleopNode", "TeleopNodeParams"]


class TeleopNodeParams(Params):
    """The joystick node's buttons and topics (navstack; the rover's node had them fixed)."""

    joy: TeleopJoyParams = Field(default_factory=TeleopJoyParams)
    joy_topic: str = "/joy"
    twist_topic: str = "/joy_vel"
    mode_topic: str = "/rover/mode"
    mode_button: int = Field(7, ge=0)
    estop_button: int = Field(1, ge=0)
    release_button: int = Field(6, ge=0)
    cancel_actions: list[str] = Field(default_factory=lambda: [
        "navigate_to_pose", "navigate_through_poses", "follow_waypoints"])
    start_mode: str = Field("teleop", pattern="^(teleop|auto)$")


class TeleopNode(Node):
    """Joystick teleop with the rover's teleop/autonomy switch and an e-stop button."""

    def __init__(self, runtime: Runtime, params: TeleopNodeParams | None = None,
                 name: str = "teleop") -> None:
        super().__init__(name, runtime)
        self.params = params or TeleopNodeParams()
        self.teleop = TeleopJoy(self.params.joy)
        self.mode = self.params.start_mode
        self.cancelled = 0
        self._prev: tuple[int, ...] = ()
        self.estop = EStopClient(runtime, "joystick")

    def on_configure(self) -> None:
        p = self.params
        self.pub = self.create_publisher(p.twist_topic, Twist, QoS(depth=1))
        self.pub_mode = self.create_publisher(p.mode_topic, String, LATCHED)
        self.create_subscription(p.joy_topic, Joy, self._on_joy, QoS(depth=10))

    def on_activate(self) -> None:
        self.pub_mode.publish(String(self.mode))

    def _pressed(self, msg: Joy, i: int) -> bool:
        now = i < len(msg.buttons) and msg.buttons[i] != 0
        before = i < len(self._prev) and self._prev[i] != 0
        return now and not before

    def _on_joy(self, msg: Joy) -> None:
        p = self.params
        if self._pressed(msg, p.estop_button):
            self.estop.latch("joystick e-stop button")
        held = p.joy.enable_button < len(msg.buttons) and msg.buttons[p.joy.enable_button]
        if self._pressed(msg, p.release_button) and held and self.estop.latched:
            try:
                self.estop.release()
            except EStopReleaseRefused as exc:
                self.log.warning("%s", exc)
        if self._pressed(msg, p.mode_button):
            self.set_mode("auto" if self.mode == "teleop" else "teleop")
        self._prev = tuple(msg.buttons)
        if self.mode == "teleop":
            out = self.teleop.joy(msg)
            if out is not None:
                self.pub.publish(out.to_twist())

    def set_mode(self, mode: str) -> None:
        """Switch to ``teleop`` (cancelling every active navigation goal) or ``auto``."""
        if mode == "teleop":
            self.cancelled += self._cancel_goals()
        elif mode == "auto":
            for name in self.params.cancel_actions:  # success when an auto goal ends well
                server = self._server(name)
                for handle in getattr(server, "goals", []):
                    if not handle.done:
                        handle.add_done_callback(self._on_goal_done)
        self.mode = mode
        self.pub_mode.publish(String(mode))

    def _on_goal_done(self, result: object) -> None:
        if self.mode == "auto" and getattr(result, "status", None) is GoalStatus.SUCCEEDED:
            self.mode = "success"
            self.pub_mode.publish(String("success"))

    def _server(self, name: str) -> object:
        """The action server ``name``, with or without the leading slash (the stack's
        servers are ``/navigate_to_pose``...; ROS names them relative)."""
        servers = self.bus.action_servers
        return servers.get(name) or servers.get("/" + name.lstrip("/")) or servers.get(
            name.lstrip("/"))

    def _cancel_goals(self) -> int:
        n = 0
        for name in self.params.cancel_actions:
            server = self._server(name)
            for handle in list(getattr(server, "goals", [])):
                if not handle.done:
                    handle.cancel()
                    n += 1
        return n
