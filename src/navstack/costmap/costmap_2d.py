"""Costmap2D: a uint8 cost grid with Nav2's cost values and map<->world conversions.

Cell ``(mx, my)`` is stored at ``data[my, mx]``; ``origin_x/origin_y`` is the world
position of the outer corner of cell (0, 0) in the costmap's ``frame_id``; the grid is
axis-aligned with that frame (Nav2 costmap_2d semantics).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FREE_SPACE = 0
MAX_NON_OBSTACLE = 252
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255


@dataclass
class Costmap2D:
    """A 2D cost grid.  ``data`` has shape ``(size_y, size_x)`` and dtype uint8."""

    size_x: int
    size_y: int
    resolution: float
    origin_x: float = 0.0
    origin_y: float = 0.0
    frame_id: str = "map"
    default_value: int = FREE_SPACE
    data: NDArray[np.uint8] = field(default=None)  # type: ignore[arg-type]

    def __post_init__(self) -> None:
        if self.size_x <= 0 or self.size_y <= 0:
            raise ValueError(f"costmap size must be positive, got {self.size_x}x{self.size_y}")
        if not self.resolution > 0.0:
            raise ValueError(f"costmap resolution must be positive, got {self.resolution}")
        if self.data is None:
            self.data = np.full((self.size_y, self.size_x), self.default_value, dtype=np.uint8)
        elif self.data.shape != (self.size_y, self.size_x) or self.data.dtype != np.uint8:
            raise ValueError(
                f"costmap data must be uint8 of shape {(self.size_y, self.size_x)}, "
                f"got {self.data.dtype} {self.data.shape}")

    @staticmethod
    def from_array(data: NDArray[np.uint8], resolution: float, origin_x: float = 0.0,
                   origin_y: float = 0.0, frame_id: str = "map") -> Costmap2D:
        arr = np.ascontiguousarray(data, dtype=np.uint8)
        return Costmap2D(arr.shape[1], arr.shape[0], resolution, origin_x, origin_y,
                         frame_id, data=arr)

    # --- geometry ------------------------------------------------------------------
    @property
    def size_x_m(self) -> float:
        return self.size_x * self.resolution

    @property
    def size_y_m(self) -> float:
        return self.size_y * self.resolution

    def world_to_map(self, wx: float, wy: float) -> tuple[int, int] | None:
        """Cell ``(mx, my)`` containing world point, or ``None`` if outside."""
        mx = math.floor((wx - self.origin_x) / self.resolution)
        my = math.floor((wy - self.origin_y) / self.resolution)
        if 0 <= mx < self.size_x and 0 <= my < self.size_y:
            return mx, my
        return None

    def world_to_map_array(self, xy: NDArray[np.float64]) -> tuple[NDArray[np.int64],
                                                                   NDArray[np.int64],
                                                                   NDArray[np.bool_]]:
        """Vectorised ``world_to_map`` for ``(N, 2)`` points: ``(mx, my, inside)``."""
        mx = np.floor((xy[:, 0] - self.origin_x) / self.resolution).astype(np.int64)
        my = np.floor((xy[:, 1] - self.origin_y) / self.resolution).astype(np.int64)
        inside = (mx >= 0) & (mx < self.size_x) & (my >= 0) & (my < self.size_y)
        return mx, my, inside

    def map_to_world(self, mx: float, my: float) -> tuple[float, float]:
        """World position of the centre of cell ``(mx, my)``."""
        return (self.origin_x + (mx + 0.5) * self.resolution,
                self.origin_y + (my + 0.5) * self.resolution)

    def cost_at_world(self, wx: float, wy: float) -> int:
        """Cost at a world point; ``NO_INFORMATION`` outside the grid."""
        cell = self.world_to_map(wx, wy)
        return NO_INFORMATION if cell is None else int(self.data[cell[1], cell[0]])

    # --- editing -------------------------------------------------------------------
    def reset(self, value: int | None = None) -> None:
        self.data.fill(self.default_value if value is None else value)

    def copy(self) -> Costmap2D:
        return Costmap2D(self.size_x, self.size_y, self.resolution, self.origin_x,
                         self.origin_y, self.frame_id, self.default_value, self.data.copy())

    def update_origin(self, new_origin_x: float, new_origin_y: float) -> None:
        """Move the window (rolling costmap), keeping overlapping cells in place in the world.

        The origin snaps to whole cells, as Nav2's ``Costmap2D::updateOrigin``.
        """
        cell_ox = math.floor((new_origin_x - self.origin_x) / self.resolution)
        cell_oy = math.floor((new_origin_y - self.origin_y) / self.resolution)
        if cell_ox == 0 and cell_oy == 0:
            return
        new = np.full_like(self.data, self.default_value)
        sx0, sx1 = max(0, cell_ox), min(self.size_x, self.size_x + cell_ox)
        sy0, sy1 = max(0, cell_oy), min(self.size_y, self.size_y + cell_oy)
        if sx0 < sx1 and sy0 < sy1:
            new[sy0 - cell_oy:sy1 - cell_oy, sx0 - cell_ox:sx1 - cell_ox] = \
                self.data[sy0:sy1, sx0:sx1]
        self.data = new
        self.origin_x += cell_ox * self.resolution
        self.origin_y += cell_oy * self.resolution

    def resize_map(self, size_x: int, size_y: int, resolution: float, origin_x: float,
                   origin_y: float, keep: bool = False) -> None:
        """Re-allocate the grid in place (Nav2 ``Costmap2D::resizeMap``); all cells reset,
        unless ``keep``: then, at an unchanged resolution with the origin moved by whole
        cells, the cells of the old grid keep their value where the two overlap (a map
        that grows must not leave the planner an all-unknown costmap until the next
        update).

        In place so that holders of this object (planners, controllers) see the new grid.
        """
        old = (self.data, self.origin_x, self.origin_y, self.resolution)
        if size_x <= 0 or size_y <= 0:
            raise ValueError(f"costmap size must be positive, got {size_x}x{size_y}")
        if not resolution > 0.0:
            raise ValueError(f"costmap resolution must be positive, got {resolution}")
        self.size_x, self.size_y, self.resolution = int(size_x), int(size_y), float(resolution)
        self.origin_x, self.origin_y = float(origin_x), float(origin_y)
        self.data = np.full((self.size_y, self.size_x), self.default_value, dtype=np.uint8)
        if keep:
            self.copy_overlap(*old)

    def copy_overlap(self, data: NDArray[np.uint8], origin_x: float, origin_y: float,
                     resolution: float) -> None:
        """Copy the cells of another grid (``data`` with that origin, same resolution,
        origin offset a whole number of cells) where it overlaps this one; otherwise do
        nothing."""
        if abs(resolution - self.resolution) > 1e-12:
            return
        fx = (origin_x - self.origin_x) / self.resolution
        fy = (origin_y - self.origin_y) / self.resolution
        dx, dy = round(fx), round(fy)
        if abs(fx - dx) > 1e-6 or abs(fy - dy) > 1e-6:
            return
        h, w = data.shape
        x0, y0 = max(0, dx), max(0, dy)
        x1, y1 = min(self.size_x, dx + w), min(self.size_y, dy + h)
        if x0 < x1 and y0 < y1:
            self.data[y0:y1, x0:x1] = data[y0 - dy:y1 - dy, x0 - dx:x1 - dx]

    def reset_map(self, x0: int, y0: int, xn: int, yn: int) -> None:
        """Set cells ``[x0, xn) x [y0, yn)`` to ``default_value`` (Nav2 ``resetMap``)."""
        self.data[max(0, y0):max(0, yn), max(0, x0):max(0, xn)] = self.default_value
