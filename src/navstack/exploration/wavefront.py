"""Path distances over the traversable cells: a wavefront (Dijkstra) from the robot.

Frontier exploration ranks frontiers by how far the robot must *drive* to them, not by
straight-line distance (a frontier on the other side of a wall is far).  The wavefront
is the planner's own 8-connected Dijkstra kernel
(:class:`~navstack.planning.grid_search.GridSearchWorkspace`, numba, unit weights, no
corner cutting) run until the open list empties, so the distance to every reachable cell
is exact for the 8-connected grid metric and unreachable cells stay ``inf``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from navstack.planning.grid_search import GridSearchWorkspace

BoolArray = NDArray[np.bool_]
FloatArray = NDArray[np.float64]

__all__ = ["Wavefront", "nearest_cell"]

_CHUNK = 1 << 30


def nearest_cell(mask: BoolArray, row: int, col: int,
                 max_distance_cells: float = math.inf) -> tuple[int, int] | None:
    """The ``mask`` cell nearest to ``(row, col)`` (Euclidean), or ``None`` if there is
    none within ``max_distance_cells``.  ``(row, col)`` itself when it is in ``mask``."""
    h, w = mask.shape
    if 0 <= row < h and 0 <= col < w and mask[row, col]:
        return row, col
    if not mask.any():
        return None
    r0, r1 = max(0, row - int(min(max_distance_cells, h + w)) - 1), h
    c0, c1 = max(0, col - int(min(max_distance_cells, h + w)) - 1), w
    if math.isfinite(max_distance_cells):
        r1 = min(h, row + int(max_distance_cells) + 2)
        c1 = min(w, col + int(max_distance_cells) + 2)
    window = mask[r0:r1, c0:c1]
    rr, cc = np.nonzero(window)
    if rr.size == 0:
        return None
    d2 = (rr + r0 - row) ** 2 + (cc + c0 - col) ** 2
    k = int(np.argmin(d2))
    if d2[k] > max_distance_cells ** 2:
        return None
    return int(rr[k] + r0), int(cc[k] + c0)


class Wavefront:
    """Reusable distance-field solver for grids of one shape.

    :meth:`distances` returns ``(H, W)`` path lengths [m] from a start cell through
    ``traversable`` cells (``inf`` where unreachable).  The workspace is allocated once
    per grid shape.
    """

    def __init__(self) -> None:
        self._ws: GridSearchWorkspace | None = None

    def _workspace(self, shape: tuple[int, int]) -> GridSearchWorkspace:
        h, w = shape
        if self._ws is None or (self._ws.height, self._ws.width) != (h, w):
            self._ws = GridSearchWorkspace(w, h)
        return self._ws

    def distances(self, traversable: BoolArray, start: tuple[int, int],
                  resolution: float) -> FloatArray:
        """Path length [m] from cell ``start`` (row, col) to every cell."""
        h, w = traversable.shape
        r, c = start
        out = np.full((h, w), np.inf)
        if not (0 <= r < h and 0 <= c < w and traversable[r, c]):
            return out
        ws = self._workspace((h, w))
        ws.load(traversable)
        ws.begin((c, r), None)
        ws.run(0.0, _CHUNK)
        closed = ws.closed_mask()
        g = ws.g.reshape(h + 2, w + 2)[1:-1, 1:-1]
        out[closed] = g[closed] * resolution
        return out

    def path_to(self, cell: tuple[int, int]) -> NDArray[np.int64]:
        """``(K, 2)`` (row, col) cells of the shortest path from the last
        :meth:`distances` start to ``cell`` (which it must have reached)."""
        ws = self._ws
        if ws is None or not ws.is_closed((cell[1], cell[0])):
            raise ValueError(f"cell {cell} was not reached by the last wavefront")
        xy = ws.cells_to((cell[1], cell[0]))
        return np.column_stack((xy[:, 1], xy[:, 0])).astype(np.int64)

    def distances_from_any(self, traversable: BoolArray, start: tuple[int, int],
                           resolution: float, max_offset_cells: float
                           ) -> tuple[FloatArray, tuple[int, int] | None, float]:
        """Like :meth:`distances` but from the traversable cell nearest to ``start`` when
        ``start`` itself is not traversable (a robot touching an obstacle, as
        explore_lite's ``nearestCell``); returns ``(distances, used start, offset [m])``.
        """
        cell = nearest_cell(traversable, start[0], start[1], max_offset_cells)
        if cell is None:
            return np.full(traversable.shape, np.inf), None, math.inf
        offset = math.hypot(cell[0] - start[0], cell[1] - start[1]) * resolution
        dist = self.distances(traversable, cell, resolution)
        if offset != 0.0:  # (adding 0.0 changes no value: skip the pass over the grid)
            dist += offset
        return dist, cell, offset


def min_over_neighbours(values: FloatArray) -> FloatArray:
    """Per cell, the minimum of ``values`` over its 8 neighbours (not itself)."""
    padded = np.pad(values, 1, constant_values=np.inf)
    h, w = values.shape
    out = np.full((h, w), np.inf)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == 0 and dc == 0:
                continue
            np.minimum(out, padded[1 + dr:1 + dr + h, 1 + dc:1 + dc + w], out=out)
    return out


@nb.njit(cache=True)
def _paint_boxes(out: BoolArray, rows: NDArray[np.int64], cols: NDArray[np.int64],
                 k: int) -> None:
    h, w = out.shape
    for i in range(rows.size):
        r0, r1 = max(rows[i] - k, 0), min(rows[i] + k + 1, h)
        c0, c1 = max(cols[i] - k, 0), min(cols[i] + k + 1, w)
        for r in range(r0, r1):
            for c in range(c0, c1):
                out[r, c] = True


def dilate(mask: BoolArray, cells: int) -> BoolArray:
    """``mask`` grown by ``cells`` (square structuring element): ``cells`` iterations of
    the 3 x 3 binary dilation, i.e. every cell within Chebyshev distance ``cells`` of a
    ``mask`` cell.  A sparse mask (frontier points, blacklist entries) paints a box
    around each cell instead of sweeping the whole grid ``cells`` times."""
    if cells <= 0:
        return mask.copy()
    rows, cols = np.nonzero(mask)
    if rows.size * (2 * cells + 1) ** 2 > 4 * mask.size:  # dense: sweep the grid
        return np.asarray(ndimage.binary_dilation(mask, np.ones((3, 3), bool),
                                                  iterations=cells))
    out = np.zeros(mask.shape, dtype=bool)
    _paint_boxes(out, rows.astype(np.int64), cols.astype(np.int64), int(cells))
    return out
