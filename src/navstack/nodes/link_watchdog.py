"""``LinkWatchdog``: the robot stops by itself when the link to its base is lost.

Sits between the collision monitor and the base (``/cmd_vel_guarded`` -> ``/cmd_vel``):
commands pass while ``link_up()`` is true; the moment it turns false (checked at
``rate_hz``) the watchdog publishes a zero twist, then keeps publishing zero and drops
incoming commands until the link is back.  Safety never depends on the link: the check
uses only what the robot itself knows (the age of the last answered heartbeat).
"""

from __future__ import annotations

from collections.abc import Callable

from navstack.core.msgs import Twist
from navstack.runtime.bus import QoS
from navstack.runtime.node import Node, Runtime


class LinkWatchdog(Node):
    """Gates velocity commands on the link's health (module docstring)."""

    def __init__(self, runtime: Runtime, link_up: Callable[[], bool],
                 cmd_in: str = "/cmd_vel_guarded", cmd_out: str = "/cmd_vel",
                 rate_hz: float = 50.0, name: str = "link_watchdog") -> None:
        super().__init__(name, runtime)
        if not rate_hz > 0.0:
            raise ValueError(f"link watchdog rate_hz must be > 0, got {rate_hz}")
        self.link_up = link_up
        self.cmd_in, self.cmd_out, self.period = cmd_in, cmd_out, 1.0 / rate_hz
        self.up = True
        self.stops: list[float] = []    # times the link was declared lost
        self.resumes: list[float] = []  # times it came back
        self.blocked = 0

    def on_configure(self) -> None:
        self.pub = self.create_publisher(self.cmd_out, Twist, QoS(depth=1))
        self.create_subscription(self.cmd_in, Twist, self._on_cmd, QoS(depth=1))
        self.create_timer(self.period, self._check)

    def _check(self) -> None:
        up = self.link_up()
        if up != self.up:
            (self.resumes if up else self.stops).append(self.now)
            self.log.warning("link to base %s", "back: commands resume" if up
                             else "lost: stopping the robot")
            self.up = up
        if not up:
            self.pub.publish(Twist())

    def _on_cmd(self, msg: Twist) -> None:
        if self.up and self.link_up():
            self.pub.publish(msg)
        else:
            self.blocked += 1
