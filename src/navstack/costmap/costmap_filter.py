"""Costmap filter base (Nav2 ``nav2_costmap_2d::CostmapFilter``) and filter types.

A filter reads a *mask* (an OccupancyGrid published by a map server next to a
``CostmapFilterInfo`` message, see :mod:`navstack.navigation.costmap_filter_servers`) and
acts on the master grid or on the robot's state.  This algorithm-level class takes both by
method call: :meth:`CostmapFilter.set_filter_info` (what the mask values mean) and
:meth:`CostmapFilter.set_mask`; when the mask lives in another frame than the costmap,
``mask_in_costmap`` is the pose of the mask frame in the costmap frame (explicit, no TF;
the costmap node keeps it current with :meth:`CostmapFilter.set_mask_in_costmap`).
Filters run after all plugins (Nav2 ``filters:`` list) and remember the robot pose from
``update_bounds``.

Mask values follow Nav2: a cell holds ``-1`` (unknown) or ``0..100``, and a value ``v``
means ``base + multiplier * v`` in the filter's space (:func:`filter_values`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.errors import InvalidMessage
from navstack.core.msgs import CostmapFilterInfo, OccupancyGrid, Pose2D
from navstack.costmap.grid_sampling import points_to_cells
from navstack.costmap.layer import Bounds, Layer, LayerParams

KEEPOUT_FILTER = 0
SPEED_FILTER_PERCENT = 1
SPEED_FILTER_ABSOLUTE = 2
BINARY_FILTER = 3
FILTER_TYPES = {KEEPOUT_FILTER: "keepout zones / preferred lanes",
                SPEED_FILTER_PERCENT: "speed limit in percent of the maximum speed",
                SPEED_FILTER_ABSOLUTE: "speed limit in m/s",
                BINARY_FILTER: "binary filter"}
"""nav2_msgs/CostmapFilterInfo ``type`` values (Nav2 ``filter_values.hpp``)."""
BASE_DEFAULT = 0.0
MULTIPLIER_DEFAULT = 1.0

__all__ = ["BASE_DEFAULT", "BINARY_FILTER", "FILTER_TYPES", "KEEPOUT_FILTER",
           "MULTIPLIER_DEFAULT", "SPEED_FILTER_ABSOLUTE", "SPEED_FILTER_PERCENT",
           "CostmapFilter", "CostmapFilterInfo", "CostmapFilterParams", "filter_values"]


def filter_values(mask_values: NDArray[np.integer], info: CostmapFilterInfo
                  ) -> NDArray[np.float64]:
    """``base + multiplier * v`` for mask values ``v`` (Nav2's linear conversion of the
    OccupancyGrid value into the filter's space); unknown (-1) cells give NaN."""
    v = np.asarray(mask_values, dtype=np.float64)
    out = info.base + info.multiplier * v
    return np.where(v < 0, np.nan, out)


class CostmapFilterParams(LayerParams):
    """Nav2 CostmapFilter parameters."""

    filter_info_topic: str = ""
    transform_tolerance: float = Field(0.1, ge=0.0)


class CostmapFilter(Layer):
    """Holds the mask and the latest robot pose; subclasses implement ``update_costs``."""

    params: CostmapFilterParams
    accepted_types: tuple[int, ...] = tuple(FILTER_TYPES)
    """Filter info ``type`` values this filter reads."""

    def __init__(self, name: str, params: CostmapFilterParams | None = None) -> None:
        super().__init__(name, params)
        self.mask: OccupancyGrid | None = None
        self.mask_data: NDArray[np.int8] = np.zeros((0, 0), np.int8)
        self.filter_info = CostmapFilterInfo()
        self.mask_in_costmap: Pose2D | None = None
        self.robot_pose: Pose2D | None = None

    @property
    def active(self) -> bool:
        """Nav2 ``isActive``: a mask has been received."""
        return self.mask is not None

    @property
    def mask_frame(self) -> str:
        """Frame of the current mask (``""`` without a mask)."""
        return self.mask.header.frame_id if self.mask is not None else ""

    def set_filter_info(self, info: CostmapFilterInfo) -> None:
        """Take a new CostmapFilterInfo (Nav2 ``filterInfoCallback``).

        Raises :class:`~navstack.core.errors.ConfigError` when this filter cannot read the
        info (wrong ``type``, or base/multiplier a keepout filter does not allow)."""
        self.check_filter_info(info)
        self.filter_info = info

    def check_filter_info(self, info: CostmapFilterInfo, *, file: str = "",
                          key_path: str = "") -> None:
        """Raise ``ConfigError`` if this filter cannot read ``info`` (overridden)."""

    def set_mask(self, mask: OccupancyGrid, filter_info: CostmapFilterInfo | None = None,
                 mask_in_costmap: Pose2D | None = None) -> None:
        """Take a new mask (Nav2 ``maskCallback``), optionally with its filter info and
        the pose of the mask's frame in the costmap frame."""
        info = mask.info
        data = np.asarray(mask.data, dtype=np.int8)
        if data.shape != (info.height, info.width):
            if data.size != info.height * info.width:
                raise InvalidMessage(
                    f"filter '{self.name}': mask data holds {data.size} cells but its info "
                    f"says {info.width} x {info.height}; publish a consistent OccupancyGrid")
            data = data.reshape(info.height, info.width)
        if filter_info is not None:
            self.set_filter_info(filter_info)
        self.mask = mask
        self.mask_data = data
        self.mask_in_costmap = mask_in_costmap
        self._on_mask_moved()
        self.current = True

    def set_mask_in_costmap(self, mask_in_costmap: Pose2D | None) -> None:
        """Update the pose of the mask frame in the costmap frame (it moves when the
        costmap frame is ``odom`` and localization corrects ``map -> odom``)."""
        old = self.mask_in_costmap
        if old == mask_in_costmap:
            return
        self.mask_in_costmap = mask_in_costmap
        self._on_mask_moved()

    def _on_mask_moved(self) -> None:
        """Hook: the mask or its placement changed."""

    def mask_values_at(self, xy: NDArray[np.float64]) -> tuple[NDArray[np.int8],
                                                                 NDArray[np.bool_]]:
        """Raw int8 mask values at costmap-frame points ``(N, 2)`` and an inside flag
        (points off the mask read -1)."""
        if self.mask is None:
            raise RuntimeError(f"filter '{self.name}' has no mask; call set_mask() first")
        col, row, inside = points_to_cells(xy, self.mask.info, self.mask_in_costmap)
        vals = np.full(len(xy), -1, np.int8)
        vals[inside] = self.mask_data[row[inside], col[inside]]
        return vals, inside

    def is_current(self, now: float | None = None) -> bool:
        return True

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        self.robot_pose = Pose2D(robot_x, robot_y, robot_yaw)
        return bounds
