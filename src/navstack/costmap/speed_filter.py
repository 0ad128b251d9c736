"""Speed filter (Nav2 ``nav2_costmap_2d::SpeedFilter``): speed limits from a mask.

The raw mask value ``v`` under a point gives, with the filter info's ``base`` and
``multiplier``, ``speed_limit = base + multiplier * v`` (Nav2 ``getSpeedLimitAtPose``):

* filter type ``SPEED_FILTER_PERCENT`` (1): a percentage of the maximum speed, valid in
  ``[0, 100]``; ``SPEED_FILTER_ABSOLUTE`` (2): metres per second, valid when ``>= 0``;
* ``v == 0`` means no limit (:data:`NO_SPEED_LIMIT`, 0.0), as does an out-of-range result
  (Nav2 warns and publishes "no limit");
* ``v == -1`` (unknown) and points off the mask cannot be read: the lookup *fails*, and
  the filter keeps its previous limit (Nav2 logs an error and returns).

Each update (``update_bounds``, so the limit is refreshed whatever window the other
layers touched) sets :attr:`SpeedFilter.speed_limit` for the robot pose; when it differs
from the last one announced, :meth:`SpeedFilter.pop_speed_limit` hands it out once, as
Nav2 publishes a ``nav2_msgs/SpeedLimit`` only on change.

Path lookahead (Nav2 Kilted/Rolling ``enable_path_lookahead``): Nav2 applies the limit at
the robot's pose, so a fast vehicle enters a slow zone at speed and brakes inside it.
With lookahead the filter also samples the plan (:meth:`SpeedFilter.set_path`, costmap
frame) from the pose closest to the robot up to ``d = v^2 / (2 |max_decel|)`` along it,
clamped to ``[min_lookahead, max_lookahead]`` (``max_lookahead`` when ``max_decel >= 0``),
with ``v`` the robot's speed (:meth:`SpeedFilter.set_robot_speed`); the limit is the
lowest one found at the robot or on that stretch.  While a lower limit lies ahead the
lookahead distance is held so it cannot shrink as the robot slows down.  Here a failed
lookup at the robot gives "no limit" and failed path poses are skipped, as in Nav2.
The filter never changes costs.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, ValidationInfo, field_validator

from navstack.core.errors import ConfigError
from navstack.core.msgs import CostmapFilterInfo
from navstack.costmap.costmap_2d import Costmap2D
from navstack.costmap.costmap_filter import (
    FILTER_TYPES,
    SPEED_FILTER_ABSOLUTE,
    SPEED_FILTER_PERCENT,
    CostmapFilter,
    CostmapFilterParams,
    filter_values,
)
from navstack.costmap.layer import Bounds, CellWindow, register_layer

NO_SPEED_LIMIT = 0.0
"""Nav2 ``NO_SPEED_LIMIT``: a SpeedLimit of 0 restores the controller's own maxima."""


class SpeedFilterParams(CostmapFilterParams):
    """Nav2 SpeedFilter parameters (the lookahead ones are Nav2 Kilted's)."""

    speed_limit_topic: str = "speed_limit"
    enable_path_lookahead: bool = False
    max_decel: float = Field(-0.5, description="[m/s^2], negative")
    min_lookahead: float = Field(0.3, ge=0.0, description="[m]")
    max_lookahead: float = Field(5.0, ge=0.0, description="[m]")
    path_topic: str = "plan"
    odom_topic: str = "odom"

    @field_validator("max_lookahead")
    @classmethod
    def _max_not_below_min(cls, value: float, info: ValidationInfo) -> float:
        low = info.data.get("min_lookahead")
        if low is not None and value < low:
            raise ValueError(f"max_lookahead must be >= min_lookahead ({low})")
        return value


def lookahead_distance(speed: float, max_decel: float, min_lookahead: float,
                       max_lookahead: float) -> float:
    """Braking distance ``v^2 / (2 |max_decel|)`` clamped to the lookahead range
    (``max_lookahead`` when ``max_decel >= 0``, as Nav2 does)."""
    if max_decel >= 0.0:
        return max_lookahead
    d = speed * speed / (2.0 * abs(max_decel))
    return min(max(d, min_lookahead), max_lookahead)


def closest_segment(path_xy: NDArray[np.float64], x: float, y: float, start: int = 0) -> int:
    """Index ``i >= start`` of the path segment ``[i, i+1]`` closest to ``(x, y)``
    (Nav2 ``distance_from_path``); 0 for a path of one pose."""
    n = len(path_xy)
    if n < 2:
        return 0
    start = min(max(start, 0), n - 2)
    a = path_xy[start:-1]
    d = path_xy[start + 1:] - a
    seg2 = np.einsum("ij,ij->i", d, d)
    p = np.array([x, y]) - a
    t = np.where(seg2 > 0.0, np.einsum("ij,ij->i", p, d) / np.where(seg2 > 0.0, seg2, 1.0),
                 0.0)
    t = np.clip(t, 0.0, 1.0)
    q = a + d * t[:, None]
    dist2 = np.sum((q - np.array([x, y])) ** 2, axis=1)
    return start + int(np.argmin(dist2))


@register_layer("SpeedFilter", nav2="nav2_costmap_2d::SpeedFilter")
class SpeedFilter(CostmapFilter):
    """Looks up speed limits; see the module docstring."""

    params_model = SpeedFilterParams
    params: SpeedFilterParams
    accepted_types = (SPEED_FILTER_PERCENT, SPEED_FILTER_ABSOLUTE)

    def __init__(self, name: str = "speed_filter",
                 params: SpeedFilterParams | None = None) -> None:
        super().__init__(name, params)
        self.filter_info = CostmapFilterInfo(type=SPEED_FILTER_PERCENT)
        self.speed_limit = NO_SPEED_LIMIT
        """The limit at the last update (Nav2 ``speed_limit_``; 0 = none)."""
        self._announced = NO_SPEED_LIMIT
        self._pending: tuple[float, bool] | None = None
        self.path_xy: NDArray[np.float64] | None = None
        self.robot_speed = 0.0
        self.lookahead_point: tuple[float, float] | None = None
        """End of the stretch of plan the last lookahead sampled (costmap frame)."""
        self._held = 0.0
        self._start = 0

    def check_filter_info(self, info: CostmapFilterInfo, *, file: str = "",
                          key_path: str = "") -> None:
        if info.type not in self.accepted_types:
            raise ConfigError(
                f"speed filter '{self.name}' got filter type {info.type} "
                f"({FILTER_TYPES.get(info.type, 'unknown')})", file=file,
                key_path=f"{key_path or self.name + '.filter_info'}.type",
                suggestion=f"use {SPEED_FILTER_PERCENT} (percent of max speed) or "
                           f"{SPEED_FILTER_ABSOLUTE} (absolute m/s)")

    @property
    def percentage(self) -> bool:
        return self.filter_info.type == SPEED_FILTER_PERCENT

    # --- lookups -----------------------------------------------------------------------
    def limits_at(self, xy: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                           NDArray[np.bool_]]:
        """Limits at costmap-frame points ``(N, 2)`` and whether each could be read.

        A readable point gives :data:`NO_SPEED_LIMIT` (mask 0 or a limit out of range) or
        the limit; an unknown cell or a point off the mask is not readable."""
        vals, inside = self.mask_values_at(np.asarray(xy, dtype=np.float64).reshape(-1, 2))
        ok = inside & (vals >= 0)
        limit = filter_values(vals, self.filter_info)
        top = 100.0 if self.percentage else np.inf
        bad = (limit < 0.0) | (limit > top)
        limit = np.where((vals == 0) | bad | ~ok, NO_SPEED_LIMIT, limit)
        return limit, ok

    def speed_limit_at(self, x: float, y: float) -> float | None:
        """The limit at costmap-frame ``(x, y)`` (0 = no limit), ``None`` if unreadable."""
        limit, ok = self.limits_at(np.array([[x, y]], dtype=np.float64))
        return float(limit[0]) if ok[0] else None

    # --- inputs for the lookahead --------------------------------------------------------
    def set_path(self, path_xy: NDArray[np.float64] | None) -> None:
        """The plan ``(N, 2)`` in the costmap frame (``None``: no plan)."""
        if path_xy is None or len(path_xy) == 0:
            self.path_xy = None
        else:
            self.path_xy = np.asarray(path_xy, dtype=np.float64)[:, :2]
        self._start = 0

    def set_robot_speed(self, speed: float) -> None:
        """The robot's (smoothed) linear speed [m/s]."""
        self.robot_speed = abs(float(speed))

    def lookahead_distance(self) -> float:
        p = self.params
        d = lookahead_distance(self.robot_speed, p.max_decel, p.min_lookahead,
                               p.max_lookahead)
        return max(d, self._held) if p.max_decel < 0.0 else d

    # --- update ------------------------------------------------------------------------
    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        """Look up the limit at the robot every cycle (it does not depend on the window)."""
        bounds = super().update_bounds(robot_x, robot_y, robot_yaw, bounds)
        if self.mask is None:
            return bounds
        if self.params.enable_path_lookahead and self.path_xy is not None:
            limit: float | None = self._lookahead_limit(robot_x, robot_y)
        else:
            limit = self.speed_limit_at(robot_x, robot_y)
        if limit is None:  # unreadable cell: keep the previous limit (Nav2)
            return bounds
        self.speed_limit = limit
        if limit != self._announced:
            self._announced = limit
            self._pending = (limit, self.percentage)
        return bounds

    def _lookahead_limit(self, x: float, y: float) -> float:
        """Nav2 ``getSpeedLimitFromLookahead``."""
        assert self.path_xy is not None
        distance = self.lookahead_distance()
        self._held = 0.0
        path = self.path_xy
        self._start = closest_segment(path, x, y, self._start)
        self.lookahead_point = (x, y)
        at_robot = self.speed_limit_at(x, y)
        if at_robot is None:
            return NO_SPEED_LIMIT
        ahead = path[self._start:]
        steps = np.hypot(*np.diff(ahead, axis=0).T) if len(ahead) > 1 else np.zeros(0)
        along = np.concatenate(([0.0], np.cumsum(steps)))
        reach = int(np.searchsorted(along, distance, side="right"))
        stretch = ahead[:reach]
        found = [at_robot] if at_robot != NO_SPEED_LIMIT else []
        if len(stretch):
            self.lookahead_point = (float(stretch[-1, 0]), float(stretch[-1, 1]))
            limits, ok = self.limits_at(stretch)
            found += limits[ok & (limits != NO_SPEED_LIMIT)].tolist()
        lowest = min(found) if found else NO_SPEED_LIMIT
        if at_robot != lowest:
            self._held = distance
        return float(lowest)

    def pop_speed_limit(self) -> tuple[float, bool] | None:
        """``(speed_limit, percentage)`` if the limit changed since the last call (the
        SpeedLimit message Nav2 would publish now), else ``None``."""
        pending, self._pending = self._pending, None
        return pending

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        self.current = True
