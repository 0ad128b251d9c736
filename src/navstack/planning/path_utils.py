"""Path helpers shared by the grid planners: cells -> world, orientations, smoothing.

Smoothing follows Nav2's ``nav2_smoother::SimpleSmoother`` (parameters ``tolerance``,
``max_its``, ``w_data``, ``w_smooth``, ``do_refinement``, ``refinement_num``, Nav2's
defaults): Gauss-Seidel gradient descent that pulls every interior point toward its
original position (``w_data``) and toward the midpoint of its neighbours
(``w_smooth``), end points fixed.  Unlike Nav2, which abandons the whole iteration when a
point lands in collision, an update that would put a point — or the segments to its
neighbours — into a cell of cost >= INSCRIBED (or unknown, unless allowed) is simply not
taken, so the result is always collision free and smoothing continues elsewhere.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.msgs import Path
from navstack.core.params import Params
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION, Costmap2D


class SimpleSmootherParams(Params):
    """Nav2 ``SimpleSmoother`` parameters (same names and defaults)."""

    tolerance: float = Field(1e-10, gt=0.0)
    max_its: int = Field(1000, ge=1)
    w_data: float = Field(0.2, ge=0.0)
    w_smooth: float = Field(0.3, ge=0.0)
    do_refinement: bool = True
    refinement_num: int = Field(2, ge=1)


def cells_to_world(cells: NDArray[np.integer] | NDArray[np.floating],
                   costmap: Costmap2D) -> NDArray[np.float64]:
    """``(K, 2)`` cell coordinates ``(mx, my)`` -> ``(K, 2)`` world points [m]: an integer
    cell gives its centre, fractional coordinates (cell centre at the integer) scale
    alike."""
    c = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
    return np.column_stack((costmap.origin_x + (c[:, 0] + 0.5) * costmap.resolution,
                            costmap.origin_y + (c[:, 1] + 0.5) * costmap.resolution))


def path_length(xy: NDArray[np.float64]) -> float:
    """Sum of segment lengths of an ``(N, 2)`` polyline [m]."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 2:
        return 0.0
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T)))


def thin_points(xy: NDArray[np.float64], spacing: float, costmap: Costmap2D | None = None,
                allow_unknown: bool = False) -> NDArray[np.float64]:
    """The points of an ``(N, 2)`` polyline nearest to every ``spacing`` metres of arc
    length (first and last kept, no repeats): a dense path (a gradient descent's
    half-cell steps) reduced to its shape.  With ``costmap``, a chord that would cross an
    inscribed or lethal cell (or unknown, unless allowed) keeps the points between its
    ends, halving until every chord is free -- the thinned path is as safe as the dense
    one."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 3:
        return xy.copy()
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
    n = max(1, round(s[-1] / spacing))
    at = np.linspace(0.0, s[-1], n + 1)
    idx = np.unique(np.concatenate(([0], np.searchsorted(s, at).clip(0, len(xy) - 1),
                                    [len(xy) - 1])))
    if costmap is None:
        return xy[idx]
    keep: list[int] = [int(idx[0])]
    todo = [int(i) for i in idx[:0:-1]]  # a stack: the next end on top
    while todo:
        a, b = keep[-1], todo[-1]
        if b - a > 1 and _segment_blocked(xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1],
                                          costmap.data, costmap.origin_x, costmap.origin_y,
                                          costmap.resolution, allow_unknown):
            todo.append((a + b) // 2)
            continue
        keep.append(todo.pop())
    return xy[keep]


def orientations(xy: NDArray[np.float64], goal_theta: float,
                 final_approach: bool = False) -> NDArray[np.float64]:
    """Heading of every pose: along the next segment, ``goal_theta`` at the end.

    With ``final_approach`` (Nav2 ``use_final_approach_orientation``) the last pose keeps
    the heading of the last segment instead of the goal's orientation.  Repeated points
    take the heading of the previous pose.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    n = len(xy)
    theta = np.full(n, float(goal_theta))
    if n < 2:
        return theta
    d = np.diff(xy, axis=0)
    seg = np.arctan2(d[:, 1], d[:, 0])
    moving = np.hypot(d[:, 0], d[:, 1]) > 1e-12
    # a zero-length segment inherits the previous heading (forward fill)
    idx = np.where(moving, np.arange(n - 1), 0)
    np.maximum.accumulate(idx, out=idx)
    seg = np.where(moving[idx], seg[idx], goal_theta)
    theta[:-1] = seg
    if final_approach:
        theta[-1] = seg[-1]
    return theta


def make_path(xy: NDArray[np.float64], goal_theta: float, frame_id: str,
              final_approach: bool = False, stamp: float = 0.0) -> Path:
    """nav_msgs ``Path`` through ``xy`` with headings along the path."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    theta = orientations(xy, goal_theta, final_approach)
    return Path.from_array(np.column_stack((xy, theta)), frame_id=frame_id, stamp=stamp)


@nb.njit(cache=True)
def _segment_blocked(x0: float, y0: float, x1: float, y1: float, data: NDArray[np.uint8],
                     ox: float, oy: float, res: float, unknown_ok: bool) -> bool:
    """True if any cell the segment passes through is blocked (exact grid traversal,
    Amanatides & Woo 1987): inscribed or lethal, off the grid, or unknown unless
    ``unknown_ok``."""
    unknown_cost = 0 if unknown_ok else NO_INFORMATION
    return _chord_max_cost(x0, y0, x1, y1, data, ox, oy, res,
                           unknown_cost) >= INSCRIBED_INFLATED_OBSTACLE


@nb.njit(cache=True)
def _smooth(orig: NDArray[np.float64], data: NDArray[np.uint8], ox: float, oy: float,
            res: float, w_data: float, w_smooth: float, tolerance: float, max_its: int,
            unknown_ok: bool, bound: NDArray[np.int64]) -> tuple[NDArray[np.float64], int]:
    """Nav2 SimpleSmoother iterations; an update is not taken when a segment to a
    neighbour would cross a blocked cell or the point's new cell costs more than
    ``bound[i]``."""
    out = orig.copy()
    n = orig.shape[0]
    h, w = data.shape
    its = 0
    change = tolerance
    while change >= tolerance and its < max_its:
        its += 1
        change = 0.0
        for i in range(1, n - 1):
            nx = out[i, 0] + w_data * (orig[i, 0] - out[i, 0]) \
                + w_smooth * (out[i + 1, 0] + out[i - 1, 0] - 2.0 * out[i, 0])
            ny = out[i, 1] + w_data * (orig[i, 1] - out[i, 1]) \
                + w_smooth * (out[i + 1, 1] + out[i - 1, 1] - 2.0 * out[i, 1])
            cx = math.floor((nx - ox) / res)
            cy = math.floor((ny - oy) / res)
            if cx < 0 or cy < 0 or cx >= w or cy >= h or data[cy, cx] > bound[i]:
                continue
            if _segment_blocked(out[i - 1, 0], out[i - 1, 1], nx, ny, data, ox, oy, res,
                                unknown_ok):
                continue
            if _segment_blocked(nx, ny, out[i + 1, 0], out[i + 1, 1], data, ox, oy, res,
                                unknown_ok):
                continue
            change += abs(nx - out[i, 0]) + abs(ny - out[i, 1])
            out[i, 0] = nx
            out[i, 1] = ny
    return out, its


def smooth_path(xy: NDArray[np.float64], costmap: Costmap2D,
                params: SimpleSmootherParams | None = None,
                allow_unknown: bool = False, keep_cost: bool = False) -> NDArray[np.float64]:
    """Smooth an ``(N, 2)`` world path, keeping it out of inscribed/lethal cells.

    End points never move.  With ``do_refinement`` the smoothed path is smoothed again
    ``refinement_num`` times, each pass anchored to the previous result (Nav2).
    ``keep_cost`` (navstack): no point moves into a cell that costs more than the cell of
    its input point, so a path planned along the cost valley stays in it (Nav2's
    smoother only refuses collisions and cuts into the inflation at corners).
    """
    p = params or SimpleSmootherParams()
    xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 3:
        return xy.copy()
    if keep_cost:
        mx, my, inside = costmap.world_to_map_array(xy)
        bound = np.where(inside, costmap.data[my.clip(0, costmap.size_y - 1),
                                              mx.clip(0, costmap.size_x - 1)], 255)
    else:
        bound = np.full(len(xy), 255)
    bound = np.ascontiguousarray(bound, dtype=np.int64)
    passes = 1 + (p.refinement_num if p.do_refinement else 0)
    out = xy
    for _ in range(passes):
        out, _its = _smooth(out, costmap.data, costmap.origin_x, costmap.origin_y,
                            costmap.resolution, p.w_data, p.w_smooth, p.tolerance,
                            p.max_its, allow_unknown, bound)
    return out


@nb.njit(cache=True)
def _chord_max_cost(x0: float, y0: float, x1: float, y1: float, data: NDArray[np.uint8],
                    ox: float, oy: float, res: float, unknown_cost: int) -> int:
    """Highest cost of the cells the segment passes through (exact grid traversal);
    a cell outside the grid counts as lethal, an unknown one as ``unknown_cost``."""
    fx0 = (x0 - ox) / res
    fy0 = (y0 - oy) / res
    fx1 = (x1 - ox) / res
    fy1 = (y1 - oy) / res
    cx = math.floor(fx0)
    cy = math.floor(fy0)
    ex = math.floor(fx1)
    ey = math.floor(fy1)
    dx = fx1 - fx0
    dy = fy1 - fy0
    sx = 1 if dx > 0 else -1
    sy = 1 if dy > 0 else -1
    inf = math.inf
    tdx = abs(1.0 / dx) if dx != 0.0 else inf
    tdy = abs(1.0 / dy) if dy != 0.0 else inf
    tx = ((cx + 1 - fx0) if dx > 0 else (fx0 - cx)) * tdx if dx != 0.0 else inf
    ty = ((cy + 1 - fy0) if dy > 0 else (fy0 - cy)) * tdy if dy != 0.0 else inf
    worst = 0
    for _ in range(abs(ex - cx) + abs(ey - cy) + 1):
        if cx < 0 or cy < 0 or cx >= data.shape[1] or cy >= data.shape[0]:
            return 254
        c = int(data[cy, cx])
        if c == NO_INFORMATION:
            c = unknown_cost
        worst = max(worst, c)
        if tx < ty:
            cx += sx
            tx += tdx
        else:
            cy += sy
            ty += tdy
    return worst


@nb.njit(cache=True)
def _corner_cost(p: NDArray[np.float64], x: float, y: float, q: NDArray[np.float64],
                 max_length: float, data: NDArray[np.uint8], ox: float, oy: float,
                 res: float, unknown_cost: int) -> int:
    """Highest cost along ``p -> (x, y) -> q`` (two straight segments through a new
    corner), or -1 when that route is longer than ``max_length``."""
    if math.hypot(x - p[0], y - p[1]) + math.hypot(q[0] - x, q[1] - y) > max_length:
        return -1
    return max(_chord_max_cost(p[0], p[1], x, y, data, ox, oy, res, unknown_cost),
               _chord_max_cost(x, y, q[0], q[1], data, ox, oy, res, unknown_cost))


@nb.njit(cache=True)
def _straighten(xy: NDArray[np.float64], cost: NDArray[np.int64], data: NDArray[np.uint8],
                ox: float, oy: float, res: float, unknown_cost: int,
                max_deviation: float) -> NDArray[np.int64]:
    """Indices kept by :func:`straighten` (greedy farthest acceptable chord)."""
    n = xy.shape[0]
    keep = np.empty(n, dtype=np.int64)
    keep[0] = 0
    m = 1
    i = 0
    while i < n - 1:
        best = i + 1
        for j in range(n - 1, i + 1, -1):
            bound = max(cost[i], cost[j])
            if bound >= INSCRIBED_INFLATED_OBSTACLE:
                continue
            ax, ay = xy[i, 0], xy[i, 1]
            vx, vy = xy[j, 0] - ax, xy[j, 1] - ay
            length = math.hypot(vx, vy)
            if length <= 0.0:
                continue
            far = False
            for k in range(i + 1, j):  # every replaced point within max_deviation
                if abs(vx * (xy[k, 1] - ay) - vy * (xy[k, 0] - ax)) > max_deviation * length:
                    far = True
                    break
            if far:
                continue
            # a chord reaches its end through a neighbouring cell: allow one cell's rise
            # of the inflation (Nav2's exp(-2.5 d) rises ~12 % per 5 cm)
            bound = min(bound + bound * 3 // 20, INSCRIBED_INFLATED_OBSTACLE - 1)
            if _chord_max_cost(ax, ay, xy[j, 0], xy[j, 1], data, ox, oy, res,
                               unknown_cost) <= bound:
                best = j
                break
        keep[m] = best
        m += 1
        i = best
    return keep[:m]


WOBBLE_MIN_TURN = 0.01
"""[rad] turns smaller than this are neither wobbles nor the corners around one (issue
18 counts curvature above 0.2 1/m on a 0.1 m resampling: turns above 0.02 rad)."""


@nb.njit(cache=True)
def _turn(xy: NDArray[np.float64], a: int, b: int, c: int) -> float:
    """Signed heading change [rad] at ``xy[b]`` between ``a -> b`` and ``b -> c``."""
    h0 = math.atan2(xy[b, 1] - xy[a, 1], xy[b, 0] - xy[a, 0])
    h1 = math.atan2(xy[c, 1] - xy[b, 1], xy[c, 0] - xy[b, 0])
    d = h1 - h0
    while d > math.pi:
        d -= 2.0 * math.pi
    while d < -math.pi:
        d += 2.0 * math.pi
    return d


@nb.njit(cache=True)
def _cost_limit(cost_a: int, cost_b: int, stretch: int) -> int:
    """Highest cell cost a replacement between points of cost ``cost_a`` and ``cost_b``
    may cross when the stretch of plan it replaces crosses ``stretch`` at most: the
    costlier end + 15 % (one cell's rise of the inflation), or the stretch's own
    highest cost if that is higher; never inscribed (-1: no replacement)."""
    ends = max(cost_a, cost_b)
    if ends >= INSCRIBED_INFLATED_OBSTACLE:
        return -1
    return min(max(ends + ends * 3 // 20, stretch), INSCRIBED_INFLATED_OBSTACLE - 1)


@nb.njit(cache=True)
def _meet(p0: NDArray[np.float64], p1: NDArray[np.float64], q0: NDArray[np.float64],
          q1: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """Where the line through ``p0 -> p1`` meets the line through ``q0 -> q1``: the point
    and its distances along each from ``p1`` and ``q0`` [m] (signed; nan if parallel)."""
    ux, uy = p1[0] - p0[0], p1[1] - p0[1]
    vx, vy = q1[0] - q0[0], q1[1] - q0[1]
    lu, lv = math.hypot(ux, uy), math.hypot(vx, vy)
    den = ux * vy - uy * vx
    if lu <= 0.0 or lv <= 0.0 or abs(den) <= 1e-9 * lu * lv:
        return math.nan, math.nan, math.nan, math.nan
    wx, wy = q0[0] - p1[0], q0[1] - p1[1]
    s = (wx * vy - wy * vx) / den  # along p0 -> p1 from p1, in units of |u|
    t = (wx * uy - wy * ux) / den  # along q0 -> q1 from q0, in units of |v|
    return p1[0] + s * ux, p1[1] + s * uy, s * lu, t * lv


@nb.njit(cache=True)
def _drop_wobbles(xy: NDArray[np.float64], data: NDArray[np.uint8], ox: float, oy: float,
                  res: float, unknown_cost: int,
                  min_turn: float) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The polyline ``xy`` after :func:`straighten`'s wobble pass: its points (some
    moved) and the indices of those kept."""
    pts = xy.copy()
    n = pts.shape[0]
    alive = np.ones(n, dtype=np.bool_)
    changed = True
    while changed:
        changed = False
        idx = np.nonzero(alive)[0]
        m = len(idx)
        # vertices idx[1..m-2] have a turn; a wobble needs a turning vertex on each side
        for q in range(2, m - 2):
            a, b, c, d, e = idx[q - 2], idx[q - 1], idx[q], idx[q + 1], idx[q + 2]
            t_prev = _turn(pts, a, b, c)
            t = _turn(pts, b, c, d)
            t_next = _turn(pts, c, d, e)
            if abs(t) < min_turn or abs(t_prev) < min_turn or abs(t_next) < min_turn:
                continue
            if not (t * t_prev < 0.0 and t * t_next < 0.0
                    and abs(t) < abs(t_prev) and abs(t) < abs(t_next)):
                continue
            cab = _chord_max_cost(pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1], data, ox, oy,
                                  res, unknown_cost)
            cbc = _chord_max_cost(pts[b, 0], pts[b, 1], pts[c, 0], pts[c, 1], data, ox, oy,
                                  res, unknown_cost)
            ccd = _chord_max_cost(pts[c, 0], pts[c, 1], pts[d, 0], pts[d, 1], data, ox, oy,
                                  res, unknown_cost)
            cde = _chord_max_cost(pts[d, 0], pts[d, 1], pts[e, 0], pts[e, 1], data, ox, oy,
                                  res, unknown_cost)
            cost_a = _chord_max_cost(pts[a, 0], pts[a, 1], pts[a, 0], pts[a, 1], data, ox,
                                     oy, res, unknown_cost)
            cost_b = _chord_max_cost(pts[b, 0], pts[b, 1], pts[b, 0], pts[b, 1], data, ox,
                                     oy, res, unknown_cost)
            cost_d = _chord_max_cost(pts[d, 0], pts[d, 1], pts[d, 0], pts[d, 1], data, ox,
                                     oy, res, unknown_cost)
            cost_e = _chord_max_cost(pts[e, 0], pts[e, 1], pts[e, 0], pts[e, 1], data, ox,
                                     oy, res, unknown_cost)
            # (1) the chord b -> d
            lim = _cost_limit(cost_b, cost_d, max(cbc, ccd))
            if lim >= 0 and _chord_max_cost(pts[b, 0], pts[b, 1], pts[d, 0], pts[d, 1], data,
                                            ox, oy, res, unknown_cost) <= lim:
                alive[c] = False
                changed = True
                break
            # (2) b -> c carried on to where it meets d -> e: c and d become one corner
            best = INSCRIBED_INFLATED_OBSTACLE
            which = 0
            bx, by = 0.0, 0.0
            old = (math.hypot(pts[c, 0] - pts[b, 0], pts[c, 1] - pts[b, 1])
                   + math.hypot(pts[d, 0] - pts[c, 0], pts[d, 1] - pts[c, 1]))
            x, y, s, u = _meet(pts[b], pts[c], pts[d], pts[e])
            de = math.hypot(pts[e, 0] - pts[d, 0], pts[e, 1] - pts[d, 1])
            lim = _cost_limit(cost_b, cost_e, max(cbc, ccd, cde))
            if s > 0.0 and u < de and lim >= 0:
                worst = _corner_cost(pts[b], x, y, pts[e], old + de, data, ox, oy, res,
                                     unknown_cost)
                if 0 <= worst <= lim and worst < best:
                    best, which, bx, by = worst, 2, x, y
            # (3) a -> b carried on to where it meets c -> d: b and c become one corner
            x, y, s, u = _meet(pts[a], pts[b], pts[c], pts[d])
            ab = math.hypot(pts[b, 0] - pts[a, 0], pts[b, 1] - pts[a, 1])
            lim = _cost_limit(cost_a, cost_d, max(cab, cbc, ccd))
            if s > -ab and u < 0.0 and lim >= 0:
                worst = _corner_cost(pts[a], x, y, pts[d], old + ab, data, ox, oy, res,
                                     unknown_cost)
                if 0 <= worst <= lim and worst < best:
                    best, which, bx, by = worst, 3, x, y
            if which == 0:
                continue
            moved = d if which == 2 else b
            pts[moved, 0] = bx
            pts[moved, 1] = by
            alive[c] = False
            changed = True
            break
    return pts, np.nonzero(alive)[0]


def straighten(xy: NDArray[np.float64], costmap: Costmap2D, max_deviation: float,
               allow_unknown: bool = False) -> NDArray[np.float64]:
    """The vertices of ``xy`` kept when every stretch that a straight chord can replace is
    replaced (navstack): from each kept point, the farthest later point whose chord stays
    within ``max_deviation`` [m] of every point it replaces and crosses no cell costlier
    than the costlier of its two ends (+15 %: one cell's rise of the inflation, never
    inscribed).

    A grid planner's path bends back and forth along its cost valley: after a detour
    around a person it swings back to the valley's centre only to turn again into the
    next door, each S two curvature sign changes (issue 18 allows two per 10 m).  The
    deviation bound keeps the plan where the planner put it (no chord aimed across a
    corridor at a door's centre line, no corner cut: a door approach keeps its shape),
    the cost rule keeps it as far from obstacles as its own ends.

    Then the wobbles go: a vertex that turns against both its neighbours, by less than
    either of them (a kink of a few degrees left between a walker detour's return and the
    turn into a door, say; a swing wide of a person at a door's mouth between the turn
    into the door and the turn out of it), is replaced, whatever its deviation -- the
    deviation bound keeps the corners the planner made, and a turn smaller than and
    opposite to both corners around it is not one (each such kink is two curvature sign
    changes).  First choice, the chord between its neighbours; else the segment before it
    carried on until it meets the segment after the next corner, or the segment after it
    carried back until it meets the segment before the previous corner (the kink and that
    corner become one corner, the plan's directions before and after kept; the less
    costly of the two, never longer than the stretch it replaces).  A replacement passes
    the cost rule above or crosses no cell costlier than the stretch it replaces does:
    out of a door every chord is costlier than its ends in the rooms, and the kink
    stayed."""
    xy = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 3:
        return xy.copy()
    unknown_cost = 252 if allow_unknown else 254
    mx, my, inside = costmap.world_to_map_array(xy)
    raw = costmap.data[my.clip(0, costmap.size_y - 1), mx.clip(0, costmap.size_x - 1)]
    cost = np.where(inside, np.where(raw == NO_INFORMATION, unknown_cost, raw), 254)
    cost = np.ascontiguousarray(cost, dtype=np.int64)
    keep = _straighten(xy, cost, costmap.data, costmap.origin_x, costmap.origin_y,
                       costmap.resolution, unknown_cost, float(max_deviation))
    kept = np.ascontiguousarray(xy[keep])
    pts, calm = _drop_wobbles(kept, costmap.data, costmap.origin_x, costmap.origin_y,
                              costmap.resolution, unknown_cost, WOBBLE_MIN_TURN)
    return pts[calm]
