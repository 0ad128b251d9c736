"""``DigitalOutputNode``: a GPIO output on the bus (an LED or a relay).

Subscribes ``topic`` (std_msgs/Bool: true = active) and publishes the pin's state on
``<topic>/state`` (latched) after every change.  The pin opens on activate and returns
to its safe value on deactivate, so a deactivated stack leaves relays released.  The
driver conventions (:mod:`navstack.drivers.gpio`) are the ones the gripper servo node
will follow.
"""

from __future__ import annotations

from typing import Any

from navstack.core.msgs import Bool
from navstack.drivers.gpio import DigitalOutput, GpioParams
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["DigitalOutputNode"]


class DigitalOutputNode(Node):
    def __init__(self, runtime: Runtime, params: GpioParams, topic: str,
                 pin_factory: Any = None, name: str | None = None) -> None:
        super().__init__(name or f"gpio{params.pin}", runtime)
        self.topic = topic
        self.output = DigitalOutput(params, pin_factory)

    def on_configure(self) -> None:
        self.pub_state = self.create_publisher(f"{self.topic}/state", Bool, LATCHED)
        self.create_subscription(self.topic, Bool, self._on_value, QoS(depth=1))

    def on_activate(self) -> None:
        self.output.open()
        self.pub_state.publish(Bool(self.output.value))

    def on_deactivate(self) -> None:
        self.output.close()
        self.pub_state.publish(Bool(self.output.value))

    def _on_value(self, msg: Bool) -> None:
        self.output.set(msg.data)
        self.pub_state.publish(Bool(self.output.value))
