"""Nearest-cell lookup of world points in an OccupancyGrid-shaped raster.

Shared by the static layer (map in another resolution/origin/frame than the costmap) and
the costmap filters (masks).  A raster is ``values[row, col]`` with ``resolution`` and the
pose of cell (0, 0)'s outer corner (``MapMetaData.origin``, yaw honoured) in the raster's
frame; ``raster_in_costmap`` is the pose of that frame in the costmap frame (identity when
both are the same frame) - callers pass it explicitly instead of a TF lookup.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import MapMetaData, Pose2D


def points_to_cells(xy: NDArray[np.float64], info: MapMetaData,
                    raster_in_costmap: Pose2D | None = None
                    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]:
    """``(col, row, inside)`` of the raster cells containing costmap-frame points ``(N, 2)``."""
    x = xy[:, 0]
    y = xy[:, 1]
    if raster_in_costmap is not None:
        t = raster_in_costmap
        c, s = math.cos(t.theta), math.sin(t.theta)
        dx, dy = x - t.x, y - t.y
        x, y = c * dx + s * dy, -s * dx + c * dy
    o = info.origin.to_pose2d()
    c, s = math.cos(o.theta), math.sin(o.theta)
    dx, dy = x - o.x, y - o.y
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    col = np.floor(lx / info.resolution).astype(np.int64)
    row = np.floor(ly / info.resolution).astype(np.int64)
    inside = (col >= 0) & (col < info.width) & (row >= 0) & (row < info.height)
    return col, row, inside


def window_centres(origin_x: float, origin_y: float, resolution: float, x0: int, y0: int,
                   x1: int, y1: int) -> NDArray[np.float64]:
    """World centres of cells ``[x0, x1) x [y0, y1)`` of a costmap, row-major ``(N, 2)``."""
    xs = origin_x + (np.arange(x0, x1) + 0.5) * resolution
    ys = origin_y + (np.arange(y0, y1) + 0.5) * resolution
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack((gx.ravel(), gy.ravel()))


def sample_window(values: NDArray[np.uint8] | NDArray[np.int8], info: MapMetaData,
                  origin_x: float, origin_y: float, resolution: float,
                  window: tuple[int, int, int, int],
                  raster_in_costmap: Pose2D | None = None
                  ) -> tuple[NDArray[np.generic], NDArray[np.bool_]]:
    """Nearest raster value at each costmap cell centre of ``window`` = ``(x0, y0, x1, y1)``.

    Returns ``(values, inside)`` shaped like the window (rows are y); ``values`` is 0
    where the centre falls outside the raster.
    """
    x0, y0, x1, y1 = window
    pts = window_centres(origin_x, origin_y, resolution, x0, y0, x1, y1)
    col, row, inside = points_to_cells(pts, info, raster_in_costmap)
    out = np.zeros(len(pts), dtype=values.dtype)
    out[inside] = values[row[inside], col[inside]]
    shape = (y1 - y0, x1 - x0)
    return out.reshape(shape), inside.reshape(shape)
