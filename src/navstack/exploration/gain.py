"""Expected information gain of a viewpoint: unknown cells a lidar there would see.

The gain of standing at a cell is the number of unknown cells within ``sensor_range``
that a ray from it reaches before an obstacle (González-Baños & Latombe, "Navigation
strategies for exploring indoor environments", IJRR 21(10), 2002: the area of the
unexplored region visible from the candidate).  Rays pass through unknown cells
(optimistic: unknown may be free) and stop at observed obstacles; each cell counts once.
A numba kernel casts ``beams`` rays per viewpoint with a per-call stamp array, so many
viewpoints cost no allocation; the rays' cells come from a table of offsets built once
per (range, beams) (:func:`_beam_table`: the same cells as stepping each ray, tested).
"""

from __future__ import annotations

import functools
import math
from typing import Any

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
    # each cell its own group of one
    return _union(_codes(view.unknown, stop), r, c, np.arange(r.size + 1, dtype=np.int64),
                  sensor_range / view.resolution, int(beams))[0]


@nb.njit(cache=True)
def _rounding_matters(x: float, y: float, fy: int) -> bool:
    """Whether ``floor(R + 0.5 + x)`` may differ from ``R + floor(y)``, ``y = 0.5 + x``:
    ``y`` within 1e-6 of an integer, unless ``x`` is a multiple of 0.5 (then both sums
    are exact in floating point)."""
    return min(y - fy, fy + 1.0 - y) < 1e-6 and 2.0 * x != math.floor(2.0 * x)


@nb.njit(cache=True)
def _beam_table(range_cells: float, beams: int) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.int64],
        NDArray[np.int64], NDArray[np.bool_], NDArray[np.int64]]:
    """Each beam's cells as offsets from the viewpoint's cell, for :func:`_union_kernel`.

    A beam of angle ``a = 2 pi b / beams`` from the centre of cell ``(R, C)`` samples
    every half cell: step ``s`` is in cell ``floor(R + 0.5 + dr s)``, ``floor(C + 0.5 +
    dc s)`` with ``dr, dc = sin(a) / 2, cos(a) / 2``.  That is ``R + floor(0.5 + dr s)``
    -- an offset the same for every viewpoint (rows and columns below 2^30, where the
    sum's rounding error stays under 1e-6) -- unless ``0.5 + dr s`` is within 1e-6 of
    an integer (and ``dr s`` no multiple of 0.5, which both sums hold exactly), where
    the floor of the float sum depends on how ``R + 0.5 + dr s`` rounds: such steps are
    flagged (``amb``) and computed per viewpoint as before.  A step in the same cell as
    the one before (neither flagged) is dropped: a beam that was not stopped there sees
    nothing new in it.  Returns per beam ``dr``, ``dc`` and, row ``b``'s first
    ``count[b]`` entries, its kept steps' row and column offsets, step ``s`` and flag."""
    steps = math.ceil(range_cells * 2.0)
    dr_b = np.empty(beams)
    dc_b = np.empty(beams)
    tr = np.zeros((beams, steps), dtype=np.int64)
    tc = np.zeros((beams, steps), dtype=np.int64)
    ts = np.zeros((beams, steps), dtype=np.int64)
    amb = np.zeros((beams, steps), dtype=np.bool_)
    count = np.zeros(beams, dtype=np.int64)
    for b in range(beams):
        a = 2.0 * math.pi * b / beams
        dr = math.sin(a) * 0.5
        dc = math.cos(a) * 0.5
        dr_b[b] = dr
        dc_b[b] = dc
        n = 0
        pr = 0
        pc = 0
        p_amb = True  # the first step is always kept
        for s in range(1, steps + 1):
            xr = dr * s
            xc = dc * s
            yr = 0.5 + xr
            yc = 0.5 + xc
            fr = math.floor(yr)
            fc = math.floor(yc)
            flag = _rounding_matters(xr, yr, fr) or _rounding_matters(xc, yc, fc)
            if flag or p_amb or fr != pr or fc != pc:
                tr[b, n] = fr
                tc[b, n] = fc
                ts[b, n] = s
                amb[b, n] = flag
                n += 1
            pr = fr
            pc = fc
            p_amb = flag
        count[b] = n
    return dr_b, dc_b, tr, tc, ts, amb, count


def _codes(unknown: NDArray[np.bool_], blocked: NDArray[np.bool_]) -> NDArray[np.uint8]:
    """One byte per cell for :func:`_union_kernel`: 2 stops a ray (checked first),
    1 unknown, 0 neither."""
    return np.where(blocked, np.uint8(2), unknown.astype(np.uint8))


@functools.lru_cache(maxsize=8)
def _beam_table_cached(range_cells: float, beams: int) -> tuple[NDArray[Any], ...]:
    """:func:`_beam_table` per (range in cells, beams), built once: a strategy asks for
    one table (its tables are never written to)."""
    return _beam_table(range_cells, beams)


def _union(code: NDArray[np.uint8], rows: NDArray[np.int64], cols: NDArray[np.int64],
           offsets: NDArray[np.int64], range_cells: float, beams: int
           ) -> tuple[NDArray[np.int64], NDArray[np.int32]]:
    """Per group ``g`` (points ``offsets[g]:offsets[g + 1]``): unknown cells (``code``,
    :func:`_codes`) visible from any of its points, each counted once; and the stamps
    of the cells counted (a cell of group ``g`` holds ``g + 1``, 0 where none counted).

    The kernel runs on ``code`` framed by cells that stop a ray, as wide as a beam
    reaches beyond the grid: a beam leaving the grid stopped there before too, and no
    step needs a bounds check."""
    dr_b, dc_b, tr, tc, ts, amb, count = _beam_table_cached(float(range_cells), int(beams))
    h, w = code.shape
    # a flagged step lands at most one cell beyond its table entry
    pad = int(max(np.abs(tr).max(), np.abs(tc).max())) + 1
    if rows.size:  # viewpoints off the grid: their beams start farther out
        pad += max(0, -int(rows.min()), int(rows.max()) - h + 1, -int(cols.min()),
                   int(cols.max()) - w + 1)
    framed = np.full((h + 2 * pad, w + 2 * pad), 2, dtype=np.uint8)
    framed[pad:pad + h, pad:pad + w] = code
    stamp = np.zeros(framed.shape, dtype=np.int32)
    wide = w + 2 * pad
    out = _union_kernel(framed.reshape(-1), wide, pad, rows, cols, offsets, dr_b, dc_b,
                        tr * wide + tc, ts, amb, count, stamp.reshape(-1))
    return out, stamp[pad:pad + h, pad:pad + w]


@nb.njit(cache=True)
def _union_kernel(code: NDArray[np.uint8], wide: int, pad: int, rows: NDArray[np.int64],
                  cols: NDArray[np.int64], offsets: NDArray[np.int64],
                  dr_b: NDArray[np.float64], dc_b: NDArray[np.float64],
                  step_at: NDArray[np.int64], ts: NDArray[np.int64], amb: NDArray[np.bool_],
                  count: NDArray[np.int64], stamp: NDArray[np.int32]) -> NDArray[np.int64]:
    """:func:`_union` on the framed grid (flat, rows ``wide`` long), with each kept
    step's flat offset from the viewpoint ``step_at``."""
    groups = offsets.size - 1
    beams = count.size
    out = np.zeros(groups, dtype=np.int64)
    for g in range(groups):
        tag = g + 1
        n_seen = 0
        for k in range(offsets[g], offsets[g + 1]):
            rr = rows[k]
            cc = cols[k]
            r0 = rr + 0.5
            c0 = cc + 0.5
            at = (rr + pad) * wide + cc + pad
            for b in range(beams):
                for j in range(count[b]):
                    if amb[b, j]:
                        i = ((math.floor(r0 + dr_b[b] * ts[b, j]) + pad) * wide
                             + math.floor(c0 + dc_b[b] * ts[b, j]) + pad)
                    else:
                        i = at + step_at[b, j]
                    v = code[i]
                    if v == 2:
                        break
                    if v == 1 and stamp[i] != tag:
                        stamp[i] = tag
                        n_seen += 1
        out[g] = n_seen
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
    code = _codes(view.unknown, ~view.unknown & ~view.free)
    range_cells = sensor_range / view.resolution
    if seen_from is not None:
        _, here = _union(code, np.array([seen_from[0]], dtype=np.int64),
                         np.array([seen_from[1]], dtype=np.int64), np.array([0, 1]),
                         range_cells, int(beams))
        code[here != 0] = 0  # seen from here: no longer counted (rays still pass)
        # the robot's cell itself (where every path ends) now sees nothing to count
        keep = (cells[:, 0] != seen_from[0]) | (cells[:, 1] != seen_from[1])
        if not keep.all():
            group = np.repeat(np.arange(len(paths)), np.diff(offsets))
            offsets[1:] = np.cumsum(np.bincount(group[keep], minlength=len(paths)))
            cells = cells[keep]
    return _union(code, np.ascontiguousarray(cells[:, 0]), np.ascontiguousarray(cells[:, 1]),
                  offsets, range_cells, int(beams))[0]
