"""navstack <-> ROS 2 conversions for nav2_msgs (same conventions as :mod:`.convert_geometry`).

nav2_msgs is not in the ROS 2 Humble typestore rosbags ships, so its message definitions
(Nav2 Humble ``nav2_msgs/msg/*.msg``) are registered here (:data:`NAV2_MSG_DEFINITIONS`).
"""

from __future__ import annotations

from typing import Any

from navstack.core.msgs import CostmapFilterInfo, SpeedLimit
from navstack.runtime.recording.convert_geometry import f32, from_header, to_header

NAV2_MSG_DEFINITIONS: dict[str, str] = {
    "nav2_msgs/msg/CostmapFilterInfo": (
        "std_msgs/Header header\nuint8 type\nstring filter_mask_topic\nfloat32 base\n"
        "float32 multiplier\n"),
    "nav2_msgs/msg/SpeedLimit": (
        "std_msgs/Header header\nbool percentage\nfloat64 speed_limit\n"),
}
"""ROS 2 message definitions of the nav2_msgs types the bus carries."""


def to_costmap_filter_info(m: CostmapFilterInfo, r: Any) -> Any:
    return r.CostmapFilterInfo(header=to_header(m.header, r), type=int(m.type),
                               filter_mask_topic=m.filter_mask_topic, base=float(m.base),
                               multiplier=float(m.multiplier))


def from_costmap_filter_info(o: Any) -> CostmapFilterInfo:
    return CostmapFilterInfo(from_header(o.header), int(o.type), str(o.filter_mask_topic),
                             f32(o.base), f32(o.multiplier))


def to_speed_limit(m: SpeedLimit, r: Any) -> Any:
    return r.SpeedLimit(header=to_header(m.header, r), percentage=bool(m.percentage),
                        speed_limit=float(m.speed_limit))


def from_speed_limit(o: Any) -> SpeedLimit:
    return SpeedLimit(from_header(o.header), bool(o.percentage), float(o.speed_limit))
