"""Speed filter (Nav2 ``nav2_costmap_2d::SpeedFilter``): speed limits from a mask.

The raw mask value ``v`` (0..100) under a point gives, with the filter info's ``base`` and
``multiplier``, ``speed_limit = base + multiplier * v``:

* filter type ``SPEED_FILTER_PERCENT`` (1): a percentage of the maximum speed, valid in
  ``[0, 100]``; ``SPEED_FILTER_ABSOLUTE`` (2): metres per second, valid when ``>= 0``;
* ``v == 0`` means "no limit", ``v == -1`` (unknown) and points off the mask give no
  limit either, as does an out-of-range result (Nav2 warns and publishes "no limit").

:meth:`SpeedFilter.speed_limit_at` answers for any point; each ``update_map`` stores the
limit at the robot's pose in ``current_speed_limit`` for the controller
(``set_speed_limit``), whether or not any cell needed updating.
The filter never changes costs.
"""

from __future__ import annotations

import numpy as np

from navstack.core.errors import ConfigError
from navstack.costmap.costmap_2d import Costmap2D
from navstack.costmap.costmap_filter import (
    SPEED_FILTER_ABSOLUTE,
    SPEED_FILTER_PERCENT,
    CostmapFilter,
    CostmapFilterInfo,
    CostmapFilterParams,
)
from navstack.costmap.layer import Bounds, CellWindow, register_layer


class SpeedFilterParams(CostmapFilterParams):
    """Nav2 SpeedFilter parameters."""

    speed_limit_topic: str = "speed_limit"


@register_layer("SpeedFilter", nav2="nav2_costmap_2d::SpeedFilter")
class SpeedFilter(CostmapFilter):
    """Looks up speed limits; see the module docstring."""

    params_model = SpeedFilterParams
    params: SpeedFilterParams

    def __init__(self, name: str = "speed_filter",
                 params: SpeedFilterParams | None = None) -> None:
        super().__init__(name, params)
        self.filter_info = CostmapFilterInfo(type=SPEED_FILTER_PERCENT)
        self.current_speed_limit: tuple[float, bool] | None = None

    def _check_info(self, info: CostmapFilterInfo) -> None:
        if info.type not in (SPEED_FILTER_PERCENT, SPEED_FILTER_ABSOLUTE):
            raise ConfigError(
                f"speed filter '{self.name}' got filter type {info.type}",
                key_path=f"{self.name}.filter_info.type",
                suggestion=f"use {SPEED_FILTER_PERCENT} (percent of max speed) or "
                           f"{SPEED_FILTER_ABSOLUTE} (absolute m/s)")

    @property
    def percentage(self) -> bool:
        return self.filter_info.type == SPEED_FILTER_PERCENT

    def speed_limit_at(self, x: float, y: float) -> tuple[float, bool] | None:
        """``(limit, percentage)`` at costmap-frame ``(x, y)``, or ``None`` for no limit."""
        vals, inside = self.mask_values_at(np.array([[x, y]], dtype=np.float64))
        v = int(vals[0])
        if not inside[0] or v <= 0:  # off the mask, unknown (-1) or free (0): no limit
            return None
        limit = self.filter_info.base + self.filter_info.multiplier * v
        if self.percentage:
            if not 0.0 <= limit <= 100.0:
                return None
        elif limit < 0.0:
            return None
        return float(limit), self.percentage

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        """Look up the limit at the robot every cycle (it does not depend on the window)."""
        bounds = super().update_bounds(robot_x, robot_y, robot_yaw, bounds)
        if self.mask is not None:
            self.current_speed_limit = self.speed_limit_at(robot_x, robot_y)
        return bounds

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        self.current = True
