"""Bresenham ray tracing on a cost grid (Nav2 ``Costmap2D::raytraceLine``), numba.

Used by the obstacle layer to clear free space between a sensor and its returns.  A ray
starts ``min_length`` cells from the origin, runs along the Bresenham line towards the
end cell and stops after ``min(max_length, |major axis|)`` steps; the end cell itself is
*not* written (it holds the obstacle that ended the ray).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray


@numba.njit(cache=True)
def raytrace_lines(grid: NDArray[np.uint8], x0: int, y0: int, ends_x: NDArray[np.int64],
                   ends_y: NDArray[np.int64], max_length: float, min_length: float,
                   value: int) -> None:
    """Set the cells of every ray ``(x0, y0) -> (ends_x[k], ends_y[k])`` to ``value``.

    Lengths are in cells.  All end cells must lie inside ``grid`` (rows are y).
    """
    for k in range(ends_x.shape[0]):
        x1 = ends_x[k]
        y1 = ends_y[k]
        dx_full = x1 - x0
        dy_full = y1 - y0
        dist = math.hypot(dx_full, dy_full)
        if dist < min_length:
            continue
        if dist > 0.0:
            sx = int(x0 + dx_full / dist * min_length)
            sy = int(y0 + dy_full / dist * min_length)
        else:
            sx = x0
            sy = y0
        dx = x1 - sx
        dy = y1 - sy
        abs_dx = abs(dx)
        abs_dy = abs(dy)
        step_x = 1 if dx > 0 else (-1 if dx < 0 else 0)
        step_y = 1 if dy > 0 else (-1 if dy < 0 else 0)
        scale = 1.0 if dist == 0.0 else min(1.0, max_length / dist)
        x = sx
        y = sy
        if abs_dx >= abs_dy:
            err = abs_dx // 2
            end = min(int(scale * abs_dx), abs_dx)
            for _ in range(end):
                grid[y, x] = value
                x += step_x
                err += abs_dy
                if err >= abs_dx:
                    y += step_y
                    err -= abs_dx
        else:
            err = abs_dy // 2
            end = min(int(scale * abs_dy), abs_dy)
            for _ in range(end):
                grid[y, x] = value
                y += step_y
                err += abs_dx
                if err >= abs_dy:
                    x += step_x
                    err -= abs_dy


def clip_rays_to_map(ox: float, oy: float, wx: NDArray[np.float64], wy: NDArray[np.float64],
                     origin_x: float, origin_y: float, end_x: float, end_y: float
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Shorten rays from ``(ox, oy)`` so their ends lie on the map (Nav2 ``raytraceFreespace``).

    The origin must be inside the map; vectorised over the end points.
    """
    wx = wx.astype(np.float64, copy=True)
    wy = wy.astype(np.float64, copy=True)
    a = wx - ox
    b = wy - oy
    with np.errstate(divide="ignore", invalid="ignore"):
        m = wx < origin_x
        t = (origin_x - ox) / a[m]
        wx[m] = origin_x
        wy[m] = oy + b[m] * t
        m = wy < origin_y
        t = (origin_y - oy) / b[m]
        wx[m] = ox + a[m] * t
        wy[m] = origin_y
        m = wx > end_x
        t = (end_x - ox) / a[m]
        wx[m] = end_x - 0.001
        wy[m] = oy + b[m] * t
        m = wy > end_y
        t = (end_y - oy) / b[m]
        wx[m] = ox + a[m] * t
        wy[m] = end_y - 0.001
    return wx, wy
