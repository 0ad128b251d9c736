"""Theta* any-angle global planner (Nav2 ``nav2_theta_star_planner::ThetaStarPlanner``).

``ThetaStarPlanner(params).plan(start, goal, costmap, cancel=None) -> Path`` in the
costmap frame, with Nav2's parameters (:class:`ThetaStarParams`).

Cost model (Nav2 ``theta_star.hpp``): travelling one cell length through a cell of cost
``c <= 252`` costs ``w_euc_cost + w_traversal_cost * (26 + 0.9 c)^2 / 252^2``; unknown cells
cost ``w_euc_cost + w_traversal_cost * 253^2 / 252^2`` with ``allow_unknown`` and block
otherwise; inscribed (253) and lethal (254) cells block.  Nav2 adds the traversal term once
per cell a line touches; we integrate the same weight along the segment (length in each
cell x its weight), so in uniform cost a path costs exactly its length times the weight
and a straight line on an empty map is optimal.  (Nav2's line-of-sight ``isSafe`` tests
``26 + 0.9 c <= 252``, blocking cost 252 too; we use ``c <= 252`` everywhere.)

Search: textbook Theta* (Nash, Daniel, Koenig & Felner, AAAI 2007) in numba: relaxing a
neighbour tries the any-angle shortcut from the parent (exact line of sight,
:func:`segment_cost`) and the grid step, keeping the cheaper; Nav2 checks the grandparent
once per expansion instead, which gives slightly longer paths.  The heuristic is the
Euclidean distance times the weight of a free cell (admissible; Nav2 uses
``min(w_euc_cost, 1)``).  The search runs in chunks of ``terminal_checking_interval``
expansions between cancel checks; an indexed binary heap and generation stamps keep
per-plan set-up O(1).  Internally positions are in cell units: ``(x - origin_x) / res``.

Start and goal: the first and last vertices are the exact start and goal positions, and
lines of sight are checked from there.  A lethal start (or unknown, without
``allow_unknown``) raises ``StartOccupied``; a start in the inscribed band is treated as
free, as Nav2 clears the start cell (``clearStart``) so a robot near a wall can plan out.
An untraversable goal cell raises ``GoalOccupied``.  Start and goal in one cell give a
one-pose path (Nav2).  The vertices (:attr:`ThetaStarPlanner.last_waypoints`) are joined
by lines sampled every resolution (Nav2 ``linearInterpolation``, ending at the goal);
headings follow the path, the goal's heading (or with ``use_final_approach_orientation``
the last segment's) at the end.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from navstack.core.errors import (
    GoalOccupied,
    GoalOutsideMap,
    NoValidPath,
    PlannerCancelled,
    StartOccupied,
    StartOutsideMap,
)
from navstack.core.interfaces import CancelFn, GlobalPlanner
from navstack.core.msgs import Path, Pose2D
from navstack.core.params import Params
from navstack.core.plugins import register_planner
from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)
from navstack.planning.grid_planner import fmt_xy
from navstack.planning.path_utils import make_path

RUNNING = 0
"""Status: the expansion budget of this call ran out; call again to continue."""
FOUND = 1
"""Status: the goal was expanded; ``parent`` holds the path."""
EXHAUSTED = 2
"""Status: the open list emptied without reaching the goal."""

HALF_SQRT2 = 0.5 * math.sqrt(2.0)
CORNER_EPS = 1e-9
"""Two boundary crossings closer than this (in segment parameter) are one corner."""

# state vector layout: generation, heap size, expansions, start, goal
_GEN, _SIZE, _EXPANSIONS, _START, _GOAL = range(5)
STATE_LEN = 5

# neighbour offsets in Nav2's order (N, S, E, W first: how_many_corners 4 uses those)
MOVES_DX = np.array([0, 0, 1, -1, 1, -1, 1, -1], dtype=np.int64)
MOVES_DY = np.array([1, -1, 0, 0, -1, 1, 1, -1], dtype=np.int64)


@nb.njit(cache=True)
def segment_cost(ax: float, ay: float, bx: float, by: float, weight: NDArray[np.float64],
                 width: int, height: int) -> float:
    """Weighted length of segment ``a -> b`` (cell units); ``-1.0`` if it is blocked.

    Walks exactly the cells the segment passes through (Amanatides & Woo 1987) summing
    ``weight[cell] * length inside the cell``.  A cell blocks when its weight is negative
    or it lies off the grid; through a grid corner both side cells must be free too
    (supercover rule), so no line squeezes between two diagonal obstacles.
    """
    dx, dy = bx - ax, by - ay
    length = math.sqrt(dx * dx + dy * dy)
    cx, cy, ex, ey = math.floor(ax), math.floor(ay), math.floor(bx), math.floor(by)
    sx = 1 if dx > 0.0 else -1
    sy = 1 if dy > 0.0 else -1
    inf = math.inf
    tdx = abs(1.0 / dx) if dx != 0.0 else inf
    tdy = abs(1.0 / dy) if dy != 0.0 else inf
    # parameter t (0..1 along the segment) of the next vertical / horizontal cell boundary
    tx = ((cx + 1 - ax) if dx > 0.0 else (ax - cx)) * tdx if dx != 0.0 else inf
    ty = ((cy + 1 - ay) if dy > 0.0 else (ay - cy)) * tdy if dy != 0.0 else inf
    t = 0.0
    total = 0.0
    for _ in range(abs(ex - cx) + abs(ey - cy) + 3):
        if cx < 0 or cy < 0 or cx >= width or cy >= height:
            return -1.0
        w = weight[cy * width + cx]
        if w < 0.0:
            return -1.0
        if cx == ex and cy == ey:
            total += w * (1.0 - t) * length
            return total
        t_next = min(tx, ty, 1.0)
        total += w * (t_next - t) * length
        t = t_next
        if t >= 1.0:
            return total
        if abs(tx - ty) <= CORNER_EPS:  # through a grid corner: both side cells too
            qx, qy = cx + sx, cy + sy
            if (qx < 0 or qx >= width or qy < 0 or qy >= height
                    or weight[cy * width + qx] < 0.0 or weight[qy * width + cx] < 0.0):
                return -1.0
            cx += sx
            cy += sy
            tx += tdx
            ty += tdy
        elif tx < ty:
            cx += sx
            tx += tdx
        else:
            cy += sy
            ty += tdy
    return total


@nb.njit(cache=True)
def _sift_up(i: int, key: float, node: int, hkey: NDArray[np.float64],
             hnode: NDArray[np.int32], hpos: NDArray[np.int32]) -> None:
    while i > 0:
        p = (i - 1) >> 1
        if hkey[p] <= key:
            break
        hkey[i], hnode[i] = hkey[p], hnode[p]
        hpos[hnode[i]] = i
        i = p
    hkey[i], hnode[i], hpos[node] = key, node, i


@nb.njit(cache=True)
def _pop(size: int, hkey: NDArray[np.float64], hnode: NDArray[np.int32],
         hpos: NDArray[np.int32]) -> int:
    """Remove the root; return it.  ``size`` is the heap size before the pop."""
    top = int(hnode[0])
    hpos[top] = -1
    size -= 1
    if size > 0:
        key, node, i = hkey[size], hnode[size], 0
        while True:
            c = 2 * i + 1
            if c >= size:
                break
            if c + 1 < size and hkey[c + 1] < hkey[c]:
                c += 1
            if key <= hkey[c]:
                break
            hkey[i], hnode[i] = hkey[c], hnode[c]
            hpos[hnode[i]] = i
            i = c
        hkey[i], hnode[i], hpos[node] = key, node, i
    return top


@nb.njit(cache=True)
def _position(n: int, width: int, start: int, goal: int, sx: float, sy: float, gx: float,
              gy: float) -> tuple[float, float]:
    """Vertex position of cell ``n``: the exact start/goal point, else the cell centre."""
    if n == start:
        return sx, sy
    if n == goal:
        return gx, gy
    j = n // width
    return n - j * width + 0.5, j + 0.5


@nb.njit(cache=True)
def theta_star_begin(start: int, goal: int, sx: float, sy: float, gx: float, gy: float,
                     h_weight: float, g: NDArray[np.float64], parent: NDArray[np.int32],
                     stamp: NDArray[np.int32], hkey: NDArray[np.float64],
                     hnode: NDArray[np.int32], hpos: NDArray[np.int32],
                     state: NDArray[np.int64]) -> None:
    """Start a search from cell ``start`` (vertex at ``(sx, sy)``) to ``goal``."""
    gen = state[_GEN] + 1
    if 2 * gen + 1 >= 2**31 - 1:  # wrap the generation counter: clear the stamps once
        stamp[:] = 0
        gen = 1
    g[start], parent[start], stamp[start] = 0.0, start, 2 * gen
    hkey[0], hnode[0], hpos[start] = h_weight * math.hypot(gx - sx, gy - sy), start, 0
    state[_GEN], state[_SIZE], state[_EXPANSIONS] = gen, 1, 0
    state[_START], state[_GOAL] = start, goal


@nb.njit(cache=True)
def theta_star_run(weight: NDArray[np.float64], width: int, height: int, corners: int,
                   sx: float, sy: float, gx: float, gy: float, h_weight: float,
                   max_expansions: int, g: NDArray[np.float64], parent: NDArray[np.int32],
                   stamp: NDArray[np.int32], hkey: NDArray[np.float64],
                   hnode: NDArray[np.int32], hpos: NDArray[np.int32],
                   state: NDArray[np.int64]) -> int:
    """Expand up to ``max_expansions`` cells; return RUNNING, FOUND or EXHAUSTED."""
    open_mark = 2 * state[_GEN]
    closed_mark = open_mark + 1
    size = int(state[_SIZE])
    start = int(state[_START])
    goal = int(state[_GOAL])
    expanded = 0
    status = RUNNING
    while expanded < max_expansions:
        if size == 0:
            status = EXHAUSTED
            break
        u = _pop(size, hkey, hnode, hpos)
        size -= 1
        stamp[u] = closed_mark
        expanded += 1
        if u == goal:
            status = FOUND
            break
        ux, uy = _position(u, width, start, goal, sx, sy, gx, gy)
        p = int(parent[u])
        px, py = _position(p, width, start, goal, sx, sy, gx, gy)
        ui = u % width
        uj = u // width
        for k in range(corners):
            vi = ui + MOVES_DX[k]
            vj = uj + MOVES_DY[k]
            if vi < 0 or vj < 0 or vi >= width or vj >= height:
                continue
            v = vj * width + vi
            if weight[v] < 0.0 or stamp[v] == closed_mark:
                continue
            vx, vy = _position(v, width, start, goal, sx, sy, gx, gy)
            seen = stamp[v] == open_mark
            best = math.inf
            best_parent = -1
            # path 1: the grid step (centre to centre: half a step in each cell; a diagonal
            # needs both side cells free), or an exact walk from/to the start or goal point
            if u == start or v == goal:
                c1 = segment_cost(ux, uy, vx, vy, weight, width, height)
            elif k < 4:
                c1 = 0.5 * (weight[u] + weight[v])
            elif weight[uj * width + vi] < 0.0 or weight[vj * width + ui] < 0.0:
                c1 = -1.0
            else:
                c1 = HALF_SQRT2 * (weight[u] + weight[v])
            if c1 >= 0.0:
                best = g[u] + c1
                best_parent = u
            # path 2: the any-angle shortcut from u's parent, walked only when its lower
            # bound (cheapest weight x length) could beat what v already has; ties prefer it
            if p != u and g[p] + h_weight * math.hypot(vx - px, vy - py) <= min(
                    best, g[v] if seen else math.inf):
                c2 = segment_cost(px, py, vx, vy, weight, width, height)
                if c2 >= 0.0 and g[p] + c2 <= best:
                    best = g[p] + c2
                    best_parent = p
            if best_parent < 0 or (seen and best >= g[v]):
                continue
            g[v] = best
            parent[v] = best_parent
            f = best + h_weight * math.hypot(gx - vx, gy - vy)
            if seen:
                _sift_up(int(hpos[v]), f, v, hkey, hnode, hpos)
            else:
                stamp[v] = open_mark
                _sift_up(size, f, v, hkey, hnode, hpos)
                size += 1
    state[_SIZE] = size
    state[_EXPANSIONS] += expanded
    return status


@nb.njit(cache=True)
def extract_vertices(parent: NDArray[np.int32], start: int, goal: int) -> NDArray[np.int64]:
    """Flat cell indices of the path vertices from ``start`` to ``goal``."""
    count = 1
    n = goal
    while n != start:
        n = int(parent[n])
        count += 1
    out = np.empty(count, dtype=np.int64)
    n = goal
    for i in range(count - 1, -1, -1):
        out[i] = n
        n = int(parent[n])
    return out


# --- parameters and cost model -------------------------------------------------------------
class ThetaStarParams(Params):
    """Nav2 ``nav2_theta_star_planner`` parameters (names and defaults).

    ``how_many_corners``: neighbours per cell, 4 (N, S, E, W) or 8; ``w_euc_cost`` /
    ``w_traversal_cost``: weights of length and of cell cost (higher keeps away from
    obstacles; 0 is allowed here for a pure shortest path, Nav2 wants > 0);
    ``terminal_checking_interval``: expansions between cancel checks.
    """

    how_many_corners: int = 8
    w_euc_cost: float = Field(1.0, gt=0.0)
    w_traversal_cost: float = Field(2.0, ge=0.0)
    allow_unknown: bool = True
    terminal_checking_interval: int = Field(5000, ge=1)
    use_final_approach_orientation: bool = False

    @field_validator("how_many_corners")
    @classmethod
    def _four_or_eight(cls, v: int) -> int:
        if v not in (4, 8):
            raise ValueError(f"how_many_corners must be 4 or 8, got {v}")
        return v


def theta_star_weight_table(w_euc_cost: float, w_traversal_cost: float,
                            allow_unknown: bool) -> NDArray[np.float64]:
    """Cost per cell length for every costmap value 0..255; ``-1`` marks obstacles."""
    c = np.arange(256, dtype=np.float64)
    scaled = 26.0 + 0.9 * c
    table = w_euc_cost + w_traversal_cost * scaled * scaled / (MAX_NON_OBSTACLE ** 2)
    table[INSCRIBED_INFLATED_OBSTACLE:] = -1.0
    if allow_unknown:
        table[NO_INFORMATION] = (w_euc_cost + w_traversal_cost * (LETHAL_OBSTACLE - 1) ** 2
                                 / MAX_NON_OBSTACLE ** 2)
    return table


def interpolate_polyline(xy: NDArray[np.float64], spacing: float) -> NDArray[np.float64]:
    """Points every ``spacing`` metres along each segment of ``xy`` (Nav2
    ``linearInterpolation``), plus the final point; ``(M, 2)``."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 2:
        return xy.copy()
    d = np.diff(xy, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    loops = np.maximum(1, (length / spacing).astype(np.int64))
    seg = np.repeat(np.arange(len(d)), loops)
    first = np.concatenate(([0], np.cumsum(loops)[:-1]))
    k = np.arange(len(seg)) - np.repeat(first, loops)
    unit = np.divide(d, length[:, None], out=np.zeros_like(d), where=length[:, None] > 0.0)
    pts = xy[seg] + (k * spacing)[:, None] * unit[seg]
    return np.vstack((pts, xy[-1:]))


def drop_collinear(xy: NDArray[np.float64], tol: float = 1e-9) -> NDArray[np.float64]:
    """Remove vertices that lie on the straight line between their neighbours.

    Theta* can leave such vertices where a shortcut grazed an obstacle corner; the two
    segments cover exactly the cells of the joined one, so dropping them changes nothing
    but the vertex count.
    """
    if len(xy) < 3:
        return xy
    a = xy[1:-1] - xy[:-2]
    b = xy[2:] - xy[1:-1]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.einsum("ij,ij->i", a, b)
    scale = np.hypot(a[:, 0], a[:, 1]) * np.hypot(b[:, 0], b[:, 1])
    keep = np.ones(len(xy), dtype=bool)
    keep[1:-1] = ~((np.abs(cross) <= tol * np.maximum(scale, 1e-300)) & (dot > 0.0))
    return xy[keep]


class ThetaStarWorkspace:
    """Search buffers for one grid size, reused across plans (nothing W*H is cleared)."""

    def __init__(self, width: int, height: int) -> None:
        n = width * height
        self.width, self.height = width, height
        self.g = np.zeros(n, dtype=np.float64)
        self.parent = np.zeros(n, dtype=np.int32)
        self.stamp = np.zeros(n, dtype=np.int32)
        self.hkey = np.zeros(n, dtype=np.float64)
        self.hnode = np.zeros(n, dtype=np.int32)
        self.hpos = np.full(n, -1, dtype=np.int32)
        self.state = np.zeros(STATE_LEN, dtype=np.int64)

    @property
    def expansions(self) -> int:
        return int(self.state[_EXPANSIONS])


@register_planner("ThetaStarPlanner", nav2="nav2_theta_star_planner::ThetaStarPlanner")
class ThetaStarPlanner(GlobalPlanner):
    """``plan(start, goal, costmap, cancel=None) -> Path`` with Theta* (module docstring)."""

    name = "ThetaStarPlanner"
    params_model = ThetaStarParams
    params: ThetaStarParams

    def __init__(self, params: ThetaStarParams | Mapping[str, Any] | None = None) -> None:
        super().__init__(params if isinstance(params, ThetaStarParams)
                         else ThetaStarParams.from_mapping(params))
        p = self.params
        self._table = theta_star_weight_table(p.w_euc_cost, p.w_traversal_cost,
                                              p.allow_unknown)
        self._h_weight = float(self._table[0])
        self._ws: ThetaStarWorkspace | None = None
        self.last_waypoints: NDArray[np.float64] = np.zeros((0, 2))
        """Any-angle vertices ``(K, 2)`` [m] of the last plan (before interpolation)."""
        self.last_expansions = 0
        """Cells expanded by the last search."""

    # --- checks ------------------------------------------------------------------------------
    def _cell(self, role: str, p: Pose2D, costmap: Costmap2D) -> tuple[int, int]:
        cell = costmap.world_to_map(p.x, p.y) if math.isfinite(p.x + p.y) else None
        if cell is None:
            x1 = costmap.origin_x + costmap.size_x_m
            y1 = costmap.origin_y + costmap.size_y_m
            msg = (f"{role} {fmt_xy(p)} is outside the costmap, which spans x "
                   f"[{costmap.origin_x:.2f}, {x1:.2f}] y [{costmap.origin_y:.2f}, {y1:.2f}] "
                   f"in frame '{costmap.frame_id}'; give a {role} inside the map")
            raise (StartOutsideMap if role == "start" else GoalOutsideMap)(msg)
        return cell

    def _blocked(self, role: str, p: Pose2D, cost: int) -> str:
        if cost == NO_INFORMATION:
            return f"{role} {fmt_xy(p)} is in unknown space (cost 255) and allow_unknown is false"
        return f"{role} {fmt_xy(p)} is in an obstacle (cost {cost})"

    def _workspace(self, width: int, height: int) -> ThetaStarWorkspace:
        if self._ws is None or (self._ws.width, self._ws.height) != (width, height):
            self._ws = ThetaStarWorkspace(width, height)
        return self._ws

    # --- planning ------------------------------------------------------------------------------
    def plan_waypoints(self, start: Pose2D, goal: Pose2D, costmap: Costmap2D,
                       cancel: CancelFn | None = None) -> NDArray[np.float64]:
        """The any-angle vertices ``(K, 2)`` [m] from ``start`` to ``goal`` (K >= 1).

        Raises ``StartOutsideMap``, ``GoalOutsideMap``, ``StartOccupied``,
        ``GoalOccupied``, ``NoValidPath`` or ``PlannerCancelled``.
        """
        s_cell = self._cell("start", start, costmap)
        g_cell = self._cell("goal", goal, costmap)
        s_cost = int(costmap.data[s_cell[1], s_cell[0]])
        g_cost = int(costmap.data[g_cell[1], g_cell[0]])
        if s_cost == LETHAL_OBSTACLE or (s_cost == NO_INFORMATION and self._table[s_cost] < 0):
            raise StartOccupied(self._blocked("start", start, s_cost)
                                + "; clear the costmap or move the robot into free space")
        if self._table[g_cost] < 0.0:
            raise GoalOccupied(self._blocked("goal", goal, g_cost)
                               + "; choose a goal in free space")
        self.last_expansions = 0
        if s_cell == g_cell:
            self.last_waypoints = np.array([[start.x, start.y]])
            return self.last_waypoints
        w, h = costmap.size_x, costmap.size_y
        weight = self._table[costmap.data].reshape(-1)
        s_idx = s_cell[1] * w + s_cell[0]
        g_idx = g_cell[1] * w + g_cell[0]
        weight[s_idx] = self._table[0]  # Nav2 clearStart: the start cell is free
        res = costmap.resolution
        sx, sy = (start.x - costmap.origin_x) / res, (start.y - costmap.origin_y) / res
        gx, gy = (goal.x - costmap.origin_x) / res, (goal.y - costmap.origin_y) / res
        ws = self._workspace(w, h)
        theta_star_begin(s_idx, g_idx, sx, sy, gx, gy, self._h_weight, ws.g, ws.parent,
                         ws.stamp, ws.hkey, ws.hnode, ws.hpos, ws.state)
        what = f"planning from start {fmt_xy(start)} to goal {fmt_xy(goal)}"
        while True:
            if cancel is not None and cancel():
                self.last_expansions = ws.expansions
                raise PlannerCancelled(f"{what} was cancelled after {ws.expansions} expansions")
            status = theta_star_run(weight, w, h, self.params.how_many_corners, sx, sy, gx, gy,
                                    self._h_weight, self.params.terminal_checking_interval,
                                    ws.g, ws.parent, ws.stamp, ws.hkey, ws.hnode, ws.hpos,
                                    ws.state)
            if status != RUNNING:
                break
        self.last_expansions = ws.expansions
        if status != FOUND:
            raise NoValidPath(
                f"no valid path from start {fmt_xy(start)} to goal {fmt_xy(goal)}: the goal is not "
                f"reachable through free space ({ws.expansions} cells searched); check the "
                f"costmap for a blocked passage")
        cells = extract_vertices(ws.parent, s_idx, g_idx)
        xy = np.column_stack((costmap.origin_x + (cells % w + 0.5) * res,
                              costmap.origin_y + (cells // w + 0.5) * res))
        xy[0] = (start.x, start.y)
        xy[-1] = (goal.x, goal.y)
        xy = drop_collinear(xy)
        self.last_waypoints = xy
        return xy

    def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap2D,
             cancel: CancelFn | None = None) -> Path:
        """Plan from ``start`` to ``goal`` (both in ``costmap.frame_id``); see
        :meth:`plan_waypoints` for the errors."""
        xy = self.plan_waypoints(start, goal, costmap, cancel)
        final_approach = self.params.use_final_approach_orientation
        if len(xy) == 1:  # Nav2: one pose at the start, goal (or start) heading
            theta = start.theta if final_approach else goal.theta
            return Path.from_array(np.array([[start.x, start.y, theta]]),
                                   frame_id=costmap.frame_id)
        dense = interpolate_polyline(xy, costmap.resolution)
        return make_path(dense, goal.theta, costmap.frame_id, final_approach)
