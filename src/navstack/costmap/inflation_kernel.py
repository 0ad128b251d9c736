"""Exact truncated Euclidean distance transform fused with Nav2's inflation cost lookup.

Nav2's ``InflationLayer`` propagates a brushfire from every lethal cell in order of
distance.  Here the same costs come from an *exact* squared Euclidean distance transform
(EDT) of the seed mask, computed in two separable passes (Felzenszwalb & Huttenlocher,
"Distance Transforms of Sampled Functions", Theory of Computing 8, 2012):

1. per column, the vertical cell distance ``g`` to the nearest seed, capped at ``R + 1``
   (``R`` = inflation radius in cells; larger distances cannot matter);
2. per row, ``d2(q) = min_p (q - p)^2 + g(p)^2``.  Each row picks the cheaper of two exact
   evaluations: a vectorised min-plus sweep over ``|q - p| <= D`` where ``D`` is the
   largest ``g`` in a block of cells (dense obstacles -> tiny ``D``), or the lower
   envelope of parabolas (few seeds within reach -> few parabolas).

Squared distances are integers, so the cost table is indexed by ``d2`` exactly:
``lut[d2] = cost(sqrt(d2))`` for ``d2 <= R^2``; further cells are not inflated - the same
``distance <= cell_inflation_radius`` cut-off Nav2 applies.  Measured on a 2000x2000 grid
with 50 % random lethal cells and R = 40 this takes ~20 ms; ``scipy.ndimage.
distance_transform_edt`` alone takes ~450 ms on the same grid, so it is not used.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    MAX_NON_OBSTACLE,
)

_BLOCK = 128


def cost_lut(radius_cells: int, resolution: float, inscribed_radius: float,
             cost_scaling_factor: float, extra_radius: float = 0.0) -> NDArray[np.uint8]:
    """Cost per squared cell distance ``0..R^2``, plus a trailing 0 for "beyond R".

    Nav2 ``InflationLayer::computeCost``: distance 0 -> LETHAL (254); ``d <= inscribed``
    -> INSCRIBED (253); else ``int(252 * exp(-k * (d - inscribed)))``.  ``extra_radius``
    (uncertainty-aware inflation) shifts the decay outward: cells with
    ``inscribed < d <= inscribed + extra`` get MAX_NON_OBSTACLE (252) and the exponential
    starts at ``inscribed + extra``.
    """
    d2 = np.arange(radius_cells * radius_cells + 1, dtype=np.float64)
    d = np.sqrt(d2) * resolution
    start = inscribed_radius + extra_radius
    decay = np.floor((INSCRIBED_INFLATED_OBSTACLE - 1)
                     * np.exp(-cost_scaling_factor * np.maximum(d - start, 0.0)))
    cost = np.minimum(decay, MAX_NON_OBSTACLE)
    cost[d <= inscribed_radius] = INSCRIBED_INFLATED_OBSTACLE
    cost[0] = LETHAL_OBSTACLE
    return np.concatenate([cost, [0.0]]).astype(np.uint8)


@numba.njit(cache=True)
def _vertical_distance(data: NDArray[np.uint8], ex0: int, ey0: int, ex1: int, ey1: int,
                       cap: int, seed_unknown: bool) -> NDArray[np.int32]:
    """``g[y, x]``: cells to the nearest seed in the same column, capped at ``cap``."""
    h = ey1 - ey0
    w = ex1 - ex0
    g = np.empty((h, w), np.int32)
    first = data[ey0, ex0:ex1]
    g0 = g[0]
    for x in range(w):
        v = first[x]
        g0[x] = 0 if (v == 254) | (seed_unknown & (v == 255)) else cap
    for y in range(1, h):
        cur = g[y]
        prev = g[y - 1]
        row = data[ey0 + y, ex0:ex1]
        for x in range(w):
            v = row[x]
            t = min(prev[x] + 1, cap)
            cur[x] = 0 if (v == 254) | (seed_unknown & (v == 255)) else t
    for y in range(h - 2, -1, -1):
        cur = g[y]
        nxt = g[y + 1]
        for x in range(w):
            cur[x] = min(cur[x], nxt[x] + 1)
    return g


@numba.njit(cache=True)
def _inflate(data: NDArray[np.uint8], ex0: int, ey0: int, ex1: int, ey1: int, bx0: int,
             by0: int, bx1: int, by1: int, radius: int, lut: NDArray[np.uint8],
             seed_unknown: bool, inflate_unknown: bool) -> None:
    cap = radius + 1
    r2 = radius * radius
    g = _vertical_distance(data, ex0, ey0, ex1, ey1, cap, seed_unknown)
    w = ex1 - ex0
    qa = bx0 - ex0
    wb = bx1 - bx0
    nb = (wb + _BLOCK - 1) // _BLOCK
    gp = np.full(w + 2 * radius, cap * cap, np.int32)  # padded g^2 row
    inner = gp[radius:radius + w]
    out = np.empty(wb, np.int32)
    fidx = np.empty(w, np.int64)
    fval = np.empty(w, np.int64)
    env = np.empty(w, np.int64)
    z = np.empty(w + 1, np.float64)
    bmax = np.empty(nb, np.int64)
    for yy in range(by0, by1):
        grow = g[yy - ey0]
        n = 0
        for q in range(w):
            gq = grow[q]
            inner[q] = gq * gq
            if gq < cap:
                fidx[n] = q
                fval[n] = gq * gq + q * q
                n += 1
        if n == 0:
            continue
        work = 0
        for b in range(nb):
            seg = grow[qa + b * _BLOCK:qa + min(wb, (b + 1) * _BLOCK)]
            m = 0
            for i in range(seg.shape[0]):
                m = max(m, seg[i])
            m = min(m, radius)
            bmax[b] = m
            work += m * seg.shape[0]
        if work * 3 <= 50 * wb + 220 * n:
            # min-plus sweep, exact because d2(q) <= g(q)^2 bounds the useful |q - p|
            for b in range(nb):
                lo = b * _BLOCK
                hi = min(wb, lo + _BLOCK)
                o = out[lo:hi]
                c0 = gp[radius + qa + lo:radius + qa + hi]
                for i in range(hi - lo):
                    o[i] = c0[i]
                for dx in range(1, bmax[b] + 1):
                    dd = dx * dx
                    left = gp[radius + qa + lo - dx:radius + qa + hi - dx]
                    right = gp[radius + qa + lo + dx:radius + qa + hi + dx]
                    for i in range(hi - lo):
                        o[i] = min(o[i], min(left[i], right[i]) + dd)
        else:
            # lower envelope of the parabolas (q - p)^2 + g(p)^2 over the finite g(p)
            k = 0
            env[0] = 0
            z[0] = -np.inf
            z[1] = np.inf
            for j in range(1, n):
                fq = fval[j]
                q = fidx[j]
                s = 0.0
                while True:
                    p = env[k]
                    s = (fq - fval[p]) / (2.0 * (q - fidx[p]))
                    if s <= z[k]:
                        k -= 1
                    else:
                        break
                k += 1
                env[k] = j
                z[k] = s
                z[k + 1] = np.inf
            k = 0
            for i in range(wb):
                q = qa + i
                while z[k + 1] < q:
                    k += 1
                p = fidx[env[k]]
                out[i] = (q - p) * (q - p) + grow[p] * grow[p]
        row = data[yy, bx0:bx1]
        for i in range(wb):
            c = lut[min(out[i], r2 + 1)]
            old = row[i]
            mx = max(c, old)
            take = (old == 255) & ((c >= 253) | (inflate_unknown & (c > 0)))
            row[i] = c if take else mx


def inflate(data: NDArray[np.uint8], seed_window: tuple[int, int, int, int],
            write_window: tuple[int, int, int, int], radius_cells: int,
            lut: NDArray[np.uint8], inflate_around_unknown: bool = False,
            inflate_unknown: bool = False) -> None:
    """Inflate ``data`` in place.

    Seeds (LETHAL cells, and NO_INFORMATION cells if ``inflate_around_unknown``) are read
    from ``seed_window`` = ``(x0, y0, x1, y1)`` (half-open); costs are written only inside
    ``write_window`` (which must lie within ``seed_window``) with Nav2's combination rule:
    ``max(old, cost)``, except that an unknown cell takes ``cost`` only if it is at least
    INSCRIBED (or, with ``inflate_unknown``, any non-zero cost).
    """
    ex0, ey0, ex1, ey1 = seed_window
    bx0, by0, bx1, by1 = write_window
    if not (ex0 <= bx0 <= bx1 <= ex1 and ey0 <= by0 <= by1 <= ey1):
        raise ValueError(f"write window {write_window} must lie inside seed window "
                         f"{seed_window}")
    if bx1 <= bx0 or by1 <= by0 or radius_cells <= 0:
        return
    if len(lut) != radius_cells * radius_cells + 2:
        raise ValueError(f"lut must have R^2 + 2 = {radius_cells ** 2 + 2} entries, "
                         f"got {len(lut)}")
    _inflate(data, ex0, ey0, ex1, ey1, bx0, by0, bx1, by1, int(radius_cells), lut,
             bool(inflate_around_unknown), bool(inflate_unknown))


def cell_distance(world_dist: float, resolution: float) -> int:
    """Nav2 ``Costmap2D::cellDistance`` (truncation), robust to float error (0.3/0.1 -> 3)."""
    return math.floor(world_dist / resolution + 1e-9)
