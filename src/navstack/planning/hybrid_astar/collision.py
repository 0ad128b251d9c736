"""SE(2) footprint collision checks for Hybrid-A* (Nav2 ``GridCollisionChecker``).

Like Nav2, the footprint is rotated once per angle bin at configure time and a pose is
checked by reading the costmap cells under the pre-rotated footprint; a pose whose
centre cell is cheaper than the *possibly-inscribed* cost (the inflation cost at the
footprint's reach) cannot touch a lethal cell and costs one cell read.  Nav2 checks the
footprint placed at the centre of the cell with the bin's exact heading; here the sets
are *conservative* instead.  Each cell is split into :data:`SUBCELLS` x :data:`SUBCELLS`
sub-cells and there is one set per (bin, sub-cell): it holds every cell whose square the
polygon can overlap for any pose whose position lies within ``pose_slack`` cells
(Chebyshev) of the sub-cell centre and whose heading lies within ``heading_slack`` bins
of the bin centre.  Callers sample motions densely enough (:data:`SAMPLE_STEP` cells and
half a bin apart) that the continuous motion between two checked samples stays inside
that slack, so a path that passes these checks is collision-free along its whole
length, not only at its nodes.  The sub-cells keep the slack at 0.375 cells instead of
0.75 with one set per cell: in rooms about two robot lengths wide the wider margin
rejects manoeuvres that fit, and on the benchmark's 147k map it doubled the planning
time of the slowest plans (docs/hybrid_astar.md).

Collision means what Nav2's checker means: a LETHAL cell (or an unknown cell when
``allow_unknown`` is false, or a cell off the map) under the footprint, or a centre cell
that is INSCRIBED or worse.  Cells are ``(mx, my)`` of the (possibly downsampled) search
grid, ``data[my, mx]``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
)
from navstack.costmap.inflation_kernel import cell_distance, cost_lut

SAMPLE_STEP = 0.5
"""Largest spacing [cells] between two checked poses along any motion."""
HEADING_STEP = 0.5
"""Largest heading change [bins] between two checked poses along any motion."""
SUBCELLS = 4
"""Sub-cells per cell and axis; each has its own footprint cell sets."""
POSE_SLACK = 0.5 / SUBCELLS + 0.5 * SAMPLE_STEP
"""Position tolerance [cells, Chebyshev] of a cell set around its sub-cell's centre:
half a sub-cell (the sample is anywhere in its sub-cell) plus half a sample step."""
HEADING_SLACK = 0.5 + 0.5 * HEADING_STEP
"""Heading tolerance [bins] of a cell set: half a bin of rounding plus half a step."""


@nb.njit(cache=True)
def cheb_to_polygon(px: float, py: float, poly: NDArray[np.float64]) -> float:
    """Chebyshev (L-infinity) distance from ``(px, py)`` to the *filled* polygon (0 inside).

    Per edge ``a-b``, ``f(t) = max(|a_x + t d_x - p_x|, |a_y + t d_y - p_y|)`` is convex
    and piecewise linear in ``t``; its minimum lies at an end, a zero of one term or a
    crossing of the two, so evaluating those candidates is exact.
    """
    n = poly.shape[0]
    inside = False
    best = math.inf
    for i in range(n):
        ax, ay = poly[i, 0], poly[i, 1]
        bx, by = poly[(i + 1) % n, 0], poly[(i + 1) % n, 1]
        if (ay > py) != (by > py) and px < ax + (py - ay) * (bx - ax) / (by - ay):
            inside = not inside
        dx, dy = bx - ax, by - ay
        ux, uy = ax - px, ay - py
        best = min(best, max(abs(ux), abs(uy)), max(abs(ux + dx), abs(uy + dy)))
        for c in range(4):
            t = -1.0
            if c == 0 and dx != 0.0:
                t = -ux / dx
            elif c == 1 and dy != 0.0:
                t = -uy / dy
            elif c == 2 and dx != dy:
                t = (uy - ux) / (dx - dy)
            elif c == 3 and dx != -dy:
                t = (-uy - ux) / (dx + dy)
            if 0.0 < t < 1.0:
                best = min(best, max(abs(ux + t * dx), abs(uy + t * dy)))
    return 0.0 if inside else best


@nb.njit(cache=True)
def _bin_cells(poly: NDArray[np.float64], theta: float, half_range: float, n_head: int,
               reach: float, threshold: float, shift_x: float, shift_y: float
               ) -> NDArray[np.int32]:
    """Offsets ``(k, 2)`` within Chebyshev ``threshold`` of the polygon turned by any
    heading in ``theta +- half_range`` (sampled ``n_head`` times) and moved by
    ``(shift_x, shift_y)`` cells from the cell centre."""
    r = math.ceil(reach + threshold + max(abs(shift_x), abs(shift_y))) + 1
    out = np.empty(((2 * r + 1) ** 2, 2), dtype=np.int32)
    rot = np.empty_like(poly)
    best = np.full((2 * r + 1, 2 * r + 1), math.inf)
    for h in range(n_head):
        th = theta - half_range + 2.0 * half_range * h / max(n_head - 1, 1)
        c, s = math.cos(th), math.sin(th)
        for i in range(poly.shape[0]):
            rot[i, 0] = c * poly[i, 0] - s * poly[i, 1]
            rot[i, 1] = s * poly[i, 0] + c * poly[i, 1]
        for oy in range(-r, r + 1):
            for ox in range(-r, r + 1):
                if best[oy + r, ox + r] <= threshold:
                    continue
                d = cheb_to_polygon(ox - shift_x, oy - shift_y, rot)
                if d < best[oy + r, ox + r]:
                    best[oy + r, ox + r] = d
    k = 0
    for oy in range(-r, r + 1):
        for ox in range(-r, r + 1):
            if best[oy + r, ox + r] <= threshold:
                out[k, 0] = ox
                out[k, 1] = oy
                k += 1
    return out[:k]


class FootprintCells:
    """Per-(bin, sub-cell) conservative footprint cell offsets for one grid resolution.

    Set ``i = set_index(b, sx, sy)`` (bin ``b``, sub-cell column ``sx`` and row ``sy``)
    holds the ``(dx, dy)`` cell offsets, from the pose's cell, ``off_x/off_y[starts[2 i]:
    starts[2 i + 2]]``; ``reach`` is the largest centre-to-centre distance of any offset
    [cells] (used for the possibly-inscribed shortcut and the map-border margin).

    ``covered_d2``: offsets with ``dx^2 + dy^2 <= covered_d2`` form the set's *core*,
    stored last, from ``starts[2 i + 1]``.  The planner passes the largest squared cell
    distance the inflation marks INSCRIBED (the footprint's inscribed radius): a lethal
    cell that close makes the centre cell INSCRIBED, which :func:`pose_check` rejects
    before it reads the set, so away from the map's edge the core can never decide a
    check and is skipped (about a third of a 0.5 x 0.4 m footprint's cells at 5 cm); near
    the edge it is read, since a core cell off the map is a collision.  Only valid when
    the costmap was inflated with that radius and unknown cells are traversable (unknown
    cells are not inflated); otherwise keep the default ``-1`` (no core).
    """

    def __init__(self, polygon_m: NDArray[np.float64], resolution: float, bins: int,
                 pose_slack: float = POSE_SLACK, heading_slack: float = HEADING_SLACK,
                 covered_d2: int = -1) -> None:
        poly = np.ascontiguousarray(polygon_m, dtype=np.float64) / resolution
        radius = float(np.max(np.hypot(poly[:, 0], poly[:, 1])))
        bin_size = 2.0 * math.pi / bins
        half = heading_slack * bin_size
        # headings sampled every 1/8 bin; the rotation between samples moves a vertex by
        # at most radius * step / 2, added to the threshold to stay conservative
        n_head = max(2, math.ceil(2.0 * heading_slack * 8)) + 1
        rot_margin = radius * (2.0 * half / (n_head - 1)) * 0.5
        threshold = 0.5 + pose_slack + rot_margin
        sub = [(sx + 0.5) / SUBCELLS - 0.5 for sx in range(SUBCELLS)]
        sets = [_bin_cells(poly, b * bin_size, half, n_head, radius, threshold, sub[sx],
                           sub[sy])
                for b in range(bins) for sy in range(SUBCELLS) for sx in range(SUBCELLS)]
        parts = []
        for cells_i in sets:
            core = cells_i[:, 0] ** 2 + cells_i[:, 1] ** 2 <= covered_d2
            parts += [cells_i[~core], cells_i[core]]
        self.starts = np.zeros(len(parts) + 1, dtype=np.int64)
        self.starts[1:] = np.cumsum([len(part) for part in parts])
        cells = np.concatenate(parts)
        if int(np.abs(cells).max()) > np.iinfo(np.int16).max:
            raise ValueError(f"footprint reaches {int(np.abs(cells).max())} cells at "
                             f"{resolution} m: more than the int16 cell offsets hold; "
                             f"plan on a coarser grid (downsample_costmap)")
        # int16: the 16 sub-cell sets per bin are read in the innermost loop of the
        # search and stay cache-resident in a quarter of the int64 size
        self.off_x = np.ascontiguousarray(cells[:, 0], dtype=np.int16)
        self.off_y = np.ascontiguousarray(cells[:, 1], dtype=np.int16)
        self.reach = float(np.max(np.hypot(cells[:, 0], cells[:, 1])))
        self.border = math.ceil(self.reach) + 1
        self.resolution = resolution
        self.bins = bins

    def offsets(self, i: int) -> NDArray[np.int16]:
        """All offsets ``(k, 2)`` of set ``i``, core included."""
        sl = slice(self.starts[2 * i], self.starts[2 * i + 2])
        return np.column_stack((self.off_x[sl], self.off_y[sl]))


def possible_collision_cost(reach_cells: float, resolution: float, inscribed_radius: float,
                            inflation_radius: float, cost_scaling_factor: float) -> int:
    """Cost below which no lethal cell lies within ``reach_cells`` of a cell's centre.

    Nav2's ``findCircumscribedCost`` (inflation cost at the circumscribed radius), taken
    at the cell sets' reach: the inflation cost of a cell is ``lut[d2]`` of its squared
    cell distance to the nearest lethal cell and never decreases toward the obstacle, so
    ``cost < lut[floor(reach^2)]`` proves ``d2 > reach^2``.  Returns 0 (never shortcut)
    when the reach lies outside the inflation radius.
    """
    r_cells = cell_distance(inflation_radius, resolution)
    if r_cells <= 0:
        return 0
    lut = cost_lut(r_cells, resolution, inscribed_radius, cost_scaling_factor)
    # the reach is usually the root of an integer (an offset's length): a rounding error
    # must not drop the squared distance below it (8.06... = sqrt(65) squares to 64.99...)
    d2 = math.floor(reach_cells * reach_cells + 1e-6)
    if d2 > r_cells * r_cells:
        return 0
    return int(lut[d2])


@nb.njit(cache=True, inline="always")
def set_index(b: int, sx: int, sy: int) -> int:
    """Index of the cell set of bin ``b``, sub-cell column ``sx`` and row ``sy``."""
    return (b * SUBCELLS + sy) * SUBCELLS + sx


@nb.njit(cache=True, inline="always")
def pose_check(data: NDArray[np.uint8], x: float, y: float, b: int,
               off_x: NDArray[np.int16], off_y: NDArray[np.int16],
               starts: NDArray[np.int64], border: int, possible_cost: int,
               allow_unknown: bool) -> int:
    """Collision check of a pose at continuous cell coordinates ``(x, y)``, bin ``b``.

    Returns the centre cell's cost (0..255) when free, ``-1`` when in collision.
    Inlined into its callers (numba IR inlining).  The search kernel keeps its own copy as
    a closure (``search_run``'s ``check``; keep the two in step): even inlined, a call
    increments and decrements the reference count of every array argument, which in the
    search loop cost more than the check itself.
    """
    h, w = data.shape
    if x < 0.0 or y < 0.0:
        return -1
    cx = int(x)
    cy = int(y)
    if cx >= w or cy >= h:
        return -1
    c = int(data[cy, cx])
    if c == NO_INFORMATION:
        if not allow_unknown:
            return -1
    elif c >= INSCRIBED_INFLATED_OBSTACLE:
        return -1
    inside = border <= cx < w - border and border <= cy < h - border
    if c < possible_cost and inside:
        return c
    # the set of the bin and sub-cell (its core only near the edge, see FootprintCells):
    # lethal, off the map or (unless allowed) unknown cells -> collision
    i = set_index(b, min(int((x - cx) * SUBCELLS), SUBCELLS - 1),
                  min(int((y - cy) * SUBCELLS), SUBCELLS - 1))
    for k in range(starts[2 * i], starts[2 * i + 1] if inside else starts[2 * i + 2]):
        x_k = cx + off_x[k]
        y_k = cy + off_y[k]
        if x_k < 0 or y_k < 0 or x_k >= w or y_k >= h:
            return -1
        v = data[y_k, x_k]
        if v == LETHAL_OBSTACLE or (v == NO_INFORMATION and not allow_unknown):
            return -1
    return c


@nb.njit(cache=True)
def poses_check(data: NDArray[np.uint8], poses: NDArray[np.float64], bins: int,
                off_x: NDArray[np.int16], off_y: NDArray[np.int16],
                starts: NDArray[np.int64], border: int, possible_cost: int,
                allow_unknown: bool) -> NDArray[np.int64]:
    """:func:`pose_check` for ``(N, 3)`` poses ``(x, y, theta)`` in cell coordinates."""
    bin_size = 2.0 * math.pi / bins
    out = np.empty(poses.shape[0], dtype=np.int64)
    for i in range(poses.shape[0]):
        b = round(poses[i, 2] / bin_size) % bins
        out[i] = pose_check(data, poses[i, 0], poses[i, 1], b, off_x, off_y, starts, border,
                            possible_cost, allow_unknown)
    return out
