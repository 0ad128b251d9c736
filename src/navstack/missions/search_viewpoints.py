"""Where to look from: a few viewpoints that together see all the free space of a map.

A camera search for objects on the floor (the TurtleBot course's packages) does not need
to drive over every cell, only to see every cell: from each viewpoint the robot turns
once in place.  Candidates are free cells ``spacing`` apart with at least ``clearance``
metres to the nearest obstacle; targets are free cells every ``target_spacing`` metres; a
candidate sees a target within ``view_range`` metres when the straight line between them
crosses no occupied (or unknown) cell.  Viewpoints are chosen greedily (the candidate
that sees most unseen targets, a set-cover heuristic) until ``coverage`` of the targets
is seen, then ordered nearest-neighbour from the start and improved with 2-opt.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import distance_transform_edt

from navstack.core.msgs import OccupancyGrid, Pose2D

FloatArray = NDArray[np.float64]


def _cells_to_xy(grid: OccupancyGrid, rc: NDArray[np.int64]) -> FloatArray:
    info = grid.info
    o = info.origin.position
    return np.column_stack((o.x + (rc[:, 1] + 0.5) * info.resolution,
                            o.y + (rc[:, 0] + 0.5) * info.resolution))


def _visible(blocked: NDArray[np.bool_], grid: OccupancyGrid, src: FloatArray,
             targets: FloatArray, view_range: float) -> NDArray[np.bool_]:
    """Which ``targets`` (n, 2) the point ``src`` sees (line of sight, within range)."""
    info = grid.info
    o = info.origin.position
    d = np.hypot(targets[:, 0] - src[0], targets[:, 1] - src[1])
    ok = d <= view_range
    steps = max(2, math.ceil(view_range / (0.5 * info.resolution)))
    f = np.linspace(0.0, 1.0, steps)[None, :]
    xs = src[0] + f * (targets[:, 0:1] - src[0])
    ys = src[1] + f * (targets[:, 1:2] - src[1])
    cols = np.floor((xs - o.x) / info.resolution).astype(np.int64)
    rows = np.floor((ys - o.y) / info.resolution).astype(np.int64)
    inside = (rows >= 0) & (rows < blocked.shape[0]) & (cols >= 0) & (cols < blocked.shape[1])
    hit = np.zeros_like(inside)
    hit[inside] = blocked[rows[inside], cols[inside]]
    return np.asarray(ok & ~hit.any(axis=1))


def search_viewpoints(grid: OccupancyGrid, start: Pose2D, clearance: float = 0.3,
                      spacing: float = 0.4, target_spacing: float = 0.2,
                      view_range: float = 2.0, coverage: float = 0.97) -> list[Pose2D]:
    """Viewpoints (see module docstring), each facing the next one; the start excluded."""
    data = np.asarray(grid.data)
    res = grid.info.resolution
    blocked = (data < 0) | (data >= 65)
    dist = distance_transform_edt(~blocked) * res
    step = max(1, round(spacing / res))
    cand_rc = np.argwhere(dist >= clearance)
    cand_rc = cand_rc[(cand_rc[:, 0] % step == 0) & (cand_rc[:, 1] % step == 0)]
    tstep = max(1, round(target_spacing / res))
    targ_rc = np.argwhere(~blocked)
    targ_rc = targ_rc[(targ_rc[:, 0] % tstep == 0) & (targ_rc[:, 1] % tstep == 0)]
    if len(cand_rc) == 0 or len(targ_rc) == 0:
        return []
    cands = _cells_to_xy(grid, cand_rc)
    targets = _cells_to_xy(grid, targ_rc)
    sees = np.array([_visible(blocked, grid, c, targets, view_range) for c in cands])
    seen = _visible(blocked, grid, np.array([start.x, start.y]), targets, view_range)
    chosen: list[int] = []
    while seen.mean() < coverage:
        gain = (sees & ~seen).sum(axis=1)
        best = int(np.argmax(gain))
        if gain[best] == 0:
            break
        chosen.append(best)
        seen |= sees[best]
    pts = [cands[i] for i in chosen]
    order = _nearest_neighbour(np.array([start.x, start.y]), pts)
    order = _two_opt(np.array([start.x, start.y]), pts, order)
    path = [pts[i] for i in order]
    out = []
    for i, p in enumerate(path):
        nxt = path[i + 1] if i + 1 < len(path) else p
        prev = path[i - 1] if i > 0 else np.array([start.x, start.y])
        heading = math.atan2(nxt[1] - p[1], nxt[0] - p[0]) if i + 1 < len(path) else \
            math.atan2(p[1] - prev[1], p[0] - prev[0])
        out.append(Pose2D(float(p[0]), float(p[1]), heading))
    return out


def _nearest_neighbour(start: FloatArray, pts: list[FloatArray]) -> list[int]:
    left = list(range(len(pts)))
    order: list[int] = []
    cur = start
    while left:
        k = min(left, key=lambda i: float(np.hypot(*(pts[i] - cur))))
        order.append(k)
        left.remove(k)
        cur = pts[k]
    return order


def _two_opt(start: FloatArray, pts: list[FloatArray], order: list[int]) -> list[int]:
    def length(o: list[int]) -> float:
        seq = [start, *(pts[i] for i in o)]
        return sum(float(np.hypot(*(b - a))) for a, b in itertools.pairwise(seq))

    best, improved = list(order), True
    while improved:
        improved = False
        for i in range(len(best) - 1):
            for j in range(i + 1, len(best)):
                cand = best[:i] + best[i:j + 1][::-1] + best[j + 1:]
                if length(cand) < length(best) - 1e-9:
                    best, improved = cand, True
    return best


__all__ = ["search_viewpoints"]
