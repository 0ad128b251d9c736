"""NavFn's navigation function: an interpolated potential field and its gradient descent.

Nav2's ``nav2_navfn_planner`` does not return a cell path.  It propagates a potential
from the robot's cell over the 4-connected grid (``navfn.cpp`` ``updateCell``): a cell of
NavFn cost ``h`` whose cheapest horizontal and vertical neighbours hold potentials
``ta <= tc`` gets

* ``ta + h`` when ``tc - ta >= h`` (the wave arrives from one side), else
* ``ta + h * (-0.2301 d^2 + 0.5307 d + 0.7040)`` with ``d = (tc - ta) / h`` -- NavFn's
  quadratic fit of the Eikonal update, so the potential approximates the cost-weighted
  *Euclidean* distance (a diagonal costs ``0.704 h``, not ``sqrt(2) h`` per cell pair).

The path is then found by descending the potential from the goal (``calcPath``): the
normalised gradient of every cell (``gradCell``: central differences of the 4-neighbour
potentials, one-sided next to unreached cells) is interpolated bilinearly at the current
point, which moves ``path_step`` (0.5) cells against it, until the robot's cell is
reached.  Where a neighbouring cell has no potential (an obstacle or beyond the
propagated region), or the point oscillates, the point steps to the 8-neighbour with the
lowest potential instead (NavFn's fallback; navstack takes a diagonal only between two
cells with potentials, so the path never cuts an obstacle's corner).  The points are not
cell centres: the path is smooth in free space and follows the cost valley between
inflated obstacles.

Departures: the propagation pops cells in exact potential order from a binary heap
(NavFn's threshold buffers are an approximation of that order); with ``use_astar`` the
key adds ``0.7 * COST_NEUTRAL`` times the Euclidean cell distance to the goal, which never
exceeds the potential still to come (every cell adds at least ``0.704 * 50``), so the
potentials are the same as Dijkstra's; the propagation stops a margin after the goal cell
is final instead of after a fixed number of cycles; points are cell centres
(``origin + (i + 0.5) res``, Nav2 maps ``origin + i res``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

__all__ = ["PATH_STEP", "POT_HIGH", "descend", "navfn_path_cells", "navfn_potential"]

POT_HIGH = 1.0e10
"""Potential of a cell the propagation did not reach (NavFn's ``POT_HIGH``)."""
PATH_STEP = 0.5
"""Gradient step [cells] (NavFn's ``pathStep``)."""
_H_FACTOR = 0.7
"""A* key: ``0.7 * cost_neutral`` per cell of Euclidean distance (see module docstring)."""


@nb.njit(cache=True)
def _update(pot: NDArray[np.float64], x: int, y: int, h: float) -> float:
    """NavFn ``updateCell``: the potential of cell ``(x, y)`` of cost ``h`` from its
    4-neighbours' current potentials."""
    ny, nx = pot.shape
    left = pot[y, x - 1] if x > 0 else POT_HIGH
    right = pot[y, x + 1] if x + 1 < nx else POT_HIGH
    down = pot[y - 1, x] if y > 0 else POT_HIGH
    up = pot[y + 1, x] if y + 1 < ny else POT_HIGH
    ta = min(left, right)
    tb = min(down, up)
    if tb < ta:
        ta, tb = tb, ta
    dc = tb - ta
    if dc >= h:
        return ta + h
    d = dc / h
    return ta + h * (-0.2301 * d * d + 0.5307 * d + 0.7040)


@nb.njit(cache=True)
def navfn_potential(weight: NDArray[np.float64], free: NDArray[np.bool_], sx: int, sy: int,
                    gx: int, gy: int, h_scale: float, margin: float) -> NDArray[np.float64]:
    """``(H, W)`` NavFn potential from source cell ``(sx, sy)`` (potential 0) over the
    ``free`` cells of NavFn cost ``weight``; unreached cells hold :data:`POT_HIGH`.

    Cells are finalised in order of ``potential + h_scale * |cell - goal|`` (``h_scale``
    0: Dijkstra); the propagation stops once the goal cell ``(gx, gy)`` is final and the
    keys have grown ``margin`` beyond its key, so the goal's surroundings are final too.
    """
    ny, nx = weight.shape
    pot = np.full((ny, nx), POT_HIGH)
    done = np.zeros((ny, nx), dtype=np.bool_)
    cap = 4 * nx * ny + 16
    keys = np.empty(cap)
    cells = np.empty(cap, dtype=np.int64)
    size = 0
    pot[sy, sx] = 0.0
    keys[0] = h_scale * math.hypot(sx - gx, sy - gy)
    cells[0] = sy * nx + sx
    size = 1
    stop_key = POT_HIGH
    while size > 0:
        key = keys[0]
        c = cells[0]
        size -= 1
        if size > 0:  # sift the last entry down from the root
            k_last = keys[size]
            c_last = cells[size]
            i = 0
            while True:
                j = 2 * i + 1
                if j >= size:
                    break
                if j + 1 < size and keys[j + 1] < keys[j]:
                    j += 1
                if k_last <= keys[j]:
                    break
                keys[i] = keys[j]
                cells[i] = cells[j]
                i = j
            keys[i] = k_last
            cells[i] = c_last
        if key > stop_key:
            break
        y = c // nx
        x = c - y * nx
        if done[y, x]:
            continue
        done[y, x] = True
        if x == gx and y == gy:
            stop_key = key + margin
        for k in range(4):
            vx = x + (1 if k == 0 else -1 if k == 1 else 0)
            vy = y + (1 if k == 2 else -1 if k == 3 else 0)
            if vx < 0 or vy < 0 or vx >= nx or vy >= ny:
                continue
            if done[vy, vx] or not free[vy, vx]:
                continue
            p = _update(pot, vx, vy, weight[vy, vx])
            if p >= pot[vy, vx]:
                continue
            pot[vy, vx] = p
            if size >= cap:  # cannot happen: every cell is pushed at most 4 times
                continue
            kv = p + h_scale * math.hypot(vx - gx, vy - gy)
            i = size
            size += 1
            while i > 0:  # sift up
                parent = (i - 1) >> 1
                if keys[parent] <= kv:
                    break
                keys[i] = keys[parent]
                cells[i] = cells[parent]
                i = parent
            keys[i] = kv
            cells[i] = vy * nx + vx
    return pot


@nb.njit(cache=True)
def _gradient(pot: NDArray[np.float64], x: int, y: int) -> tuple[float, float]:
    """NavFn ``gradCell``: the normalised downhill direction at cell ``(x, y)``."""
    ny, nx = pot.shape
    cv = pot[y, x]
    left = pot[y, x - 1] if x > 0 else POT_HIGH
    right = pot[y, x + 1] if x + 1 < nx else POT_HIGH
    down = pot[y - 1, x] if y > 0 else POT_HIGH
    up = pot[y + 1, x] if y + 1 < ny else POT_HIGH
    dx = 0.0
    dy = 0.0
    if left < POT_HIGH:
        dx += left - cv
    if right < POT_HIGH:
        dx += cv - right
    if down < POT_HIGH:
        dy += down - cv
    if up < POT_HIGH:
        dy += cv - up
    norm = math.hypot(dx, dy)
    if norm > 0.0:
        return dx / norm, dy / norm
    return 0.0, 0.0


@nb.njit(cache=True)
def descend(pot: NDArray[np.float64], gx: int, gy: int, neutral: float,
            max_steps: int) -> NDArray[np.float64]:
    """NavFn ``calcPath`` from cell ``(gx, gy)`` down to the potential's source.

    Returns ``(K, 2)`` points in cell coordinates (cell ``(i, j)``'s centre is ``(i, j)``)
    from the goal cell to the source cell, or an empty array when the descent fails (no
    potential at the start, a zero gradient, leaving the grid, or ``max_steps``)."""
    ny, nx = pot.shape
    out = np.empty((max_steps + 2, 2))
    n = 0
    px = float(gx)
    py = float(gy)
    if pot[gy, gx] >= POT_HIGH:
        return out[:0]
    for _ in range(max_steps):
        cx = math.floor(px + 0.5)
        cy = math.floor(py + 0.5)
        if pot[cy, cx] < neutral:  # the source cell: done
            out[n, 0] = cx
            out[n, 1] = cy
            return out[:n + 1]
        out[n, 0] = px
        out[n, 1] = py
        n += 1
        oscillating = (n > 2 and out[n - 1, 0] == out[n - 3, 0]
                       and out[n - 1, 1] == out[n - 3, 1])
        x0 = math.floor(px)
        y0 = math.floor(py)
        smooth = not oscillating and x0 >= 1 and y0 >= 1 and x0 + 2 < nx and y0 + 2 < ny
        if smooth:  # the 4 interpolation cells and their neighbours all have potentials
            for yy in range(y0 - 1, y0 + 3):
                for xx in range(x0 - 1, x0 + 3):
                    if pot[yy, xx] >= POT_HIGH:
                        smooth = False
        if smooth:
            fx = px - x0
            fy = py - y0
            g00 = _gradient(pot, x0, y0)
            g10 = _gradient(pot, x0 + 1, y0)
            g01 = _gradient(pot, x0, y0 + 1)
            g11 = _gradient(pot, x0 + 1, y0 + 1)
            vx = ((1.0 - fy) * ((1.0 - fx) * g00[0] + fx * g10[0])
                  + fy * ((1.0 - fx) * g01[0] + fx * g11[0]))
            vy = ((1.0 - fy) * ((1.0 - fx) * g00[1] + fx * g10[1])
                  + fy * ((1.0 - fx) * g01[1] + fx * g11[1]))
            norm = math.hypot(vx, vy)
            if norm == 0.0:
                return out[:0]
            px += PATH_STEP * vx / norm
            py += PATH_STEP * vy / norm
            continue
        # next to a cell without potential (or oscillating): to the lowest 8-neighbour
        # (a diagonal only between two cells with potentials: no corner cutting)
        best = pot[cy, cx]
        bx = cx
        by = cy
        for yy in range(cy - 1, cy + 2):
            for xx in range(cx - 1, cx + 2):
                if (xx == cx and yy == cy) or xx < 0 or yy < 0 or xx >= nx or yy >= ny:
                    continue
                if xx != cx and yy != cy and (pot[cy, xx] >= POT_HIGH
                                              or pot[yy, cx] >= POT_HIGH):
                    continue
                if pot[yy, xx] < best:
                    best = pot[yy, xx]
                    bx = xx
                    by = yy
        if bx == cx and by == cy:
            return out[:0]  # a local minimum: nowhere lower to go
        px = float(bx)
        py = float(by)
    return out[:0]


def navfn_path_cells(weight: NDArray[np.float64], free: NDArray[np.bool_],
                     source: tuple[int, int], goal: tuple[int, int], use_astar: bool,
                     neutral: float) -> NDArray[np.float64]:
    """Cell-coordinate points from ``source`` to ``goal`` along NavFn's gradient descent
    (empty when it fails); ``weight``/``free`` are ``(H, W)`` NavFn costs and
    passability."""
    h, w = weight.shape
    h_scale = _H_FACTOR * neutral if use_astar else 0.0
    margin = 4.0 * float(np.max(weight, initial=neutral))
    pot = navfn_potential(np.ascontiguousarray(weight, dtype=np.float64),
                          np.ascontiguousarray(free, dtype=np.bool_),
                          source[0], source[1], goal[0], goal[1], h_scale, margin)
    reach = float(pot[goal[1], goal[0]])
    if reach >= POT_HIGH:
        return np.zeros((0, 2))
    # every cell moved adds at least 0.704 * neutral: the path has at most
    # reach / (0.704 neutral) cells, 2 steps each; twice that leaves room for detours
    max_steps = int(4.0 * reach / (0.704 * neutral)) + 4 * (w + h)
    pts = descend(pot, goal[0], goal[1], neutral, max_steps)
    return np.ascontiguousarray(pts[::-1])
