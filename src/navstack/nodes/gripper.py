"""``GripperServiceNode``: the gripper servo driver as the course's bus service.

Offers ``/gripper/servo`` (request :class:`~navstack.core.msgs.gripper_msgs.ServoCommand`
``(pin, duty)``, reply ``"OK"``) backed by :class:`~navstack.drivers.gpio_servo.GpioServo`
and publishes ``/gripper/status`` (std_msgs/String ``open`` / ``closed``) after each
request.  As on the course's robot the call returns when the servo is there: a close ramp
holds the caller for its 20 steps (2 s), so call it from a behaviour that may wait.  A
bad request raises :class:`~navstack.drivers.gpio_servo.ServoError` to the caller.  On
deactivation the servo returns to its open duty and the pin is released.  The simulator
offers the same service (:class:`navstack.sim.gripper_node.SimGripperNode`).
"""

from __future__ import annotations

from navstack.core.msgs import String
from navstack.core.msgs.gripper_msgs import GRIPPER_SERVICE, GRIPPER_STATUS_TOPIC, ServoCommand
from navstack.drivers.gpio_servo import GpioServo
from navstack.runtime.bus import LATCHED
from navstack.runtime.node import Node, Runtime


class GripperServiceNode(Node):
    """The servo service on the bus (see module docstring)."""

    def __init__(self, runtime: Runtime, servo: GpioServo, name: str = "gripper") -> None:
        super().__init__(name, runtime)
        self.servo = servo
        self.requests = 0

    def on_configure(self) -> None:
        self.pub_status = self.create_publisher(GRIPPER_STATUS_TOPIC, String, LATCHED)
        self.bus.advertise_service(GRIPPER_SERVICE, self._serve)

    def on_activate(self) -> None:
        self.servo.open()
        self.pub_status.publish(String("open"))

    def on_deactivate(self) -> None:
        self.servo.close()

    def on_cleanup(self) -> None:
        self.bus.remove_service(GRIPPER_SERVICE)

    def _serve(self, request: ServoCommand) -> str:
        reply = self.servo.command(request.pin, request.duty)
        self.requests += 1
        p = self.servo.params
        closed = self.servo.duty >= 0.5 * (p.open_duty + p.close_duty)
        self.pub_status.publish(String("closed" if closed else "open"))
        return reply


__all__ = ["GripperServiceNode"]
