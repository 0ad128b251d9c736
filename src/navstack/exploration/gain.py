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

__all__ = ["visible_unknown"]


@nb.njit(cache=True)
def _gain_kernel(unknown: NDArray[np.bool_], blocked: NDArray[np.bool_],
                 rows: NDArray[np.int64], cols: NDArray[np.int64], range_cells: float,
                 beams: int, stamp: NDArray[np.int32]) -> NDArray[np.int64]:
    h, w = unknown.shape
    out = np.zeros(rows.size, dtype=np.int64)
    steps = math.ceil(range_cells * 2.0)
    for k in range(rows.size):
        tag = k + 1
        r0 = rows[k] + 0.5
        c0 = cols[k] + 0.5
        count = 0
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
        out[k] = count
    return out


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
    return _gain_kernel(np.ascontiguousarray(view.unknown), np.ascontiguousarray(stop), r, c,
                        sensor_range / view.resolution, int(beams), stamp)
