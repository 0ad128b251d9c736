"""Costmap filter base (Nav2 ``nav2_costmap_2d::CostmapFilter``) and filter info.

A filter reads a *mask* (an OccupancyGrid published by a map server next to a
``CostmapFilterInfo`` message) and acts on the master grid or on the robot's state.
Here the mask and its info are passed in with :meth:`CostmapFilter.set_mask`; when the
mask lives in another frame than the costmap, ``mask_in_costmap`` is the pose of the mask
frame in the costmap frame (explicit, no TF).  Filters run after all plugins (Nav2
``filters:`` list) and remember the robot pose from ``update_bounds``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.costmap.grid_sampling import points_to_cells
from navstack.costmap.layer import Bounds, Layer, LayerParams

KEEPOUT_FILTER = 0
SPEED_FILTER_PERCENT = 1
SPEED_FILTER_ABSOLUTE = 2
BINARY_FILTER = 3
BASE_DEFAULT = 0.0
MULTIPLIER_DEFAULT = 1.0


@dataclass(frozen=True)
class CostmapFilterInfo:
    """nav2_msgs/CostmapFilterInfo: filter type and the linear mask-value conversion."""

    type: int = KEEPOUT_FILTER
    filter_mask_topic: str = "/filter_mask"
    base: float = BASE_DEFAULT
    multiplier: float = MULTIPLIER_DEFAULT


class CostmapFilterParams(LayerParams):
    """Nav2 CostmapFilter parameters."""

    filter_info_topic: str = ""
    transform_tolerance: float = Field(0.1, ge=0.0)


class CostmapFilter(Layer):
    """Holds the mask and the latest robot pose; subclasses implement ``update_costs``."""

    params: CostmapFilterParams

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

    def set_mask(self, mask: OccupancyGrid, filter_info: CostmapFilterInfo | None = None,
                 mask_in_costmap: Pose2D | None = None) -> None:
        info = mask.info
        data = np.asarray(mask.data, dtype=np.int8)
        if data.shape != (info.height, info.width):
            data = data.reshape(info.height, info.width)
        if filter_info is not None:
            self._check_info(filter_info)
            self.filter_info = filter_info
        self.mask = mask
        self.mask_data = data
        self.mask_in_costmap = mask_in_costmap
        self.current = True

    def _check_info(self, info: CostmapFilterInfo) -> None:
        """Validate the filter info for this filter type (overridden)."""

    def mask_values_at(self, xy: NDArray[np.float64]) -> tuple[NDArray[np.int8],
                                                                 NDArray[np.bool_]]:
        """Raw int8 mask values at costmap-frame points ``(N, 2)`` and an inside flag."""
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
