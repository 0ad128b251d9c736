"""``GridView``: what exploration needs to know about a map, as boolean rasters.

Exploration reads an occupancy grid -- the global costmap as Nav2 publishes it
(``nav_msgs/OccupancyGrid``: 0..100 scaled costs, -1 unknown), or a SLAM map (0 free,
100 occupied, -1 unknown) -- and classifies every cell:

* ``unknown``: never observed (-1);
* ``free``: observed and below ``occupied_threshold`` (frontiers border these);
* ``traversable``: observed and below ``lethal_threshold``, i.e. a cell the robot's
  *centre* may occupy.  On the costmap topic the inscribed band is 99..100 (costs
  250..254), so the default 99 keeps the robot's own footprint out of walls; a raw SLAM
  map has no inflation, so :meth:`GridView.from_occupancy` can dilate its obstacles by
  the robot's inscribed radius instead (``inflate_radius``).

Row ``r``, column ``c`` is the cell whose lower-left corner is at ``origin +
(c, r) * resolution`` (``OccupancyGrid`` layout, rows along +y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from navstack.core.errors import NavstackError
from navstack.core.msgs import OccupancyGrid

BoolArray = NDArray[np.bool_]
FloatArray = NDArray[np.float64]

__all__ = ["ExplorationError", "GridView"]


class ExplorationError(NavstackError):
    """Exploration cannot proceed with the input given (names what is wrong)."""


@dataclass(frozen=True)
class GridView:
    """Boolean classification of an occupancy grid (see module docstring)."""

    unknown: BoolArray
    free: BoolArray
    traversable: BoolArray
    resolution: float
    origin_x: float = 0.0
    origin_y: float = 0.0
    stamp: float = 0.0

    def __post_init__(self) -> None:
        shape = self.unknown.shape
        if len(shape) != 2 or 0 in shape:
            raise ExplorationError(f"grid must be a non-empty 2-D array, got shape {shape}")
        if self.free.shape != shape or self.traversable.shape != shape:
            raise ExplorationError(f"unknown {shape}, free {self.free.shape} and traversable "
                                   f"{self.traversable.shape} masks must have one shape")
        if not self.resolution > 0.0:
            raise ExplorationError(f"resolution must be positive, got {self.resolution}")

    @classmethod
    def from_occupancy(cls, grid: OccupancyGrid, *, occupied_threshold: int = 65,
                       lethal_threshold: int = 99, inflate_radius: float = 0.0) -> GridView:
        """Classify ``grid`` (values -1, 0..100).  ``occupied_threshold``: a cell at or
        above it is an obstacle (map_server's 0.65); ``lethal_threshold``: at or above it
        the robot centre may not go; ``inflate_radius`` [m]: also keep the centre this far
        from obstacles (for raw maps without a costmap's inflation)."""
        info = grid.info
        data = np.asarray(grid.data, dtype=np.int16).reshape(info.height, info.width)
        unknown = data < 0
        occupied = data >= occupied_threshold
        free = ~unknown & ~occupied
        traversable = ~unknown & (data < lethal_threshold)
        if inflate_radius > 0.0 and occupied.any():
            dist = ndimage.distance_transform_edt(~occupied, sampling=info.resolution)
            traversable &= dist > inflate_radius
        o = info.origin.position
        return cls(unknown, free, traversable, info.resolution, o.x, o.y, grid.header.stamp)

    @classmethod
    def from_truth(cls, occupied: BoolArray, observed: BoolArray, resolution: float,
                   origin_x: float, origin_y: float, inscribed_radius: float) -> GridView:
        """A view of a true occupancy raster of which only ``observed`` cells are known
        (the idealised explorer of the benchmark): traversable = observed free cells
        farther than ``inscribed_radius`` from every occupied cell."""
        free = observed & ~occupied
        dist = ndimage.distance_transform_edt(~(occupied & observed), sampling=resolution)
        return cls(~observed, free, free & (dist > inscribed_radius), resolution,
                   origin_x, origin_y)

    # --- geometry --------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.unknown.shape[0]), int(self.unknown.shape[1]))

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """``(row, col)`` of the cell containing ``(x, y)`` (may be outside the grid)."""
        return (math.floor((y - self.origin_y) / self.resolution),
                math.floor((x - self.origin_x) / self.resolution))

    def inside(self, row: int, col: int) -> bool:
        h, w = self.shape
        return 0 <= row < h and 0 <= col < w

    def centre_of(self, row: float, col: float) -> tuple[float, float]:
        """World ``(x, y)`` of the centre of cell ``(row, col)``."""
        return (self.origin_x + (col + 0.5) * self.resolution,
                self.origin_y + (row + 0.5) * self.resolution)

    def centres(self, rows: NDArray[np.integer], cols: NDArray[np.integer]) -> FloatArray:
        """``(N, 2)`` world centres of cells ``rows``, ``cols``."""
        return np.column_stack((self.origin_x + (np.asarray(cols) + 0.5) * self.resolution,
                                self.origin_y + (np.asarray(rows) + 0.5) * self.resolution))

    @property
    def known_fraction(self) -> float:
        return float(1.0 - self.unknown.mean())
