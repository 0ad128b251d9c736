"""Distance from any point to what an occupancy map explains (navstack).

A return the map explains lies on or near an occupied cell, or in space the map does not
know (unknown cells, or off the map): a wall, a door frame, or a wall a map being built
(SLAM) has not published yet.  Whatever lies further than a few centimetres from all of
those sits in space the map knows to be free: a person, a cart, a dropped box.  The
collision monitor's ``exclude_map_obstacles`` and the obstacle layer's
``unmapped_padding`` use this split (docs/command_path.md, "Clearance").
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from navstack.core.msgs import OccupancyGrid

__all__ = ["OCCUPIED_THRESHOLD", "MapDistance"]

FloatArray = NDArray[np.float64]

OCCUPIED_THRESHOLD = 65
"""Occupancy (0-100) from which a cell is occupied: map_server's ``occupied_thresh``
0.65."""


class MapDistance:
    """Distance [m] from every cell of the latest map to its nearest occupied
    (occupancy >= :data:`OCCUPIED_THRESHOLD`) or unknown (-1) cell; outside the map: 0
    (unknown).  :meth:`at` is ``inf`` everywhere for a map with neither."""

    def __init__(self) -> None:
        self.distance: FloatArray | None = None
        self.grid: OccupancyGrid | None = None

    def update(self, grid: OccupancyGrid) -> None:
        info = grid.info
        data = np.asarray(grid.data).reshape(info.height, info.width)
        explained = (data >= OCCUPIED_THRESHOLD) | (data < 0)
        self.grid = grid
        self.distance = (np.asarray(ndimage.distance_transform_edt(~explained),
                                    dtype=np.float64) * info.resolution
                         if explained.any() else np.full(explained.shape, np.inf))

    def at(self, xy_map: FloatArray) -> FloatArray:
        """Distances for ``(N, 2)`` points in the map's frame (``update`` first)."""
        if self.grid is None or self.distance is None:
            raise RuntimeError("MapDistance.at before update: no map yet")
        info = self.grid.info
        o = info.origin.to_pose2d()
        c, s = math.cos(o.theta), math.sin(o.theta)
        dx, dy = xy_map[:, 0] - o.x, xy_map[:, 1] - o.y
        col = np.floor((c * dx + s * dy) / info.resolution).astype(np.int64)
        row = np.floor((-s * dx + c * dy) / info.resolution).astype(np.int64)
        h, w = self.distance.shape
        inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
        out = np.zeros(len(xy_map))
        out[inside] = self.distance[row[inside], col[inside]]
        return out
