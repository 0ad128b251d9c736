"""Keepout filter (Nav2 ``nav2_costmap_2d::KeepoutFilter``).

The mask is read as Nav2 reads it (``Costmap2D(OccupancyGrid)``): ``-1`` -> NO_INFORMATION,
otherwise ``round(value * 254 / 100)``, so an occupied mask cell (100) is LETHAL and an
intermediate value (e.g. 50 -> 127) becomes a proportional cost - preferred lanes are
drawn with low values.  In the update window each master cell takes the mask cell under
its centre when that value is known and higher than the current cost (or the current
cost is unknown).  The filter info must be of type 0 and keep ``base`` 0 and
``multiplier`` 1.

``override_lethal_cost`` (Nav2 Jazzy): while the robot itself stands in a lethal keepout
cell, lethal mask cells are written as ``lethal_override_cost`` instead, so the planner
can lead it out of the zone.

A freshly set mask, a moved mask (:meth:`~CostmapFilter.set_mask_in_costmap`, e.g. a new
``odom <- map`` correction under a local costmap) and a change of the override state force
the next update to cover the mask's extent (Nav2 only applies filters in windows other
layers touched, so a late mask would otherwise wait for them).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.errors import ConfigError
from navstack.core.msgs import CostmapFilterInfo, OccupancyGrid
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D
from navstack.costmap.costmap_filter import (
    BASE_DEFAULT,
    FILTER_TYPES,
    KEEPOUT_FILTER,
    MULTIPLIER_DEFAULT,
    CostmapFilter,
    CostmapFilterParams,
)
from navstack.costmap.grid_sampling import sample_window
from navstack.costmap.layer import Bounds, CellWindow, register_layer


class KeepoutFilterParams(CostmapFilterParams):
    """Nav2 KeepoutFilter parameters."""

    override_lethal_cost: bool = False
    lethal_override_cost: int = Field(252, ge=0, le=253)


def mask_to_costs(values: NDArray[np.int8]) -> NDArray[np.uint8]:
    """Nav2 OccupancyGrid -> Costmap2D conversion: -1 -> 255, v -> round(v * 254 / 100)."""
    v = values.astype(np.float64)
    cost = np.clip(np.round(v * LETHAL_OBSTACLE / 100.0), 0, LETHAL_OBSTACLE)
    return np.where(values < 0, NO_INFORMATION, cost).astype(np.uint8)


@register_layer("KeepoutFilter", nav2="nav2_costmap_2d::KeepoutFilter")
class KeepoutFilter(CostmapFilter):
    """Writes keepout zones (lethal) and lane preferences (costs) from a mask."""

    params_model = KeepoutFilterParams
    params: KeepoutFilterParams

    def __init__(self, name: str = "keepout_filter",
                 params: KeepoutFilterParams | None = None) -> None:
        super().__init__(name, params)
        self._pending = Bounds()
        self._extent = Bounds()
        self._overriding = False
        self._costs: NDArray[np.uint8] = np.zeros((0, 0), np.uint8)
        self._costs_of: OccupancyGrid | None = None

    def check_filter_info(self, info: CostmapFilterInfo, *, file: str = "",
                          key_path: str = "") -> None:
        where = key_path or f"{self.name}.filter_info"
        if info.type != KEEPOUT_FILTER:
            raise ConfigError(
                f"keepout filter '{self.name}' got filter type {info.type} "
                f"({FILTER_TYPES.get(info.type, 'unknown')})", file=file,
                key_path=f"{where}.type",
                suggestion=f"a keepout filter reads type {KEEPOUT_FILTER}")
        if info.base != BASE_DEFAULT or info.multiplier != MULTIPLIER_DEFAULT:
            raise ConfigError(
                f"keepout filter '{self.name}' needs base {BASE_DEFAULT} and multiplier "
                f"{MULTIPLIER_DEFAULT} in its CostmapFilterInfo, got base {info.base} and "
                f"multiplier {info.multiplier}", file=file, key_path=where,
                suggestion="set base: 0.0 and multiplier: 1.0 in the filter info server")

    def _on_mask_moved(self) -> None:
        """Rewrite the zone where it was and where it is now at the next update."""
        self._pending.union(self._extent)
        self._extent = Bounds()
        if self.mask is None:
            return
        info = self.mask.info
        o = info.origin.to_pose2d()
        w, h = info.width * info.resolution, info.height * info.resolution
        corners = o.transform_points(np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]))
        if self.mask_in_costmap is not None:
            corners = self.mask_in_costmap.transform_points(corners)
        self._extent.touch_points(corners)
        self._pending.union(self._extent)

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        bounds = super().update_bounds(robot_x, robot_y, robot_yaw, bounds)
        if self.params.override_lethal_cost:
            overriding = self._robot_in_keepout()
            if overriding != self._overriding:  # the zone's costs change: rewrite all of it
                self._pending.union(self._extent)
            self._overriding = overriding
        bounds.union(self._pending)
        self._pending = Bounds()
        return bounds

    def _robot_in_keepout(self) -> bool:
        if self.robot_pose is None or self.mask is None:
            return False
        vals, inside = self.mask_values_at(np.array([[self.robot_pose.x, self.robot_pose.y]]))
        return bool(inside[0]) and int(mask_to_costs(vals)[0]) == LETHAL_OBSTACLE

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        if not self.enabled or self.mask is None or window.empty:
            return
        if self._costs_of is not self.mask:  # the mask's costs, once per mask
            self._costs = mask_to_costs(self.mask_data)
            self._costs_of = self.mask
        sampled, inside = sample_window(
            self._costs, self.mask.info, master.origin_x, master.origin_y, master.resolution,
            (window.min_i, window.min_j, window.max_i, window.max_j), self.mask_in_costmap)
        cost = np.asarray(sampled, dtype=np.uint8)
        if self.params.override_lethal_cost and self._overriding:
            cost[cost == LETHAL_OBSTACLE] = self.params.lethal_override_cost
        dst = master.data[window.slices]
        take = inside & (cost != NO_INFORMATION) & ((cost > dst) | (dst == NO_INFORMATION))
        dst[take] = cost[take]
        self.current = True
