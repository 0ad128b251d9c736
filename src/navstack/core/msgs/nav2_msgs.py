"""nav2_msgs equivalents: costmap filter info and speed limits.

Field names and meanings follow ``nav2_msgs/msg/CostmapFilterInfo`` and
``nav2_msgs/msg/SpeedLimit``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from navstack.core.msgs.std import Header


@dataclass(frozen=True, slots=True)
class CostmapFilterInfo:
    """nav2_msgs/CostmapFilterInfo: which filter a mask feeds and how to read its values.

    ``type``: 0 keepout / preferred lanes, 1 speed limit in percent of the maximum speed,
    2 speed limit in m/s, 3 binary filter.  ``filter_mask_topic``: the OccupancyGrid
    mask's topic.  A mask value ``v`` (0..100) means ``base + multiplier * v`` in the
    filter's space.
    """

    header: Header = field(default_factory=Header)
    type: int = 0
    filter_mask_topic: str = "filter_mask"
    base: float = 0.0
    multiplier: float = 1.0


@dataclass(frozen=True, slots=True)
class SpeedLimit:
    """nav2_msgs/SpeedLimit: ``speed_limit`` in percent of the maximum speed
    (``percentage``) or in m/s; ``0.0`` means no limit (Nav2 ``NO_SPEED_LIMIT``)."""

    header: Header = field(default_factory=Header)
    percentage: bool = False
    speed_limit: float = 0.0
