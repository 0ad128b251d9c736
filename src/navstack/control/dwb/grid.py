"""Costmap-grid kernels for the DWB critics: cell lookup, wavefront, footprint raster.

* :func:`world_to_cells` — vectorised ``Costmap2D::worldToMap`` for any array shape.
* :class:`Wavefront` / :func:`wavefront` — the ``costmap_queue`` propagation behind
  ``MapGridCritic``: cells are expanded 4-connected in order of Euclidean distance to
  the seed that reached them (FIFO among equal distances), each taking the Manhattan
  cell distance to that seed as its value.  Lethal and unknown cells stop
  the wave and are marked obstacle (ROS 1 robot_navigation's
  ``dwb_critics::MapGridQueue::validCellToQueue``; the ROS 2 port lets the wave pass
  through walls, which makes "unreachable" impossible); cells never reached are
  unreachable.  A bucket queue keyed on the integer squared distance makes it
  ``O(cells)``.
* :func:`footprint_costs` — ``ObstacleFootprintCritic::scorePose``: the maximum cost on
  the Bresenham raster of the oriented footprint's edges, for many poses at once.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import (
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

FOOTPRINT_OK = 0
FOOTPRINT_CENTER_OFF_GRID = 1
FOOTPRINT_OFF_GRID = 2
FOOTPRINT_LETHAL = 3
FOOTPRINT_UNKNOWN = 4


def world_to_cells(costmap: Costmap2D, x: FloatArray,
                   y: FloatArray) -> tuple[IntArray, IntArray, NDArray[np.bool_]]:
    """Cells ``(mx, my)`` of world points of any shape, and whether each is on the grid.

    Off-grid entries are clipped to a valid index so they can be gathered safely; mask
    them with ``inside``.  One numba pass (:func:`_cells_kernel`).
    """
    x = np.asarray(x, dtype=np.float64)
    shape = x.shape
    mx = np.empty(shape, dtype=np.int64)
    my = np.empty(shape, dtype=np.int64)
    inside = np.empty(shape, dtype=np.bool_)
    _cells_kernel(np.ascontiguousarray(x).reshape(-1),
                  np.ascontiguousarray(y, dtype=np.float64).reshape(-1),
                  float(costmap.origin_x), float(costmap.origin_y), float(costmap.resolution),
                  int(costmap.size_x), int(costmap.size_y), mx.reshape(-1), my.reshape(-1),
                  inside.reshape(-1))
    return mx, my, inside


@numba.njit(cache=True)
def _cells_kernel(x: FloatArray, y: FloatArray, origin_x: float, origin_y: float,
                  resolution: float, size_x: int, size_y: int, mx: IntArray, my: IntArray,
                  inside: NDArray[np.bool_]) -> None:
    """``floor((p - origin) / resolution)``, clipped into the grid, for flat arrays."""
    for i in range(x.shape[0]):
        fx = np.floor((x[i] - origin_x) / resolution)
        fy = np.floor((y[i] - origin_y) / resolution)
        inside[i] = fx >= 0 and fx < size_x and fy >= 0 and fy < size_y
        mx[i] = int(min(max(fx, 0.0), size_x - 1))
        my[i] = int(min(max(fy, 0.0), size_y - 1))


def adjust_plan_resolution(plan: FloatArray, resolution: float) -> FloatArray:
    """``nav_2d_utils::adjustPlanResolution``: insert poses so gaps are at most ``resolution``.

    ``plan`` is ``(M, 3)``; a gap of length ``d > resolution`` gets
    ``ceil((d - resolution) / resolution)`` evenly spaced poses inserted.
    """
    if len(plan) < 2:
        return plan.copy()
    plan = np.ascontiguousarray(plan, dtype=np.float64)
    steps = _densify_steps(plan, resolution)
    out = np.empty((int(steps.sum()) + 1, 3))
    _densify(plan, steps, out)
    return out


@numba.njit(cache=True)
def _densify_steps(plan: FloatArray, resolution: float) -> IntArray:
    m = plan.shape[0] - 1
    steps = np.empty(m, dtype=np.int64)
    for i in range(m):
        dx = plan[i + 1, 0] - plan[i, 0]
        dy = plan[i + 1, 1] - plan[i, 1]
        dist = np.hypot(dx, dy)
        steps[i] = int(np.ceil((dist - resolution) / resolution) + 1.0) \
            if dist ** 2 > resolution ** 2 else 1
    return steps


@numba.njit(cache=True)
def _densify(plan: FloatArray, steps: IntArray, out: FloatArray) -> None:
    """Pose ``j`` of gap ``i`` is ``plan[i] + (j / steps[i]) * (plan[i+1] - plan[i])``;
    the gap's end is ``plan[i + 1]`` exactly."""
    out[0] = plan[0]
    k = 1
    for i in range(steps.shape[0]):
        n = steps[i]
        for j in range(1, n):
            frac = j / n
            for c in range(3):
                out[k, c] = plan[i, c] + frac * (plan[i + 1, c] - plan[i, c])
            k += 1
        for c in range(3):
            out[k, c] = plan[i + 1, c]
        k += 1


@numba.njit(cache=True)
def plan_run_end(plan: FloatArray, resolution: float, origin_x: float, origin_y: float,
                 data: NDArray[np.uint8], unknown: int) -> tuple[bool, int, int]:
    """``(found, mx, my)``: the last cell of the first run of the densified plan on
    known grid cells (``found`` False if no pose is on one): the last entry of
    ``plan_run_cells`` without building the dense plan (same points, same arithmetic
    as :func:`adjust_plan_resolution` and :func:`world_to_cells`)."""
    size_y, size_x = data.shape
    started = False
    last_x, last_y = -1, -1
    m = plan.shape[0]
    if m == 0:
        return (False, -1, -1)
    for i in range(m):
        if i == 0:
            n = 1
        else:
            dx = plan[i, 0] - plan[i - 1, 0]
            dy = plan[i, 1] - plan[i - 1, 1]
            dist = np.hypot(dx, dy)
            n = int(np.ceil((dist - resolution) / resolution) + 1.0) \
                if dist ** 2 > resolution ** 2 else 1
        for j in range(1, n + 1):
            if i == 0:
                px, py = plan[0, 0], plan[0, 1]
            elif j == n:
                px, py = plan[i, 0], plan[i, 1]
            else:
                frac = j / n
                px = plan[i - 1, 0] + frac * (plan[i, 0] - plan[i - 1, 0])
                py = plan[i - 1, 1] + frac * (plan[i, 1] - plan[i - 1, 1])
            fx = np.floor((px - origin_x) / resolution)
            fy = np.floor((py - origin_y) / resolution)
            ok = fx >= 0 and fx < size_x and fy >= 0 and fy < size_y
            if ok:
                cx, cy = int(fx), int(fy)
                ok = data[cy, cx] != unknown
            if ok:
                started = True
                last_x, last_y = cx, cy
            elif started:
                return (True, last_x, last_y)
    return (started, last_x, last_y)


_DX = np.array([-1, 0, 1, 0], dtype=np.int64)
_DY = np.array([0, -1, 0, 1], dtype=np.int64)


@numba.njit(cache=True)
def _wavefront_kernel(cost: NDArray[np.uint8], seed_x: IntArray, seed_y: IntArray,
                      block: bool, need: NDArray[np.bool_], need_count: int,
                      values: FloatArray, seen: NDArray[np.bool_],
                      head: NDArray[np.int32], tail: NDArray[np.int32],
                      nxt: NDArray[np.int32], qx: NDArray[np.int32], qy: NDArray[np.int32],
                      qsx: NDArray[np.int32], qsy: NDArray[np.int32]) -> None:
    size_y, size_x = cost.shape
    n = size_x * size_y
    obstacle = float(n)
    values[:, :] = float(n + 1)
    seen[:, :] = False
    head[:] = -1
    max_key = head.shape[0] - 1
    remaining = need_count
    count = 0
    cursor = max_key + 1
    num_seeds = seed_x.shape[0]
    i = 0
    e = -1
    while remaining != 0:
        # candidates: the seeds first, then the 4 neighbours of the popped cell
        if i < num_seeds:
            cand_n = 1
        else:
            while cursor <= max_key and head[cursor] < 0:
                cursor += 1
            if cursor > max_key:
                break
            e = head[cursor]
            head[cursor] = nxt[e]
            cand_n = 4
        for d in range(cand_n):
            if cand_n == 1:
                x = seed_x[i]
                y = seed_y[i]
                sx = x
                sy = y
            else:
                x = qx[e] + _DX[d]
                y = qy[e] + _DY[d]
                if x < 0 or y < 0 or x >= size_x or y >= size_y:
                    continue
                sx = qsx[e]
                sy = qsy[e]
            if seen[y, x]:
                continue
            seen[y, x] = True
            if need[y, x]:
                remaining -= 1
            # stop at lethal and unknown cells only: a wave stopped at inscribed cells
            # makes a path hugging an inflated wall "unreachable"; samples entering
            # inscribed space are rejected by BaseObstacle anyway
            if block and cost[y, x] >= LETHAL_OBSTACLE:
                values[y, x] = obstacle
                continue
            # the source is fixed when a cell is queued, so is its value
            values[y, x] = abs(x - sx) + abs(y - sy)
            key = (x - sx) * (x - sx) + (y - sy) * (y - sy)
            qx[count] = x
            qy[count] = y
            qsx[count] = sx
            qsy[count] = sy
            nxt[count] = -1
            if head[key] < 0:
                head[key] = count
            else:
                nxt[tail[key]] = count
            tail[key] = count
            if key < cursor:
                cursor = key
            count += 1
        if i < num_seeds:
            i += 1


class Wavefront:
    """Reusable buffers for :func:`wavefront` (no page faults on every control cycle).

    :meth:`compute` overwrites and returns the same ``values`` array each call, so keep
    the result only until the next call on this instance.
    """

    def __init__(self) -> None:
        self._shape: tuple[int, int] = (0, 0)

    def _ensure(self, shape: tuple[int, int]) -> None:
        if shape == self._shape:
            return
        size_y, size_x = shape
        n = size_x * size_y
        self.values = np.empty(shape)
        self.seen = np.empty(shape, dtype=np.bool_)
        max_key = (size_x - 1) ** 2 + (size_y - 1) ** 2
        self.head = np.empty(max_key + 1, dtype=np.int32)
        self.tail = np.empty(max_key + 1, dtype=np.int32)
        self.queue = np.empty((5, n), dtype=np.int32)
        self.no_need = np.zeros(shape, dtype=np.bool_)
        self._shape = shape

    def compute(self, cost: NDArray[np.uint8], seed_x: IntArray, seed_y: IntArray,
                block: bool = True, need: NDArray[np.bool_] | None = None) -> FloatArray:
        """Manhattan-distance map from the seed cells (``MapGridCritic`` semantics).

        Returns ``(size_y, size_x)`` float values: the distance in cells, ``n`` (cells
        in the map) for obstacle cells met by the wave and ``n + 1`` for unreachable
        ones.  Neighbours are tried in Nav2's order (x-1, y-1, x+1, y+1).

        ``need`` (bool grid) stops the wave as soon as every needed cell has been
        queued: a cell's value is fixed when it is queued, so the needed cells get
        exactly the values of a full propagation while far-away cells are skipped
        (they stay "unreachable").  ``None`` propagates over the whole map.
        """
        self._ensure(cost.shape)
        q = self.queue
        if need is None:
            need_mask, need_count = self.no_need, -1
        else:
            need_mask, need_count = need, int(np.count_nonzero(need))
        if need_count == 0:
            self.values.fill(float(cost.size + 1))
            return self.values
        _wavefront_kernel(cost, np.ascontiguousarray(seed_x, dtype=np.int64),
                          np.ascontiguousarray(seed_y, dtype=np.int64), block, need_mask,
                          need_count, self.values, self.seen, self.head, self.tail, q[0], q[1],
                          q[2], q[3], q[4])
        return self.values


def wavefront(cost: NDArray[np.uint8], seed_x: IntArray, seed_y: IntArray,
              block: bool = True, need: NDArray[np.bool_] | None = None) -> FloatArray:
    """One-off :meth:`Wavefront.compute` into a fresh array."""
    return Wavefront().compute(cost, seed_x, seed_y, block, need).copy()


@numba.njit(cache=True)
def _line_cost(data: NDArray[np.uint8], x0: int, y0: int, x1: int, y1: int) -> tuple[float, int]:
    """Max cost along the Bresenham line (both ends included) and a failure code."""
    dx, dy = abs(x1 - x0), -abs(y1 - y0)
    stepx = 1 if x0 < x1 else -1
    stepy = 1 if y0 < y1 else -1
    err = dx + dy
    best = 0.0
    x, y = x0, y0
    while True:
        c = data[y, x]
        if c == LETHAL_OBSTACLE:
            return best, FOOTPRINT_LETHAL
        if c == NO_INFORMATION:
            return best, FOOTPRINT_UNKNOWN
        if c > best:
            best = float(c)
        if x == x1 and y == y1:
            return best, FOOTPRINT_OK
        e2 = 2 * err
        if e2 >= dy:
            err += dy
            x += stepx
        if e2 <= dx:
            err += dx
            y += stepy


@numba.njit(cache=True)
def footprint_costs(poses: FloatArray, footprint: FloatArray, data: NDArray[np.uint8],
                    origin_x: float, origin_y: float,
                    resolution: float) -> tuple[FloatArray, NDArray[np.int8]]:
    """Footprint-perimeter cost and failure code for each of ``poses`` ``(K, 3)``.

    Codes: 0 ok, 1 centre off grid, 2 a footprint vertex off grid, 3 a lethal cell on
    the perimeter, 4 an unknown cell on the perimeter (the first met, in edge order).
    """
    k = poses.shape[0]
    p = footprint.shape[0]
    size_y, size_x = data.shape
    costs = np.zeros(k)
    codes = np.zeros(k, dtype=np.int8)
    vx = np.empty(p, dtype=np.int64)
    vy = np.empty(p, dtype=np.int64)
    for i in range(k):
        px, py, th = poses[i, 0], poses[i, 1], poses[i, 2]
        cx = np.floor((px - origin_x) / resolution)
        cy = np.floor((py - origin_y) / resolution)
        if cx < 0 or cy < 0 or cx >= size_x or cy >= size_y:
            codes[i] = FOOTPRINT_CENTER_OFF_GRID
            continue
        c, s = np.cos(th), np.sin(th)
        off = False
        for j in range(p):
            wx = px + footprint[j, 0] * c - footprint[j, 1] * s
            wy = py + footprint[j, 0] * s + footprint[j, 1] * c
            fx = np.floor((wx - origin_x) / resolution)
            fy = np.floor((wy - origin_y) / resolution)
            if fx < 0 or fy < 0 or fx >= size_x or fy >= size_y:
                off = True
                break
            vx[j] = int(fx)
            vy[j] = int(fy)
        if off:
            codes[i] = FOOTPRINT_OFF_GRID
            continue
        worst = 0.0
        for j in range(p):
            j1 = (j + 1) % p
            line, code = _line_cost(data, vx[j], vy[j], vx[j1], vy[j1])
            if code != FOOTPRINT_OK:
                codes[i] = code
                break
            worst = max(worst, line)
        costs[i] = worst
    return costs, codes


__all__ = [
    "FOOTPRINT_CENTER_OFF_GRID", "FOOTPRINT_LETHAL", "FOOTPRINT_OFF_GRID", "FOOTPRINT_OK",
    "FOOTPRINT_UNKNOWN", "Wavefront", "adjust_plan_resolution", "footprint_costs",
    "wavefront", "world_to_cells",
]
