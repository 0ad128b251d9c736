"""Hybrid-A* heuristics: obstacle (2D Dijkstra) and distance (Dubins/RS lookup table).

Nav2 ``NodeHybrid::getHeuristicCost`` returns ``max(obstacle, distance)``:

* **Obstacle heuristic** (``ObstacleHeuristic``): a cost-aware 8-connected Dijkstra from
  the goal over the costmap, on a 2x downsampled grid (each coarse cell takes the
  cheapest of its 2x2 cells; Nav2 ``downsample_obstacle_heuristic``) whose values are
  doubled back to full cells.  A step costs ``length * (1 + cost_penalty * cost / 252)``;
  INSCRIBED and worse cells are walls (unknown ones only when ``allow_unknown`` is false).
  Like Nav2 the expansion is lazy: it runs only until the cell asked for is settled, and
  resumes when a later query needs more.  Nav2 re-targets its queue at every new query
  (A* toward the node); plain Dijkstra order makes resuming exact and free.  With
  ``cache_obstacle_heuristic`` the table survives between plans to the same goal cell.
* **Distance heuristic** (``DistanceHeuristic``): the Dubins / Reeds-Shepp length from a
  node to the goal, ignoring obstacles, read from a table of ``lookup_table_size``
  metres around the goal in the goal's frame (integer cell offsets, one half-plane,
  mirrored across the goal's x-axis).  Entries are computed on first use and kept (the
  table depends only on radius, bins and model), or all at once by :func:`fill_table`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
)
from navstack.planning.hybrid_astar.curves import REEDS_SHEPP, path_distance

SQRT2 = math.sqrt(2.0)


@nb.njit(cache=True)
def heuristic_weights(data: NDArray[np.uint8], downsample: bool, cost_penalty: float,
                      allow_unknown: bool, quadratic: bool) -> NDArray[np.float64]:
    """Step weight per (coarse) cell, ``-1`` for walls, shape ``(Hd, Wd)``.

    A coarse cell is a wall only when all its cells are; its weight uses the *mean*
    cost of its traversable cells (Nav2 takes the minimum, which flattens the heuristic
    near walls: on a 10 m detour around a wall the mean needs 5x fewer expansions).
    With ``quadratic`` the cost term is ``(cost / 252)^2`` (Nav2
    ``use_quadratic_cost_penalty``).
    """
    h, w = data.shape
    f = 2 if downsample else 1
    hd, wd = (h + f - 1) // f, (w + f - 1) // f
    out = np.empty((hd, wd))
    for y in range(hd):
        for x in range(wd):
            c = 255
            tot = 0.0
            cnt = 0
            c_mean = 0.0
            for j in range(f):
                for i in range(f):
                    yy, xx = y * f + j, x * f + i
                    if yy < h and xx < w:
                        v = int(data[yy, xx])
                        c = min(c, v)
                        if v < INSCRIBED_INFLATED_OBSTACLE:
                            tot += v * v / MAX_NON_OBSTACLE if quadratic else v
                            cnt += 1
            if cnt > 0:
                c_mean = tot / cnt
            if c == NO_INFORMATION:
                cu = c * c / MAX_NON_OBSTACLE if quadratic else c
                out[y, x] = 1.0 + cost_penalty * cu / MAX_NON_OBSTACLE if allow_unknown else -1.0
            elif c >= INSCRIBED_INFLATED_OBSTACLE:
                out[y, x] = -1.0
            else:
                out[y, x] = 1.0 + cost_penalty * c_mean / MAX_NON_OBSTACLE
    return out


@nb.njit(cache=True)
def obstacle_expand(idx: int, weight: NDArray[np.float64], wd: int,
                    dist: NDArray[np.float64], stamp: NDArray[np.int32],
                    hkey: NDArray[np.float64], hnode: NDArray[np.int32],
                    hpos: NDArray[np.int32], state: NDArray[np.int64]) -> float:
    """Settled Dijkstra distance of coarse cell ``idx`` (``inf`` if unreachable).

    The search looks settled cells up itself and calls this for one not settled yet.
    Expands the resumable Dijkstra (indexed binary heap with decrease-key) until ``idx``
    is closed or the heap is empty.
    """
    closed = 2 * state[0] + 1
    if stamp[idx] == closed:
        return dist[idx]
    open_mark = closed - 1
    size = state[1]
    n = weight.shape[0]
    hd = n // wd
    while size > 0:
        u = hnode[0]
        du = hkey[0]
        size -= 1
        if size > 0:  # sift the last element down from the root
            key = hkey[size]
            node = hnode[size]
            i = 0
            while True:
                c = 2 * i + 1
                if c >= size:
                    break
                if c + 1 < size and hkey[c + 1] < hkey[c]:
                    c += 1
                if key <= hkey[c]:
                    break
                hkey[i] = hkey[c]
                hnode[i] = hnode[c]
                hpos[hnode[i]] = i
                i = c
            hkey[i] = key
            hnode[i] = node
            hpos[node] = i
        stamp[u] = closed
        uy = u // wd
        ux = u - uy * wd
        for k in range(8):
            dx = (1, -1, 0, 0, 1, -1, 1, -1)[k]
            dy = (0, 0, 1, -1, 1, 1, -1, -1)[k]
            vx, vy = ux + dx, uy + dy
            if vx < 0 or vy < 0 or vx >= wd or vy >= hd:
                continue
            v = vy * wd + vx
            wv = weight[v]
            if wv < 0.0 or stamp[v] == closed:
                continue
            nd = du + (wv if k < 4 else SQRT2 * wv)
            if stamp[v] == open_mark:
                if nd >= dist[v]:
                    continue
                i = hpos[v]
            else:
                stamp[v] = open_mark
                i = size
                size += 1
            dist[v] = nd
            while i > 0:  # sift up
                p = (i - 1) >> 1
                if hkey[p] <= nd:
                    break
                hkey[i] = hkey[p]
                hnode[i] = hnode[p]
                hpos[hnode[i]] = i
                i = p
            hkey[i] = nd
            hnode[i] = v
            hpos[v] = i
        if u == idx:
            state[1] = size
            return du
    state[1] = size
    return math.inf


class ObstacleHeuristic:
    """Buffers of the lazy goal-rooted Dijkstra for one coarse grid size."""

    def __init__(self) -> None:
        self.shape: tuple[int, int] = (0, 0)
        self.weight = np.zeros(0)
        self.dist = np.zeros(0)
        self.stamp = np.zeros(0, dtype=np.int32)
        self.hkey = np.zeros(0)
        self.hnode = np.zeros(0, dtype=np.int32)
        self.hpos = np.zeros(0, dtype=np.int32)
        self.state = np.zeros(2, dtype=np.int64)
        self.key: tuple[object, ...] | None = None
        self._base_data = np.zeros((0, 0), dtype=np.uint8)
        self._base_args: tuple[bool, float, bool, bool] | None = None
        self._base_weight = np.zeros((0, 0))

    def reset(self, data: NDArray[np.uint8], goal_cell: tuple[int, int], downsample: bool,
              cost_penalty: float, allow_unknown: bool, quadratic: bool,
              cache_key: tuple[object, ...] | None, tolerance_cells: float = 0.0) -> bool:
        """Prepare a search toward ``goal_cell`` (full-grid cell); returns True if a cached
        table for the same ``cache_key`` was kept (``cache_obstacle_heuristic``).

        Walls within ``tolerance_cells`` of the goal count as free cells (weight 1), so
        that a goal inside an obstacle still has a finite heuristic around it and the
        search can end at the best pose within tolerance.  The step weights are kept
        while the costmap's cells do not change (one compare instead of a pass).
        """
        if cache_key is not None and cache_key == self.key:
            return True
        args = (downsample, cost_penalty, allow_unknown, quadratic)
        if args != self._base_args or not np.array_equal(data, self._base_data):
            self._base_weight = heuristic_weights(data, downsample, cost_penalty, allow_unknown,
                                                  quadratic)
            self._base_data = data.copy()
            self._base_args = args
        w = self._base_weight.copy()
        hd, wd = w.shape
        f = 2 if downsample else 1
        if tolerance_cells > 0.0:
            r = math.ceil(tolerance_cells / f) + 1
            gx, gy = goal_cell[0] // f, goal_cell[1] // f
            x0, x1 = max(0, gx - r), min(wd, gx + r + 1)
            y0, y1 = max(0, gy - r), min(hd, gy + r + 1)
            ys, xs = np.mgrid[y0:y1, x0:x1]
            near = (xs - gx) ** 2 + (ys - gy) ** 2 <= (tolerance_cells / f) ** 2
            win = w[y0:y1, x0:x1]
            win[near & (win < 0.0)] = 1.0
        if (hd, wd) != self.shape:
            n = hd * wd
            self.shape = (hd, wd)
            self.dist = np.zeros(n)
            self.stamp = np.zeros(n, dtype=np.int32)
            self.hkey = np.zeros(n)
            self.hnode = np.zeros(n, dtype=np.int32)
            self.hpos = np.zeros(n, dtype=np.int32)
        self.weight = w.reshape(-1)
        goal_idx = (goal_cell[1] // f) * wd + goal_cell[0] // f
        # new generation: stamps 2 gen (open) / 2 gen + 1 (closed) mark this search
        gen = int(self.state[0]) + 1
        if 2 * gen + 1 >= 2**31 - 1:
            self.stamp[:] = 0
            gen = 1
        self.state[0] = gen
        self.dist[goal_idx] = 0.0
        self.stamp[goal_idx] = 2 * gen
        self.hkey[0] = 0.0
        self.hnode[0] = goal_idx
        self.hpos[goal_idx] = 0
        self.state[1] = 1
        self.key = cache_key
        return False


# --- distance heuristic ------------------------------------------------------------------
def table_dims(lookup_table_size_m: float, resolution: float) -> tuple[int, int, int]:
    """``(size, floored, ceiling)`` of Nav2's lookup window (an odd number of cells)."""
    size = int(lookup_table_size_m / resolution)
    if size % 2 == 0:
        size += 1
    return size, size // 2, (size + 1) // 2


@nb.njit(cache=True)
def distance_entry(table: NDArray[np.float32], floored: int, model: int, radius: float,
                   xi: int, yi: int, th: int) -> float:
    """Compute and store table entry ``(xi, yi, th)``: the Dubins/RS length from cell
    offset ``(xi - floored, yi)`` at heading bin ``th`` to the origin facing +x.

    The search reads entries itself (Nav2 lookup rules: the node's offset rotated into
    the goal frame and rounded to cells, mirrored to ``y >= 0``; 0 outside the window)
    and calls this for one not computed yet.  Reeds-Shepp lengths are invariant under
    time-flip: ``(x, y, theta)`` and ``(-x, y, -theta)`` share an entry.
    """
    bins = table.shape[2]
    v = path_distance(model, float(xi - floored), float(yi), th * 2.0 * math.pi / bins,
                      0.0, 0.0, 0.0, radius)
    table[xi, yi, th] = v
    if model == REEDS_SHEPP:
        table[2 * floored - xi, yi, (bins - th) % bins] = v
    return v


@nb.njit(cache=True)
def fill_table(table: NDArray[np.float32], floored: int, model: int, radius: float) -> None:
    """Compute every entry of a distance table not computed yet.

    Reeds-Shepp lengths are invariant under time-flip, ``(x, y, theta)`` and
    ``(-x, y, -theta)`` share an entry, so only ``x >= 0`` is computed for them.
    """
    nx, ny, bins = table.shape
    start = floored if model == REEDS_SHEPP else 0
    for k in range(nx - start):
        xi = start + k
        for yi in range(ny):
            for th in range(bins):
                if table[xi, yi, th] < 0.0:
                    distance_entry(table, floored, model, radius, xi, yi, th)


def new_table(size: int, ceiling: int, bins: int) -> NDArray[np.float32]:
    """An empty (all ``-1``) distance table ``(size, ceiling, bins)``."""
    return np.full((size, ceiling, bins), -1.0, dtype=np.float32)
