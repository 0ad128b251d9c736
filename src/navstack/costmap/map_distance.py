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

TRANSFORM_AFTER_LOOKUPS = 4.0
"""Cells looked at by :meth:`MapDistance.beyond`'s discs, per map cell, after which the
whole-map transform is cheaper (the transform costs about as much per map cell as four
to five single-cell lookups through numpy's fancy indexing)."""

OCCUPIED_THRESHOLD = 65
"""Occupancy (0-100) from which a cell is occupied: map_server's ``occupied_thresh``
0.65."""


class MapDistance:
    """Distance [m] from every cell of the latest map to its nearest occupied
    (occupancy >= :data:`OCCUPIED_THRESHOLD`) or unknown (-1) cell; outside the map: 0
    (unknown).  :meth:`at` is ``inf`` everywhere for a map with neither.

    :meth:`update` only stores the map: the whole-map distance transform (:attr:`distance`)
    is computed when first asked for, and :meth:`beyond` -- the question both users ask,
    "is this point farther than d from what the map explains?" -- looks only at the cells
    within d of each point, with the same comparison as ``at(xy) > d``.  A SLAM map is
    republished every 0.5 s: the transform of a 40 x 30 m map on every one was 30 % of a
    warehouse exploration's CPU time.  On a map that stays (a static map server's), the
    disc lookups add up: once they have looked at more cells than
    :data:`TRANSFORM_AFTER_LOOKUPS` times the map holds, the transform is computed once and
    answers every later point with one lookup until the next :meth:`update`."""

    def __init__(self) -> None:
        self.grid: OccupancyGrid | None = None
        self._distance: FloatArray | None = None
        self._explained: NDArray[np.bool_] | None = None
        self._offsets: tuple[float, float, NDArray[np.int64]] | None = None
        self._lookups = 0

    def update(self, grid: OccupancyGrid) -> None:
        self.grid = grid
        self._distance = None
        self._explained = None
        self._lookups = 0

    @property
    def explained(self) -> NDArray[np.bool_]:
        """``(H, W)`` occupied or unknown cells of the latest map (``update`` first)."""
        if self.grid is None:
            raise RuntimeError("MapDistance.explained before update: no map yet")
        if self._explained is None:
            info = self.grid.info
            data = np.asarray(self.grid.data).reshape(info.height, info.width)
            self._explained = (data >= OCCUPIED_THRESHOLD) | (data < 0)
        return self._explained

    @property
    def distance(self) -> FloatArray | None:
        """``(H, W)`` distance [m] of every cell to the nearest explained cell (``None``
        before the first map)."""
        if self.grid is None:
            return None
        if self._distance is None:
            explained = self.explained
            self._distance = (np.asarray(ndimage.distance_transform_edt(~explained),
                                         dtype=np.float64) * self.grid.info.resolution
                              if explained.any() else np.full(explained.shape, np.inf))
        return self._distance

    def _cells(self, xy_map: FloatArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        assert self.grid is not None
        info = self.grid.info
        o = info.origin.to_pose2d()
        c, s = math.cos(o.theta), math.sin(o.theta)
        dx, dy = xy_map[:, 0] - o.x, xy_map[:, 1] - o.y
        col = np.floor((c * dx + s * dy) / info.resolution).astype(np.int64)
        row = np.floor((-s * dx + c * dy) / info.resolution).astype(np.int64)
        return row, col

    def at(self, xy_map: FloatArray) -> FloatArray:
        """Distances for ``(N, 2)`` points in the map's frame (``update`` first)."""
        distance = self.distance
        if distance is None:
            raise RuntimeError("MapDistance.at before update: no map yet")
        row, col = self._cells(xy_map)
        h, w = distance.shape
        inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
        out = np.zeros(len(xy_map))
        out[inside] = distance[row[inside], col[inside]]
        return out

    def beyond(self, xy_map: FloatArray, d: float) -> NDArray[np.bool_]:
        """``at(xy_map) > d`` without the whole-map transform: a point is beyond when no
        explained cell lies within ``d`` of its cell (cell-centre distances, as the
        transform measures them) and its cell is on the map.  Once the discs have looked at
        :data:`TRANSFORM_AFTER_LOOKUPS` x the map's cells since the last map, the
        transform is computed and used instead (the same answer)."""
        if self.grid is None:
            raise RuntimeError("MapDistance.beyond before update: no map yet")
        if d < 0.0:  # every distance is >= 0
            return np.ones(len(xy_map), dtype=bool)
        if self._distance is not None:
            return self.at(xy_map) > d
        res = self.grid.info.resolution
        if self._offsets is None or self._offsets[:2] != (d, res):
            k = int(d / res) + 1
            dr, dc = np.mgrid[-k:k + 1, -k:k + 1]
            near = np.sqrt((dr * dr + dc * dc).astype(np.float64)) * res <= d
            self._offsets = (d, res, np.column_stack((dr[near], dc[near])).astype(np.int64))
        offsets = self._offsets[2]
        explained = self.explained
        h, w = explained.shape
        self._lookups += len(xy_map) * len(offsets)
        if self._lookups > TRANSFORM_AFTER_LOOKUPS * h * w:
            return self.at(xy_map) > d
        row, col = self._cells(xy_map)
        inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
        out = np.zeros(len(xy_map), dtype=bool)
        if not inside.any():
            return out
        rr = row[inside, None] + offsets[None, :, 0]
        cc = col[inside, None] + offsets[None, :, 1]
        ok = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
        hit = np.zeros(rr.shape, dtype=bool)
        hit[ok] = explained[rr[ok], cc[ok]]
        out[inside] = ~hit.any(axis=1)
        return out
