"""Shared builders for costmap tests."""

from __future__ import annotations

import math

import numpy as np

from navstack.core.msgs import Header, LaserScan, MapMetaData, OccupancyGrid, Point, Pose


def grid(values: np.ndarray, resolution: float, origin: tuple[float, float] = (0.0, 0.0),
         frame: str = "map") -> OccupancyGrid:
    v = np.asarray(values, dtype=np.int8)
    info = MapMetaData(0.0, resolution, v.shape[1], v.shape[0],
                       Pose(Point(origin[0], origin[1], 0.0)))
    return OccupancyGrid(Header(0.0, frame), info, v)


def scan(ranges: list[float], angle_min: float = 0.0, increment: float = 0.1,
         stamp: float = 0.0, range_max: float = 20.0) -> LaserScan:
    r = np.asarray(ranges, dtype=np.float32)
    return LaserScan(Header(stamp, "laser"), angle_min,
                     angle_min + increment * max(len(r) - 1, 0), increment, 0.0, 0.1, 0.05,
                     range_max, r)


def inflation_cost(d: float, inscribed: float, k: float) -> int:
    """Nav2's formula, written out independently of the implementation."""
    if d == 0.0:
        return 254
    if d <= inscribed:
        return 253
    return int(252 * math.exp(-k * (d - inscribed)))
