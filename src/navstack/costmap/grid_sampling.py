"""Nearest-cell lookup of world points in an OccupancyGrid-shaped raster.

Shared by the static layer (map in another resolution/origin/frame than the costmap) and
the costmap filters (masks).  A raster is ``values[row, col]`` with ``resolution`` and the
pose of cell (0, 0)'s outer corner (``MapMetaData.origin``, yaw honoured) in the raster's
frame; ``raster_in_costmap`` is the pose of that frame in the costmap frame (identity when
both are the same frame) - callers pass it explicitly instead of a TF lookup.
"""

from __future__ import annotations

import math

import numba
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


@numba.njit(cache=True)
def _sample_rotated(values: NDArray[np.generic], mres: float, ox: float, oy: float,
                    co: float, so: float, tx: float, ty: float, ct: float, st: float,
                    origin_x: float, origin_y: float, resolution: float, x0: int, y0: int,
                    out: NDArray[np.generic], inside: NDArray[np.bool_]) -> None:
    """Per window cell, the arithmetic of :func:`window_centres` + :func:`points_to_cells`
    (same operations in the same order, so the same cells), without temporaries."""
    height, width = values.shape
    for j in range(out.shape[0]):
        y = origin_y + (y0 + j + 0.5) * resolution
        for i in range(out.shape[1]):
            x = origin_x + (x0 + i + 0.5) * resolution
            dx, dy = x - tx, y - ty
            px, py = ct * dx + st * dy, -st * dx + ct * dy
            dx, dy = px - ox, py - oy
            col = math.floor((co * dx + so * dy) / mres)
            row = math.floor((-so * dx + co * dy) / mres)
            if 0 <= col < width and 0 <= row < height:
                out[j, i] = values[row, col]
                inside[j, i] = True


def sample_window(values: NDArray[np.uint8] | NDArray[np.int8], info: MapMetaData,
                  origin_x: float, origin_y: float, resolution: float,
                  window: tuple[int, int, int, int],
                  raster_in_costmap: Pose2D | None = None
                  ) -> tuple[NDArray[np.generic], NDArray[np.bool_]]:
    """Nearest raster value at each costmap cell centre of ``window`` = ``(x0, y0, x1, y1)``.

    Returns ``(values, inside)`` shaped like the window (rows are y); ``values`` is 0
    where the centre falls outside the raster.  When raster and costmap axes are parallel
    (no yaw in the raster origin nor in ``raster_in_costmap``) a cell's raster column
    depends on its x only and its row on its y only, so the indices are computed per
    column and per row of the window; otherwise a numba kernel walks the cells.  Both give
    exactly the cells :func:`points_to_cells` gives for the cell centres.
    """
    x0, y0, x1, y1 = window
    shape = (y1 - y0, x1 - x0)
    o = info.origin.to_pose2d()
    t = raster_in_costmap
    if o.theta == 0.0 and (t is None or t.theta == 0.0):
        xs = origin_x + (np.arange(x0, x1) + 0.5) * resolution
        ys = origin_y + (np.arange(y0, y1) + 0.5) * resolution
        if t is not None:
            xs, ys = xs - t.x, ys - t.y
        col = np.floor((xs - o.x) / info.resolution).astype(np.int64)
        row = np.floor((ys - o.y) / info.resolution).astype(np.int64)
        col_ok = (col >= 0) & (col < info.width)
        row_ok = (row >= 0) & (row < info.height)
        inside2 = row_ok[:, None] & col_ok[None, :]
        out2 = values[np.ix_(np.where(row_ok, row, 0), np.where(col_ok, col, 0))]
        return np.where(inside2, out2, np.zeros((), dtype=values.dtype)), inside2
    out = np.zeros(shape, dtype=values.dtype)
    inside = np.zeros(shape, dtype=np.bool_)
    if t is None:
        t = Pose2D(0.0, 0.0, 0.0)
    _sample_rotated(np.ascontiguousarray(values), float(info.resolution), o.x, o.y,
                    math.cos(o.theta), math.sin(o.theta), t.x, t.y, math.cos(t.theta),
                    math.sin(t.theta), float(origin_x), float(origin_y), float(resolution),
                    int(x0), int(y0), out, inside)
    return out, inside
