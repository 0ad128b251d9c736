"""The gripper servo service of the TurtleBot course: request ``(pin, duty)``, reply a
string (``"OK"``)."""

from __future__ import annotations

from dataclasses import dataclass

GRIPPER_SERVICE = "/gripper/servo"
"""Bus name of the service (the real driver node and the simulator both offer it)."""
GRIPPER_STATUS_TOPIC = "/gripper/status"
"""std_msgs/String: ``open``, ``closing``, ``closed`` or ``holding <package>``."""


@dataclass(frozen=True, slots=True)
class ServoCommand:
    """Request of the servo service: BCM ``pin`` and ``duty`` cycle [%]."""

    pin: int = 20
    duty: float = 2.0


__all__ = ["GRIPPER_SERVICE", "GRIPPER_STATUS_TOPIC", "ServoCommand"]
