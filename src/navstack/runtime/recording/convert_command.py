"""navstack <-> ROS 2 conversions for the command path's messages: ``sensor_msgs/Joy``,
``sensor_msgs/Range`` and ``nav2_msgs/CollisionMonitorState`` (same conventions as
:mod:`.convert_geometry`; ``float32`` fields read back as their shortest float64)."""

from __future__ import annotations

from typing import Any

import numpy as np

from navstack.core.msgs import CollisionMonitorState, Joy, Range
from navstack.runtime.recording.convert_geometry import f32, from_header, to_header

COLLISION_MONITOR_STATE_DEFINITION = (
    "uint8 DO_NOTHING=0\nuint8 STOP=1\nuint8 SLOWDOWN=2\nuint8 APPROACH=3\nuint8 LIMIT=4\n"
    "uint8 action_type\nstring polygon_name\n")
"""Nav2's ``nav2_msgs/msg/CollisionMonitorState`` (not in the Humble typestore)."""


def to_joy(m: Joy, r: Any) -> Any:
    return r.Joy(header=to_header(m.header, r), axes=np.asarray(m.axes, dtype=np.float32),
                 buttons=np.asarray(m.buttons, dtype=np.int32))


def from_joy(o: Any) -> Joy:
    return Joy(from_header(o.header), tuple(f32(a) for a in o.axes),
               tuple(int(b) for b in o.buttons))


def to_range(m: Range, r: Any) -> Any:
    return r.Range(header=to_header(m.header, r), radiation_type=int(m.radiation_type),
                   field_of_view=float(m.field_of_view), min_range=float(m.min_range),
                   max_range=float(m.max_range), range=float(m.range))


def from_range(o: Any) -> Range:
    return Range(from_header(o.header), int(o.radiation_type), f32(o.field_of_view),
                 f32(o.min_range), f32(o.max_range), f32(o.range))


def to_collision_monitor_state(m: CollisionMonitorState, r: Any) -> Any:
    return r.CollisionMonitorState(action_type=int(m.action_type),
                                   polygon_name=m.polygon_name)


def from_collision_monitor_state(o: Any) -> CollisionMonitorState:
    return CollisionMonitorState(int(o.action_type), str(o.polygon_name))
