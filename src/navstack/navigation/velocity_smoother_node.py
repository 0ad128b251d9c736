"""``VelocitySmootherNode``: ``/cmd_vel_nav`` -> smoothing -> ``/cmd_vel_smoothed`` (Nav2
``velocity_smoother``).

Takes the latest command (``Twist``, or ``TwistStamped`` with ``enable_stamped_cmd_vel``)
and, for ``feedback: CLOSED_LOOP``, the odometry twist; publishes
:meth:`navstack.control.velocity_smoother.VelocitySmoother.cycle`'s output on a timer at
``smoothing_frequency``, phased 1 ms after the controller's cycle so a command is
smoothed in the cycle it was computed in (a timer firing at the same instant would run
before the command is delivered, adding one period of latency).  Speed limits are not
applied here (Nav2 applies them in the controller, and so does navstack).

navstack departure: a message on ``/<name>/stop`` (:data:`STOP_TOPIC`, ``std_msgs/Bool``)
is an operator's stop -- a mission cancelled, a leg aborted: the smoother drops its state
and publishes zero at once instead of ramping down at ``max_decel`` (Nav2 ramps every
zero, so a cancelled goal keeps the robot rolling for ``v / decel`` seconds).
"""

from __future__ import annotations

from typing import Any

from navstack.control.velocity_smoother import VelocitySmoother, VelocitySmootherParams
from navstack.core.msgs import Bool, Header, Odometry, Twist, TwistStamped
from navstack.runtime.bus import QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["PHASE", "STOP_TOPIC", "VelocitySmootherNode"]

STOP_TOPIC = "/velocity_smoother/stop"
"""The default smoother's stop-request topic (``/<node name>/stop``)."""

PHASE = 1e-3
"""[s] the smoothing timer runs this long after the instants of the controller's cycles."""


class VelocitySmootherNode(Node):
    """Nav2's velocity smoother on the bus."""

    def __init__(self, runtime: Runtime, params: VelocitySmootherParams | None = None,
                 name: str = "velocity_smoother") -> None:
        super().__init__(name, runtime)
        self.params = params or VelocitySmootherParams()
        self.smoother = VelocitySmoother(self.params)
        self.published = 0

    def on_configure(self) -> None:
        p = self.params
        kind: type[Any] = TwistStamped if p.enable_stamped_cmd_vel else Twist
        self.pub = self.create_publisher(p.cmd_vel_out_topic, kind, QoS(depth=1))
        self.create_subscription(p.cmd_vel_in_topic, kind, self._on_cmd, QoS(depth=1))
        if p.feedback == "CLOSED_LOOP":
            self.create_subscription(p.odom_topic, Odometry, self._on_odom, QoS(depth=10))
        self.create_subscription(f"/{self.name}/stop", Bool, self._on_stop, QoS(depth=1))

    def on_activate(self) -> None:
        # PHASE after the controller's cycle: a command published at t is smoothed at
        # t + PHASE, not one period later (timers at equal times run before deliveries)
        period = 1.0 / self.params.smoothing_frequency
        self._timer = self.runtime.scheduler.create_timer(
            period, self._cycle, first_at=self.now + PHASE)

    def on_deactivate(self) -> None:
        self._timer.cancel()
        self.smoother.reset()

    def _on_cmd(self, msg: Twist | TwistStamped) -> None:
        twist = msg.twist if isinstance(msg, TwistStamped) else msg
        if not self.smoother.command(twist.to_twist2d(), self.now):
            self.log.warning("velocity_smoother: ignoring a non-finite command %s", twist)

    def _on_stop(self, msg: Bool) -> None:
        """An operator's stop (module docstring): zero now, no ramp."""
        if not msg.data:
            return
        self.smoother.reset()
        self.published += 1
        if self.params.enable_stamped_cmd_vel:
            self.pub.publish(TwistStamped(Header(self.now, "base_link"), Twist()))
        else:
            self.pub.publish(Twist())

    def _on_odom(self, msg: Odometry) -> None:
        self.smoother.odometry(msg.twist.twist.to_twist2d(), self.now)

    def _cycle(self) -> None:
        out = self.smoother.cycle(self.now)
        if out is None:
            return
        self.published += 1
        if self.params.enable_stamped_cmd_vel:
            self.pub.publish(TwistStamped(Header(self.now, "base_link"), out.to_twist()))
        else:
            self.pub.publish(out.to_twist())
