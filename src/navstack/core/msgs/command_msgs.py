"""Messages of the command path: ``sensor_msgs/Joy``, ``sensor_msgs/Range`` and
``nav2_msgs/CollisionMonitorState`` (field names as in ROS 2)."""

from __future__ import annotations

from dataclasses import dataclass, field

from navstack.core.msgs.std import Header


@dataclass(frozen=True, slots=True)
class Joy:
    """sensor_msgs/Joy: ``axes`` in [-1, 1], ``buttons`` 0/1, as the joy node reports."""

    header: Header = field(default_factory=Header)
    axes: tuple[float, ...] = ()
    buttons: tuple[int, ...] = ()


@dataclass(frozen=True, slots=True)
class Range:
    """sensor_msgs/Range: one distance [m] over a cone of ``field_of_view`` [rad]
    (``radiation_type`` 0 ultrasound, 1 infrared)."""

    header: Header = field(default_factory=Header)
    radiation_type: int = 0
    field_of_view: float = 0.0
    min_range: float = 0.0
    max_range: float = 0.0
    range: float = 0.0


@dataclass(frozen=True, slots=True)
class CollisionMonitorState:
    """nav2_msgs/CollisionMonitorState: the action the collision monitor is taking and
    the polygon that caused it (``action_type``: 0 DO_NOTHING, 1 STOP, 2 SLOWDOWN,
    3 APPROACH, 4 LIMIT)."""

    action_type: int = 0
    polygon_name: str = ""
