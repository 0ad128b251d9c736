"""Exact path checks for Hybrid-A* results: footprint overlap and curvature.

These are the *reference* checks the tests and ``navstack bench hybrid`` use to verify
plans, independent of the planner's own (conservative, pre-rotated) collision sets:

* :func:`pose_collision`: the footprint polygon at a pose overlaps (with positive area)
  the square of a LETHAL cell, of an unknown cell when unknown space is not allowed, or
  leaves the map — exact geometry, no rasterisation;
* :func:`path_collision`: that test along a path, densified to at most a quarter cell
  and one degree between checked poses (positions linear, heading along the shorter
  arc, as a controller tracking the path would move);
* :func:`max_curvature`: the largest curvature of the circle through three consecutive
  poses, within each run of constant travel direction (a cusp, where the vehicle stops
  and reverses, is not a curve), :func:`travel_directions` recovering the direction of
  each motion from the poses' headings when the planner's flags are not at hand.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D
from navstack.planning.hybrid_astar.collision import cheb_to_polygon
from navstack.planning.hybrid_astar.smoother import curvatures, segments


@nb.njit(cache=True)
def _pose_collision(data: NDArray[np.uint8], ox: float, oy: float, res: float,
                    poly: NDArray[np.float64], x: float, y: float, th: float,
                    allow_unknown: bool) -> int:
    """Flat index of a blocking cell the footprint overlaps, ``-2`` off the map, -1 free."""
    h, w = data.shape
    c, s = math.cos(th), math.sin(th)
    n = poly.shape[0]
    pc = np.empty((n, 2))
    for i in range(n):
        pc[i, 0] = (x + c * poly[i, 0] - s * poly[i, 1] - ox) / res
        pc[i, 1] = (y + s * poly[i, 0] + c * poly[i, 1] - oy) / res
        if pc[i, 0] < 0.0 or pc[i, 1] < 0.0 or pc[i, 0] > w or pc[i, 1] > h:
            return -2
    x0 = max(0, math.floor(pc[:, 0].min()) - 1)
    x1 = min(w - 1, math.floor(pc[:, 0].max()) + 1)
    y0 = max(0, math.floor(pc[:, 1].min()) - 1)
    y1 = min(h - 1, math.floor(pc[:, 1].max()) + 1)
    for cy in range(y0, y1 + 1):
        for cx in range(x0, x1 + 1):
            v = data[cy, cx]
            blocking = v == LETHAL_OBSTACLE or (v == NO_INFORMATION and not allow_unknown)
            if blocking and cheb_to_polygon(cx + 0.5, cy + 0.5, pc) < 0.5 - 1e-9:
                return cy * w + cx
    return -1


def pose_collision(costmap: Costmap2D, polygon: NDArray[np.float64],
                   pose: tuple[float, float, float], allow_unknown: bool = False
                   ) -> tuple[int, int] | None:
    """The ``(mx, my)`` of a cell the footprint at ``pose`` overlaps, ``(-1, -1)`` when the
    footprint leaves the map, ``None`` when it is free."""
    k = _pose_collision(costmap.data, costmap.origin_x, costmap.origin_y, costmap.resolution,
                        np.ascontiguousarray(polygon, dtype=np.float64), float(pose[0]),
                        float(pose[1]), float(pose[2]), allow_unknown)
    if k == -1:
        return None
    if k == -2:
        return (-1, -1)
    return (k % costmap.size_x, k // costmap.size_x)


@nb.njit(cache=True)
def _path_collision(data: NDArray[np.uint8], ox: float, oy: float, res: float,
                    poly: NDArray[np.float64], xyt: NDArray[np.float64],
                    allow_unknown: bool, step: float, dtheta: float) -> int:
    n = xyt.shape[0]
    if n == 0:
        return -1
    if _pose_collision(data, ox, oy, res, poly, xyt[0, 0], xyt[0, 1], xyt[0, 2],
                       allow_unknown) != -1:
        return 0
    for i in range(n - 1):
        d = math.hypot(xyt[i + 1, 0] - xyt[i, 0], xyt[i + 1, 1] - xyt[i, 1])
        dth = math.atan2(math.sin(xyt[i + 1, 2] - xyt[i, 2]), math.cos(xyt[i + 1, 2] - xyt[i, 2]))
        m = max(1, math.ceil(max(d / step, abs(dth) / dtheta)))
        for j in range(1, m + 1):
            f = j / m
            if _pose_collision(data, ox, oy, res, poly, xyt[i, 0] + f * (xyt[i + 1, 0] - xyt[i, 0]),
                               xyt[i, 1] + f * (xyt[i + 1, 1] - xyt[i, 1]), xyt[i, 2] + f * dth,
                               allow_unknown) != -1:
                return i + 1
    return -1


def path_collision(xyt: NDArray[np.float64], costmap: Costmap2D, polygon: NDArray[np.float64],
                   allow_unknown: bool = False) -> int:
    """Index of the first pose whose motion (from the previous pose) or placement overlaps
    an obstacle; ``-1`` when the whole path is collision-free."""
    arr = np.ascontiguousarray(xyt, dtype=np.float64).reshape(-1, 3)
    return int(_path_collision(costmap.data, costmap.origin_x, costmap.origin_y,
                               costmap.resolution, np.ascontiguousarray(polygon, np.float64),
                               arr, allow_unknown, 0.25 * costmap.resolution,
                               math.radians(1.0)))


def travel_directions(xyt: NDArray[np.float64]) -> NDArray[np.int8]:
    """+1 / -1 per pose: the direction (forward / reverse w.r.t. the heading) of the
    motion reaching it; the first pose takes its successor's."""
    arr = np.asarray(xyt, dtype=np.float64).reshape(-1, 3)
    out = np.ones(len(arr), dtype=np.int8)
    if len(arr) < 2:
        return out
    d = np.diff(arr[:, :2], axis=0)
    heading = 0.5 * (arr[:-1, 2] + arr[1:, 2])
    heading += np.where(np.abs(arr[1:, 2] - arr[:-1, 2]) > math.pi, math.pi, 0.0)
    dot = d[:, 0] * np.cos(heading) + d[:, 1] * np.sin(heading)
    out[1:] = np.where(dot < 0.0, -1, 1)
    out[0] = out[1]
    return out


def max_curvature(xyt: NDArray[np.float64], direction: NDArray[np.int8] | None = None) -> float:
    """Largest three-point curvature [1/unit] within the path's directional segments."""
    arr = np.asarray(xyt, dtype=np.float64).reshape(-1, 3)
    dirs = travel_directions(arr) if direction is None else np.asarray(direction, np.int8)
    best = 0.0
    for s, e in segments(dirs):
        if e - s < 2:
            continue
        k = curvatures(np.ascontiguousarray(arr[s:e + 1, :2]), 0.0, 0.0)
        best = max(best, float(k[1:-1].max()))
    return best
