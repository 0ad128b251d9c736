"""Smac's built-in path smoother (Nav2 ``nav2_smac_planner::Smoother``), constrained.

Nav2 splits the path into directional segments at every cusp (forward <-> reverse), and
smooths each segment of more than 10 poses by gradient descent with fixed end points::

    y_i += w_data * (x_i - y_i) + w_smooth * (y_{i+1} + y_{i-1} - 2 y_i)

(Gauss-Seidel, in place) until the summed motion of one iteration drops below
``tolerance`` or ``max_iterations`` is reached; a converged pass is re-run on its own
result ``refinement_num`` times when ``do_refinement`` is set.  Headings are then
re-approximated from the neighbours (plus pi on reversing segments).

Pinned points (moved by no pass): segment ends and their neighbours (the end headings are
fixed; Nav2 instead re-fits the ends with Dubins curves), and points on the tightest arcs
(curvature >= :data:`TIGHT` of the limit), which smoothing would only tighten.

Nav2 abandons the smoothing of a segment when a pose lands in collision, and repairs the
ends with Dubins curves.  Here the result must keep both lattice guarantees, so after a
pass each segment is *checked*: curvature (the circle through every three consecutive
points, and the circle tangent to the fixed end heading through the next point) must
not exceed ``1 / minimum_turning_radius`` — or the raw path's value at that point, if
that was already higher — and the motion between consecutive poses must be free for the
footprint (the planner's conservative cell sets, sampled like the search).  Points that
fail are pinned to their raw positions together with a growing neighbourhood and the
pass is re-run; after :data:`MAX_ROUNDS` failed rounds the segment stays unsmoothed.
Cusps and segment ends never move, so reversals stay exactly where the search put them.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.planning.hybrid_astar.collision import HEADING_STEP, SAMPLE_STEP, pose_check

MAX_ROUNDS = 5
TIGHT = 0.9
"""Points whose unsmoothed curvature is at least this fraction of the limit stay put."""
DIRECT_MIN_ITERATIONS = 300
"""With at least this many iterations allowed the descent converges (its error shrinks
by ``1 - w_data`` per sweep), so its fixed point is solved directly instead."""
"""Points whose unsmoothed curvature is at least this fraction of the limit stay put."""
MIN_SEGMENT = 10
"""Nav2 smooths only segments with more than this many poses after the first."""


@nb.njit(cache=True)
def _descend(raw: NDArray[np.float64], fixed: NDArray[np.bool_], w_data: float,
             w_smooth: float, tolerance: float, max_its: int, passes: int,
             res: float) -> NDArray[np.float64]:
    """Nav2's gradient descent on positions ``(N, 2)`` [cells]; ``fixed`` points stay.

    ``tolerance`` is in metres (Nav2 smooths world coordinates), ``res`` converts.
    """
    n = raw.shape[0]
    anchor = raw.copy()
    out = raw.copy()
    for _ in range(passes):
        its = 0
        change = tolerance
        while change >= tolerance and its < max_its:
            its += 1
            change = 0.0
            for i in range(1, n - 1):
                if fixed[i]:
                    continue
                for d in range(2):
                    y = out[i, d]
                    y += w_data * (anchor[i, d] - y) + w_smooth * (
                        out[i + 1, d] + out[i - 1, d] - 2.0 * y)
                    change += abs(y - out[i, d]) * res
                    out[i, d] = y
        if change >= tolerance:  # not converged: Nav2 skips the refinement passes
            break
        for i in range(n):
            anchor[i, 0] = out[i, 0]
            anchor[i, 1] = out[i, 1]
    return out


@nb.njit(cache=True)
def _solve(raw: NDArray[np.float64], fixed: NDArray[np.bool_], w_data: float,
           w_smooth: float, passes: int) -> NDArray[np.float64]:
    """The fixed point of :func:`_descend`, solved directly (tridiagonal, Thomas).

    A converged descent satisfies, for every free point,
    ``(w_data + 2 w_smooth) y_i - w_smooth (y_{i-1} + y_{i+1}) = w_data x_i``; each
    sweep shrinks the error by at least ``1 - w_data``, so with Nav2's defaults the
    descent meets ``tolerance`` 1e-10 in about a hundred sweeps and this solve returns the
    same path (to that tolerance) in O(N).  Each refinement pass re-anchors on the result.
    """
    n = raw.shape[0]
    out = raw.copy()
    anchor = raw.copy()
    cp = np.empty(n)
    dp = np.empty(n)
    for _ in range(passes):
        for d in range(2):
            # forward sweep; a fixed point is the equation y_i = x_i
            cp[0] = 0.0
            dp[0] = anchor[0, d]
            for i in range(1, n):
                if fixed[i] or i == n - 1:
                    a, b, c, rhs = 0.0, 1.0, 0.0, anchor[i, d]
                else:
                    a, b, c = -w_smooth, w_data + 2.0 * w_smooth, -w_smooth
                    rhs = w_data * anchor[i, d]
                den = b - a * cp[i - 1]
                cp[i] = c / den
                dp[i] = (rhs - a * dp[i - 1]) / den
            out[n - 1, d] = dp[n - 1]
            for i in range(n - 2, -1, -1):
                out[i, d] = dp[i] - cp[i] * out[i + 1, d]
        for i in range(n):
            anchor[i, 0] = out[i, 0]
            anchor[i, 1] = out[i, 1]
    return out


@nb.njit(cache=True)
def curvatures(xy: NDArray[np.float64], h0: float, h1: float) -> NDArray[np.float64]:
    """Per-point curvature of a directional segment: tangent circles at both ends
    (through the neighbour, tangent to the travel headings ``h0`` / ``h1``), the
    three-point circle in between."""
    n = xy.shape[0]
    k = np.zeros(n)
    if n < 2:
        return k
    for e in range(2):  # circle through the end point, tangent to its heading
        i, j, hd = (0, 1, h0) if e == 0 else (n - 1, n - 2, h1)
        dx, dy = xy[j, 0] - xy[i, 0], xy[j, 1] - xy[i, 1]
        d2 = dx * dx + dy * dy
        if d2 > 1e-24:
            k[i] = 2.0 * abs(math.cos(hd) * dy - math.sin(hd) * dx) / d2
    for i in range(1, n - 1):  # Menger curvature: circle through three points
        ax, ay, bx, by = xy[i - 1, 0], xy[i - 1, 1], xy[i, 0], xy[i, 1]
        cx, cy = xy[i + 1, 0], xy[i + 1, 1]
        den = math.hypot(bx - ax, by - ay) * math.hypot(cx - bx, cy - by) * math.hypot(
            cx - ax, cy - ay)
        if den > 1e-12:
            k[i] = 2.0 * abs((bx - ax) * (cy - by) - (by - ay) * (cx - bx)) / den
    return k


@nb.njit(cache=True)
def headings(xy: NDArray[np.float64], h0: float, h1: float, reverse: bool) -> NDArray[np.float64]:
    """Robot headings along a segment: central differences inside, ``h0``/``h1`` (robot
    headings) at the ends; reversing segments face against the travel direction."""
    n = xy.shape[0]
    out = np.empty(n)
    out[0] = h0
    out[n - 1] = h1
    flip = math.pi if reverse else 0.0
    for i in range(1, n - 1):
        out[i] = math.atan2(xy[i + 1, 1] - xy[i - 1, 1], xy[i + 1, 0] - xy[i - 1, 0]) + flip
    return out


@nb.njit(cache=True)
def segment_blocked(xy: NDArray[np.float64], th: NDArray[np.float64], bins: int,
                    data: NDArray[np.uint8], off_x: NDArray[np.int16],
                    off_y: NDArray[np.int16], starts: NDArray[np.int64], border: int,
                    possible_cost: int, allow_unknown: bool) -> NDArray[np.bool_]:
    """``bad[i]``: the motion from pose ``i`` to ``i + 1`` (interpolated densely enough
    for the conservative cell sets) touches an obstacle."""
    n = xy.shape[0]
    bad = np.zeros(n, dtype=np.bool_)
    bin_size = 2.0 * math.pi / bins
    for i in range(n - 1):
        dth = math.atan2(math.sin(th[i + 1] - th[i]), math.cos(th[i + 1] - th[i]))
        dist = math.hypot(xy[i + 1, 0] - xy[i, 0], xy[i + 1, 1] - xy[i, 1])
        m = max(1, math.ceil(max(dist / SAMPLE_STEP, abs(dth) / (HEADING_STEP * bin_size))
                             - 1e-9))
        for j in range(1, m + 1):
            s = j / m
            x = xy[i, 0] + s * (xy[i + 1, 0] - xy[i, 0])
            y = xy[i, 1] + s * (xy[i + 1, 1] - xy[i, 1])
            b = round((th[i] + s * dth) / bin_size) % bins
            if pose_check(data, x, y, b, off_x, off_y, starts, border, possible_cost,
                          allow_unknown) < 0:
                bad[i] = True
                break
    return bad


def segments(direction: NDArray[np.int8]) -> list[tuple[int, int]]:
    """Index ranges ``[s, e]`` (inclusive) of constant travel direction; consecutive
    ranges share their cusp pose."""
    n = len(direction)
    if n < 2:
        return [(0, max(n - 1, 0))]
    change = np.nonzero(direction[2:] != direction[1:-1])[0] + 1
    bounds = [0, *change.tolist(), n - 1]
    return [(bounds[i], bounds[i + 1]) for i in range(len(bounds) - 1)]


def smooth(xyt: NDArray[np.float64], direction: NDArray[np.int8], *, kappa_max: float,
           w_data: float, w_smooth: float, tolerance: float, max_its: int, passes: int,
           res: float, bins: int, data: NDArray[np.uint8], off_x: NDArray[np.int16],
           off_y: NDArray[np.int16], starts: NDArray[np.int64], border: int,
           possible_cost: int, allow_unknown: bool) -> NDArray[np.float64]:
    """Smoothed copy of a path ``(N, 3)`` in cell coordinates (see module docstring)."""
    out = np.array(xyt, dtype=np.float64)
    if max_its <= 0:
        return out
    for s, e in segments(direction):
        if e - s <= MIN_SEGMENT:
            continue
        raw = np.ascontiguousarray(out[s:e + 1, :2])
        reverse = bool(direction[min(s + 1, e)] < 0)
        flip = math.pi if reverse else 0.0
        h0, h1 = float(out[s, 2]), float(out[e, 2])
        k_raw = curvatures(raw, h0 + flip, h1 + flip)
        limit = np.maximum(kappa_max * (1.0 + 1e-9), k_raw + 1e-12)
        # pinned from the start: both ends with their neighbours (the end headings are
        # fixed, so moving the neighbour would bend the path at the end) and the points
        # of the tightest arcs, which smoothing would only tighten further
        fixed = k_raw >= TIGHT * kappa_max
        fixed[:2] = True
        fixed[-2:] = True
        grow = 1
        for _ in range(MAX_ROUNDS):
            if max_its >= DIRECT_MIN_ITERATIONS and w_data > 0.0:
                xy = _solve(raw, fixed, w_data, w_smooth, passes)
            else:
                xy = _descend(raw, fixed, w_data, w_smooth, tolerance, max_its, passes, res)
            th = headings(xy, h0, h1, reverse)
            bad = curvatures(xy, h0 + flip, h1 + flip) > limit
            seg_bad = segment_blocked(xy, th, bins, data, off_x, off_y, starts, border,
                                      possible_cost, allow_unknown)
            bad[:-1] |= seg_bad[:-1]
            bad[1:] |= seg_bad[:-1]
            if not bad.any():
                out[s:e + 1, :2] = xy
                out[s:e + 1, 2] = th
                break
            for i in np.nonzero(bad)[0].tolist():
                fixed[max(0, i - grow):i + grow + 1] = True
            grow *= 2
    return out
