"""``SimGripperNode``: the simulated gripper behind the same service as the real servo.

``/gripper/servo`` takes ``(pin, duty)`` like :class:`navstack.nodes.gripper.
GripperServiceNode` and replies ``"OK"``: a duty past half way from open to close closes
the gripper (the package in reach is held once ``close_time`` has passed, as the servo
ramp takes 2 s), a lower one opens it.  The reply comes at once (an in-process service
cannot hold the simulated clock); callers wait ``close_time`` as they would wait for the
real reply.  Invalid requests raise :class:`~navstack.drivers.gpio_servo.ServoError` with
the real driver's checks.  ``/gripper/status`` (std_msgs/String): ``open``, ``closing``,
``closed`` or ``holding <package name>``, published on change.
"""

from __future__ import annotations

from navstack.core.msgs import String
from navstack.core.msgs.gripper_msgs import GRIPPER_SERVICE, GRIPPER_STATUS_TOPIC, ServoCommand
from navstack.drivers.gpio_servo import ServoError, ServoParams
from navstack.runtime.bus import LATCHED
from navstack.runtime.node import Node, Runtime
from navstack.sim.node import SimulatorNode


class SimGripperNode(Node):
    """The gripper of the simulated robot (see module docstring)."""

    def __init__(self, runtime: Runtime, sim_node: SimulatorNode,
                 servo: ServoParams | None = None, name: str = "gripper") -> None:
        super().__init__(name, runtime)
        self.sim_node = sim_node
        self.servo = servo or ServoParams()
        self.status = "open"

    def on_configure(self) -> None:
        self.pub_status = self.create_publisher(GRIPPER_STATUS_TOPIC, String, LATCHED)
        self.bus.advertise_service(GRIPPER_SERVICE, self._serve)
        self.create_timer(0.1, self._poll)

    def on_activate(self) -> None:
        self.pub_status.publish(String(self.status))

    def on_cleanup(self) -> None:
        self.bus.remove_service(GRIPPER_SERVICE)

    def _serve(self, request: ServoCommand) -> str:
        p = self.servo
        if request.pin != p.pin:
            raise ServoError(f"pin {request.pin} is not the servo's pin (BCM {p.pin})")
        if not p.min_duty <= request.duty <= p.max_duty:
            raise ServoError(f"duty {request.duty!r} % is outside the servo's range "
                             f"{p.min_duty}..{p.max_duty} %")
        self.sim_node.advance()
        sim = self.sim_node.sim
        if request.duty >= 0.5 * (p.open_duty + p.close_duty):
            sim.packages.close(sim.pose, sim.time)
        else:
            sim.packages.open()
        self._poll()
        return "OK"

    def _poll(self) -> None:
        pkgs = self.sim_node.sim.packages
        if pkgs.carried is not None:
            status = f"holding {pkgs.specs[pkgs.carried].name}"
        elif pkgs.closed:
            status = "closing" if self.sim_node.sim.time < pkgs.closing_until else "closed"
        else:
            status = "open"
        if status != self.status:
            self.status = status
            self.pub_status.publish(String(status))


__all__ = ["SimGripperNode"]
