"""Expected information gain of a viewpoint: unknown cells a lidar there would see.

The gain of standing at a cell is the number of unknown cells within ``sensor_range``
that a ray from it reaches before an obstacle (González-Baños & Latombe, "Navigation
strategies for exploring indoor environments", IJRR 21(10), 2002: the area of the
unexplored region visible from the candidate).  Rays pass through unknown cells
(optimistic: unknown may be free) and stop at observed obstacles; each cell counts once.
A numba kernel casts ``beams`` rays per viewpoint with a per-call stamp array, so many
viewpoints cost no allocation.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.exploration.grid_view import BoolArray, GridView

__all__ = ["path_cells", "visible_unknown", "visible_unknown_along"]


def visible_unknown(view: GridView, rows: NDArray[np.integer], cols: NDArray[np.integer],
                    sensor_range: float, beams: int = 180,
                    blocked: BoolArray | None = None) -> NDArray[np.int64]:
    """Unknown cells visible within ``sensor_range`` [m] from each cell ``(rows, cols)``.

    ``blocked``: cells that stop a ray (default: observed, not free -- obstacles).
    """
    r = np.ascontiguousarray(rows, dtype=np.int64)
    c = np.ascontiguousarray(cols, dtype=np.int64)
    if r.size == 0:
        return np.zeros(0, dtype=np.int64)
    stop = (~view.unknown & ~view.free) if blocked is None else blocked
    stamp = np.zeros(view.shape, dtype=np.int32)
    # each cell its own group of one
    return _union_kernel(np.ascontiguousarray(view.unknown), np.ascontiguousarray(stop), r, c,
                         np.arange(r.size + 1, dtype=np.int64),
                         sensor_range / view.resolution, int(beams), stamp)


@nb.njit(cache=True)
def _union_kernel(unknown: NDArray[np.bool_], blocked: NDArray[np.bool_],
                  rows: NDArray[np.int64], cols: NDArray[np.int64],
                  offsets: NDArray[np.int64], range_cells: float, beams: int,
                  stamp: NDArray[np.int32]) -> NDArray[np.int64]:
    """Per group ``g`` (points ``offsets[g]:offsets[g + 1]``): unknown cells visible from
    any of its points, each counted once."""
    h, w = unknown.shape
    groups = offsets.size - 1
    out = np.zeros(groups, dtype=np.int64)
    steps = math.ceil(range_cells * 2.0)
    for g in range(groups):
        tag = g + 1
        count = 0
        for k in range(offsets[g], offsets[g + 1]):
            r0 = rows[k] + 0.5
            c0 = cols[k] + 0.5
            for b in range(beams):
                a = 2.0 * math.pi * b / beams
                dr = math.sin(a) * 0.5
                dc = math.cos(a) * 0.5
                for s in range(1, steps + 1):
                    r = math.floor(r0 + dr * s)
                    c = math.floor(c0 + dc * s)
                    if r < 0 or r >= h or c < 0 or c >= w:
                        break
                    if blocked[r, c]:
                        break
                    if unknown[r, c] and stamp[r, c] != tag:
                        stamp[r, c] = tag
                        count += 1
        out[g] = count
    return out


@nb.njit(cache=True)
def _descend(dist: NDArray[np.float64], row: int, col: int, every: int
             ) -> NDArray[np.int64]:
    """Cells every ``every`` steps of the steepest descent of ``dist`` (a wavefront's
    distances) from ``(row, col)`` to its start (distance 0), both ends included."""
    h, w = dist.shape
    out = np.empty((h * w // max(every, 1) + 2, 2), dtype=np.int64)
    n = 0
    r, c = row, col
    k = 0
    while True:
        if k % every == 0:
            out[n, 0] = r
            out[n, 1] = c
            n += 1
        best = dist[r, c]
        br, bc = r, c
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if (dr or dc) and 0 <= rr < h and 0 <= cc < w and dist[rr, cc] < best:
                    best = dist[rr, cc]
                    br, bc = rr, cc
        if br == r and bc == c:
            break
        r, c = br, bc
        k += 1
    if out[n - 1, 0] != r or out[n - 1, 1] != c:
        out[n, 0] = r
        out[n, 1] = c
        n += 1
    return out[:n]


def path_cells(distances: NDArray[np.float64], row: int, col: int, every: int
               ) -> NDArray[np.int64]:
    """``(K, 2)`` cells, one per ``every`` cells, of the shortest path from the wavefront
    start to ``(row, col)`` (followed back down ``distances``; goal first)."""
    if not np.isfinite(distances[row, col]):
        raise ValueError(f"cell ({row}, {col}) is not reached by the wavefront")
    return _descend(np.ascontiguousarray(distances), int(row), int(col), max(1, int(every)))


def visible_unknown_along(view: GridView, paths: list[NDArray[np.int64]],
                          sensor_range: float, beams: int = 180,
                          seen_from: tuple[int, int] | None = None) -> NDArray[np.int64]:
    """Per path (``(K, 2)`` cells): unknown cells visible within ``sensor_range`` from
    any of its cells -- what the robot sees on the way to a goal and there.  Cells
    visible from ``seen_from`` (the robot's cell: every path starts there, and what it
    sees now it sees whichever way it goes) are not counted."""
    if not paths:
        return np.zeros(0, dtype=np.int64)
    offsets = np.zeros(len(paths) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([len(q) for q in paths])
    cells = np.concatenate(paths).astype(np.int64)
    stop = np.ascontiguousarray(~view.unknown & ~view.free)
    unknown = np.ascontiguousarray(view.unknown)
    range_cells = sensor_range / view.resolution
    if seen_from is not None:
        here = np.zeros(view.shape, dtype=np.int32)
        _union_kernel(unknown, stop, np.array([seen_from[0]], dtype=np.int64),
                      np.array([seen_from[1]], dtype=np.int64), np.array([0, 1]),
                      range_cells, int(beams), here)
        unknown = unknown & (here == 0)
    stamp = np.zeros(view.shape, dtype=np.int32)
    return _union_kernel(unknown, stop,
                         np.ascontiguousarray(cells[:, 0]), np.ascontiguousarray(cells[:, 1]),
                         offsets, range_cells, int(beams), stamp)
