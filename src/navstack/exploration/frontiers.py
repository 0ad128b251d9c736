"""Frontier search on a :class:`GridView`, with explore_lite's definitions and path
distances.

explore_lite (``frontier_search.cpp``) defines

* a *frontier cell*: an unknown cell with at least one free 4-neighbour;
* a *frontier*: an 8-connected group of frontier cells, kept when its size in metres
  (cells x resolution) is at least ``min_frontier_size``;
* its ``centroid`` (mean of its cells, the goal explore_lite sends) and ``min_distance``
  (straight-line distance from the robot to its nearest cell).

Here the distance is the *path* distance: a wavefront (:mod:`.wavefront`) from the robot
through the traversable cells (where the robot centre may be), so a frontier behind a
wall is as far as the way round it, and a frontier that no traversable path reaches --
one seen through a gap narrower than the robot -- is *unreachable* and reported apart
instead of being sent to the navigator.  A frontier's *approach cells* are the reached
traversable cells within ``frontier_reach`` of it (the robot need not stand on unknown
space to observe it); its ``distance`` is the nearest approach cell's path distance and
its ``goal`` the approach cell nearest its centroid (explore_lite's centroid goal moved
to where the robot can stand).  Blacklisted cells (:class:`~.blacklist.Blacklist`) are
removed before grouping, as explore_lite skips blacklisted goals.

Everything is vectorised numpy/scipy; the wavefront and the line-of-sight test are numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from navstack.exploration.grid_view import BoolArray, FloatArray, GridView
from navstack.exploration.wavefront import Wavefront

IntArray = NDArray[np.int64]

__all__ = ["Frontier", "FrontierSet", "find_frontiers", "frontier_cells"]

_EIGHT = np.ones((3, 3), dtype=bool)


def frontier_cells(view: GridView) -> BoolArray:
    """Unknown cells with a free 4-neighbour (explore_lite ``isNewFrontierCell``)."""
    free = view.free
    nb = np.zeros_like(free)
    nb[1:, :] |= free[:-1, :]
    nb[:-1, :] |= free[1:, :]
    nb[:, 1:] |= free[:, :-1]
    nb[:, :-1] |= free[:, 1:]
    return view.unknown & nb


@dataclass(frozen=True)
class Frontier:
    """One frontier: its cells, size, centroid and how the robot reaches it."""

    label: int
    rows: IntArray
    cols: IntArray
    size: int
    """Number of cells (explore_lite ``size``)."""
    size_m: float
    """``size * resolution`` [m], what ``min_frontier_size`` is compared with."""
    centroid: tuple[float, float]
    distance: float
    """Path distance [m] to the nearest approach cell (``inf``: unreachable)."""
    goal: tuple[float, float] | None
    """The approach cell nearest the centroid (``None``: unreachable)."""
    nearest: tuple[float, float] | None
    """The approach cell nearest the robot by path."""
    approach_rows: IntArray = field(default_factory=lambda: np.zeros(0, np.int64))
    approach_cols: IntArray = field(default_factory=lambda: np.zeros(0, np.int64))

    @property
    def reachable(self) -> bool:
        return math.isfinite(self.distance)

    def points(self, view: GridView) -> FloatArray:
        """``(size, 2)`` world centres of the frontier's cells."""
        return view.centres(self.rows, self.cols)


@dataclass(frozen=True)
class FrontierSet:
    """Result of :func:`find_frontiers`."""

    reachable: list[Frontier]
    unreachable: list[Frontier]
    distances: FloatArray
    """Path distance [m] from the robot to every cell (inf: unreachable)."""
    start: tuple[int, int] | None
    """The wavefront's start cell (the robot's, or the nearest traversable one)."""
    mask: BoolArray
    """Frontier cells after the blacklist, before the size filter."""
    too_small: int = 0
    """Frontiers dropped by ``min_frontier_size``."""

    @property
    def all(self) -> list[Frontier]:
        return [*self.reachable, *self.unreachable]


def find_frontiers(view: GridView, robot_xy: tuple[float, float], *,
                   min_frontier_size: float = 0.5, frontier_reach: float = 0.3,
                   start_search_radius: float = 1.0, blacklist: BoolArray | None = None,
                   wavefront: Wavefront | None = None, goal_clearance: float = 0.0,
                   goal_reach: float = 1.0) -> FrontierSet:
    """All frontiers of ``view`` seen from the robot at ``robot_xy`` (module docstring).

    ``start_search_radius`` [m]: when the robot's cell is not traversable (it touches a
    wall) the wavefront starts from the nearest traversable cell within this radius.
    ``blacklist``: cells that may not be frontier cells.  Reachable frontiers come sorted
    by distance.

    ``goal_clearance`` [m] > 0: approach only from cells where the robot can turn round
    (at least this far from every obstacle cell -- the footprint's circumscribed radius):
    a frontier's approach cells are its *roomy* cells within ``frontier_reach``, else its
    roomy cells within ``goal_reach`` that see it (no obstacle cell on the straight line
    to its nearest cell), else -- a frontier only tight spots reach -- the cells within
    ``frontier_reach`` as without the option.  A goal the robot cannot turn round at
    leaves it wedged for the next one (office runs: 18 frontiers blacklisted after
    timeouts in such spots, and a return home that RPP refused).
    """
    res = view.resolution
    wf = wavefront or Wavefront()
    robot = view.cell_of(*robot_xy)
    dist, start, _ = wf.distances_from_any(view.traversable, robot, res,
                                           start_search_radius / res)
    mask = frontier_cells(view)
    if blacklist is not None:
        mask &= ~blacklist
    labels, n = ndimage.label(mask, structure=_EIGHT)
    if n == 0:
        return FrontierSet([], [], dist, start, mask)
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    keep = sizes * res >= min_frontier_size - 1e-9
    keep[0] = False
    too_small = int(n - keep[1:].sum())
    if not keep.any():
        return FrontierSet([], [], dist, start, mask, too_small)
    # approach cells: reached traversable cells within frontier_reach of a kept frontier;
    # each takes the label of the frontier cell nearest to it
    kept_labels = np.where(keep[labels], labels, 0)
    reach_cells = max(1, math.ceil(frontier_reach / res - 1e-9))
    roomy_goals = goal_clearance > 0.0
    far_cells = max(reach_cells, math.ceil(goal_reach / res - 1e-9)) if roomy_goals \
        else reach_cells
    # only cells within far_cells of a kept frontier cell matter: find each one's nearest
    # frontier cell by painting the far_cells disc around every kept cell on their
    # bounding box grown by that much (on a warehouse-size map the box's distance
    # transform was a sixth of an exploration's CPU time)
    kr, kc = np.nonzero(kept_labels)
    r0, r1 = max(0, int(kr.min()) - far_cells - 1), int(kr.max()) + far_cells + 2
    c0, c1 = max(0, int(kc.min()) - far_cells - 1), int(kc.max()) + far_cells + 2
    box = (slice(r0, r1), slice(c0, c1))
    nearest_sq, ir, ic = nearest_within(kr - r0, kc - c0, kept_labels[box].shape, far_cells)
    reached = np.isfinite(dist[box]) & view.traversable[box] & (nearest_sq <= far_cells ** 2)
    br, bc = np.nonzero(reached)
    alabel = kept_labels[box][ir[br, bc], ic[br, bc]]
    near = nearest_sq[br, bc] <= reach_cells ** 2
    roomy = np.zeros(br.size, dtype=bool)
    if roomy_goals and br.size:
        roomy = _roomy_at(view, br + r0, bc + c0, goal_clearance)
        far = roomy & ~near
        if far.any():  # a roomy cell beyond frontier_reach must see its frontier cell
            k = np.flatnonzero(far)
            roomy[k] = _sees(view, br[k] + r0, bc[k] + c0, ir[br[k], bc[k]] + r0,
                             ic[br[k], bc[k]] + c0)
    ar, ac = br + r0, bc + c0
    order = np.argsort(alabel, kind="stable")
    ar, ac, alabel = ar[order], ac[order], alabel[order]
    near, roomy = near[order], roomy[order]
    bounds = np.searchsorted(alabel, np.arange(n + 2))
    fr, fc = kr, kc  # the kept cells, row-major as np.nonzero gives them
    flab = kept_labels[fr, fc]
    forder = np.argsort(flab, kind="stable")
    fr, fc, flab = fr[forder], fc[forder], flab[forder]
    fbounds = np.searchsorted(flab, np.arange(n + 2))
    reachable: list[Frontier] = []
    unreachable: list[Frontier] = []
    for lab in np.flatnonzero(keep):
        rows = fr[fbounds[lab]:fbounds[lab + 1]].astype(np.int64)
        cols = fc[fbounds[lab]:fbounds[lab + 1]].astype(np.int64)
        pts = view.centres(rows, cols)
        centroid = (float(pts[:, 0].mean()), float(pts[:, 1].mean()))
        span = slice(bounds[lab], bounds[lab + 1])
        pick = _approach(near[span], roomy[span])
        rr = ar[span][pick].astype(np.int64)
        cc = ac[span][pick].astype(np.int64)
        if rr.size == 0:
            unreachable.append(Frontier(int(lab), rows, cols, int(rows.size),
                                        rows.size * res, centroid, math.inf, None, None))
            continue
        d = dist[rr, cc]
        approach = view.centres(rr, cc)
        k_near = int(np.argmin(d))
        k_goal = int(np.argmin(np.hypot(approach[:, 0] - centroid[0],
                                        approach[:, 1] - centroid[1])))
        reachable.append(Frontier(
            int(lab), rows, cols, int(rows.size), rows.size * res, centroid, float(d[k_near]),
            (float(approach[k_goal, 0]), float(approach[k_goal, 1])),
            (float(approach[k_near, 0]), float(approach[k_near, 1])), rr, cc))
    reachable.sort(key=lambda f: f.distance)
    return FrontierSet(reachable, unreachable, dist, start, mask, too_small)


def nearest_within(rows: IntArray, cols: IntArray, shape: tuple[int, int], radius: int
                   ) -> tuple[IntArray, IntArray, IntArray]:
    """Per cell of an ``shape`` grid, the squared distance [cells^2] to the nearest of the
    cells ``rows``, ``cols`` and that cell's row and column, for the cells within
    ``radius`` cells of one (elsewhere the squared distance is ``> radius**2`` and the
    row and column are meaningless).

    The nearest cell is the one :func:`scipy.ndimage.distance_transform_edt` returns
    with ``return_indices``: among equally near cells, the smallest column, then the
    smallest row (its lower-envelope scans keep the earlier candidate on a tie; tested
    against it).  Cost: ``len(rows)`` discs instead of the whole grid."""
    dr, dc = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    sq = dr * dr + dc * dc
    inside = sq <= radius * radius
    offsets = np.column_stack((dr[inside], dc[inside], sq[inside])).astype(np.int64)
    return _nearest_kernel(np.asarray(rows, np.int64), np.asarray(cols, np.int64),
                           int(shape[0]), int(shape[1]), offsets, radius * radius + 1)


@nb.njit(cache=True)
def _nearest_kernel(rows: IntArray, cols: IntArray, h: int, w: int, offsets: IntArray,
                    beyond: int) -> tuple[IntArray, IntArray, IntArray]:
    best = np.full((h, w), beyond, dtype=np.int64)
    ir = np.empty((h, w), dtype=np.int64)  # read only where best was set
    ic = np.empty((h, w), dtype=np.int64)
    for i in range(rows.size):
        fr = rows[i]
        fc = cols[i]
        for k in range(offsets.shape[0]):
            r = fr + offsets[k, 0]
            c = fc + offsets[k, 1]
            if r < 0 or c < 0 or r >= h or c >= w:
                continue
            n = offsets[k, 2]
            b = best[r, c]
            if n < b or (n == b and (fc < ic[r, c] or (fc == ic[r, c] and fr < ir[r, c]))):
                best[r, c] = n
                ir[r, c] = fr
                ic[r, c] = fc
    return best, ir, ic


def _approach(near: BoolArray, roomy: BoolArray) -> BoolArray:
    """Which candidate cells approach a frontier (:func:`find_frontiers`' order of
    preference: roomy and near, roomy and seeing it, near)."""
    for pick in (near & roomy, roomy, near):
        if pick.any():
            return pick
    return near


def _roomy(view: GridView, box: tuple[int, int, int, int], clearance: float) -> BoolArray:
    """Cells of ``box`` (r0, r1, c0, c1) at least ``clearance`` [m] (+ half a cell for
    the cells' extent) from every obstacle cell of ``view``; exact within the box (the
    transform runs on the box grown by the clearance)."""
    r0, r1, c0, c1 = box
    res = view.resolution
    k = math.ceil(clearance / res) + 1
    h, w = view.shape
    g0, g1 = max(0, r0 - k), min(h, r1 + k)
    h0, h1 = max(0, c0 - k), min(w, c1 + k)
    occupied = ~view.unknown[g0:g1, h0:h1] & ~view.free[g0:g1, h0:h1]
    if not occupied.any():
        clear = np.ones(occupied.shape, dtype=bool)
    else:
        clear = ndimage.distance_transform_edt(~occupied, sampling=res) >= clearance + res / 2
    out = np.zeros((r1 - r0, c1 - c0), dtype=bool)
    rr0, cc0 = r0 - g0, c0 - h0
    inner = clear[rr0:rr0 + min(r1, h) - r0, cc0:cc0 + min(c1, w) - c0]
    out[:inner.shape[0], :inner.shape[1]] = inner
    return out


def _clearance_offsets(res: float, threshold: float) -> IntArray | None:
    """``(K, 2)`` cell offsets whose distance, computed as scipy's distance transform
    computes it (``sqrt((dr res)^2 + (dc res)^2)``), is below ``threshold``; ``None``
    when offsets at one squared cell distance fall on both sides of it (the transform's
    answer would then depend on which nearest cell it picks)."""
    k = math.ceil(threshold / res) + 1
    dr, dc = np.mgrid[-k:k + 1, -k:k + 1]
    a, b = dr.astype(np.float64) * res, dc.astype(np.float64) * res
    d = np.sqrt(a * a + b * b)
    n = dr * dr + dc * dc
    below = d < threshold
    if np.intersect1d(n[below], n[~below]).size:
        return None
    return np.column_stack((dr[below], dc[below])).astype(np.int64)


def _roomy_at(view: GridView, rows: IntArray, cols: IntArray, clearance: float) -> BoolArray:
    """:func:`_roomy` at the cells ``rows``, ``cols`` only: a cell is roomy when no
    obstacle cell lies within the clearance of it -- the transform's comparison, looked
    up around each cell (on a warehouse map the transform of the frontiers' box was a
    tenth of the exploration's CPU time)."""
    if rows.size == 0:
        return np.zeros(0, dtype=bool)
    res = view.resolution
    offsets = _clearance_offsets(res, clearance + res / 2)
    if offsets is None:  # ambiguous threshold: the transform decides
        r0, c0 = int(rows.min()), int(cols.min())
        box = (r0, int(rows.max()) + 1, c0, int(cols.max()) + 1)
        return _roomy(view, box, clearance)[rows - r0, cols - c0]
    occupied = ~view.unknown & ~view.free
    # the offsets' distance grows with |column offset| along each row offset: per row
    # offset they are one run of columns, -m..m
    d_rows = np.unique(offsets[:, 0])
    half = np.array([offsets[offsets[:, 0] == d, 1].max() for d in d_rows], dtype=np.int64)
    return _clear_kernel(occupied, rows.astype(np.int64), cols.astype(np.int64),
                         d_rows.astype(np.int64), half)


@nb.njit(cache=True)
def _clear_kernel(occupied: BoolArray, rows: IntArray, cols: IntArray, d_rows: IntArray,
                  half: IntArray) -> BoolArray:
    """Whether no occupied cell lies at row ``rows[i] + d_rows[k]`` within columns
    ``cols[i] +- half[k]`` (off-grid cells are not occupied): a run is looked up in a
    per-row running count of occupied cells, two reads instead of one per cell."""
    h, w = occupied.shape
    run = np.zeros((h, w + 1), dtype=np.int32)  # run[r, c]: occupied cells left of c
    for r in range(h):
        for c in range(w):
            run[r, c + 1] = run[r, c] + occupied[r, c]
    out = np.ones(rows.size, dtype=np.bool_)
    for i in range(rows.size):
        for k in range(d_rows.size):
            r = rows[i] + d_rows[k]
            if r < 0 or r >= h:
                continue
            lo = max(cols[i] - half[k], 0)
            hi = min(cols[i] + half[k] + 1, w)
            if lo < hi and run[r, hi] != run[r, lo]:
                out[i] = False
                break
    return out


def _sees(view: GridView, rows: IntArray, cols: IntArray, trows: IntArray,
          tcols: IntArray) -> BoolArray:
    """Whether the straight line from each cell to its target cell crosses no obstacle
    cell (sampled at a quarter cell, the same samples for every line: as many as the
    longest line needs)."""
    occupied = ~view.unknown & ~view.free
    steps = int(max(np.abs(trows - rows).max(), np.abs(tcols - cols).max())) * 4 + 1
    t = np.linspace(0.0, 1.0, steps + 1)
    return _sees_kernel(occupied, t, rows.astype(np.int64), cols.astype(np.int64),
                        trows.astype(np.int64), tcols.astype(np.int64))


@nb.njit(cache=True)
def _sees_kernel(occupied: BoolArray, t: FloatArray, rows: IntArray, cols: IntArray,
                 trows: IntArray, tcols: IntArray) -> BoolArray:
    """:func:`_sees` per line, stopping at its first obstacle sample (the vectorised form
    sampled every line in full: a fifth of a warehouse frontier search)."""
    out = np.ones(rows.size, dtype=np.bool_)
    for i in range(rows.size):
        r0 = rows[i] + 0.5
        c0 = cols[i] + 0.5
        dr = float(trows[i] - rows[i])
        dc = float(tcols[i] - cols[i])
        for k in range(t.size):
            if occupied[math.floor(r0 + t[k] * dr), math.floor(c0 + t[k] * dc)]:
                out[i] = False
                break
    return out
