"""Coverage search of a known map (the TurtleBot course's package search).

The course split the known map into 0.8 m cells, kept a cell only when the box of +-3
map cells around its centre was free, visited the cells facing one common direction
(the camera sees the same way everywhere) and returned home.  Here:

* :func:`coverage_cells` -- the split and the free-box filter, on any boolean free mask
  (cells aligned to the map origin, ``cell_size`` square, box of ``2 * box_cells + 1``
  map cells);
* :func:`path_distances` -- path lengths between the start and every cell centre over
  the traversable cells (one wavefront per point, the planner's kernel); cells no path
  reaches are reported, not visited;
* :func:`order_visits` -- the visiting order: nearest neighbour from the start, then
  2-opt (Croes 1958) on the closed tour start -> cells -> start, with path lengths, not
  straight lines (a cell behind a wall is far).  2-opt is numba.
"""

from __future__ import annotations

import itertools
import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.exploration.grid_view import BoolArray, FloatArray
from navstack.exploration.wavefront import Wavefront, nearest_cell

__all__ = ["coverage_cells", "order_visits", "path_distances", "tour_length"]


def coverage_cells(free: BoolArray, resolution: float, origin_x: float = 0.0,
                   origin_y: float = 0.0, cell_size: float = 0.8,
                   box_cells: int = 3) -> FloatArray:
    """Centres ``(N, 2)`` [m] of the ``cell_size`` squares whose centre's box of
    ``+-box_cells`` map cells is entirely ``free`` (row-major order, y then x)."""
    h, w = free.shape
    nx = math.floor(w * resolution / cell_size + 1e-9)
    ny = math.floor(h * resolution / cell_size + 1e-9)
    if nx == 0 or ny == 0:
        return np.zeros((0, 2))
    cx = (np.arange(nx) + 0.5) * cell_size
    cy = (np.arange(ny) + 0.5) * cell_size
    gx, gy = np.meshgrid(cx, cy)
    cols = np.floor(gx / resolution).astype(np.int64).ravel()
    rows = np.floor(gy / resolution).astype(np.int64).ravel()
    # box sums of the free mask with an integral image
    k = box_cells
    integral = np.zeros((h + 1, w + 1), dtype=np.int64)
    integral[1:, 1:] = np.cumsum(np.cumsum(free, axis=0), axis=1)
    r0, r1 = rows - k, rows + k + 1
    c0, c1 = cols - k, cols + k + 1
    inside = (r0 >= 0) & (c0 >= 0) & (r1 <= h) & (c1 <= w)
    r0, r1, c0, c1 = (np.clip(a, 0, lim) for a, lim in ((r0, h), (r1, h), (c0, w), (c1, w)))
    total = integral[r1, c1] - integral[r0, c1] - integral[r1, c0] + integral[r0, c0]
    ok = inside & (total == (2 * k + 1) ** 2)
    return np.column_stack((origin_x + gx.ravel()[ok], origin_y + gy.ravel()[ok]))


def path_distances(traversable: BoolArray, resolution: float, origin_x: float,
                   origin_y: float, points: FloatArray, snap_radius: float = 0.3,
                   wavefront: Wavefront | None = None) -> FloatArray:
    """``(N, N)`` path lengths [m] between ``points`` over ``traversable`` cells.

    A point off the traversable cells is snapped to the nearest one within
    ``snap_radius`` [m] (plus that offset); ``inf`` where no path exists.
    """
    wf = wavefront or Wavefront()
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = len(pts)
    cells: list[tuple[int, int] | None] = []
    offsets = np.zeros(n)
    for i, (x, y) in enumerate(pts):
        r = math.floor((y - origin_y) / resolution)
        c = math.floor((x - origin_x) / resolution)
        cell = nearest_cell(traversable, r, c, snap_radius / resolution)
        cells.append(cell)
        if cell is not None:
            offsets[i] = math.hypot(cell[0] - r, cell[1] - c) * resolution
    out = np.full((n, n), np.inf)
    valid = [i for i in range(n) if cells[i] is not None]
    rows = np.array([cells[i][0] for i in valid], dtype=np.int64)  # type: ignore[index]
    cols = np.array([cells[i][1] for i in valid], dtype=np.int64)  # type: ignore[index]
    for i in valid:
        cell = cells[i]
        assert cell is not None
        dist = wf.distances(traversable, cell, resolution)
        out[i, valid] = dist[rows, cols] + offsets[i] + offsets[valid]
    np.fill_diagonal(out, 0.0)
    return np.minimum(out, out.T)


def tour_length(dist: FloatArray, order: list[int] | NDArray[np.int64],
                closed: bool = True) -> float:
    idx = list(order) + ([order[0]] if closed and len(order) else [])
    return float(sum(dist[a, b] for a, b in itertools.pairwise(idx)))


@nb.njit(cache=True)
def _two_opt(dist: NDArray[np.float64], tour: NDArray[np.int64]) -> NDArray[np.int64]:
    """2-opt on a closed tour whose first element is fixed (tour[0] = start)."""
    n = tour.size
    improved = True
    while improved:
        improved = False
        for i in range(1, n - 1):
            a, b = tour[i - 1], tour[i]
            for j in range(i + 1, n):
                c = tour[j]
                d = tour[(j + 1) % n]
                delta = dist[a, c] + dist[b, d] - dist[a, b] - dist[c, d]
                if delta < -1e-9:
                    tour[i:j + 1] = tour[i:j + 1][::-1].copy()
                    improved = True
                    b = tour[i]
    return tour


def order_visits(dist: FloatArray, start: int = 0) -> list[int]:
    """Visiting order of every node reachable from ``start`` (finite distances): nearest
    neighbour, then 2-opt on the closed tour back to ``start``.  Returns the node
    indices after ``start``, in order (``start`` itself excluded)."""
    d = np.asarray(dist, dtype=np.float64)
    n = d.shape[0]
    reachable = [i for i in range(n) if i != start and math.isfinite(d[start, i])]
    if not reachable:
        return []
    todo = set(reachable)
    tour = [start]
    while todo:
        last = tour[-1]
        nxt = min(todo, key=lambda j: (d[last, j], j))
        tour.append(nxt)
        todo.remove(nxt)
    sub = np.array(tour, dtype=np.int64)
    finite = np.where(np.isfinite(d), d, 1e9)
    out = _two_opt(np.ascontiguousarray(finite), sub.copy())
    return [int(i) for i in out[1:]]
