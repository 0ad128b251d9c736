"""Shared ``plan()`` logic of the 2D grid planners (NavFn-style and cost-aware A*).

A subclass supplies the cost model (which cells are traversable and their weights) and
its limits; this base does what Nav2's ``createPlan`` does around the search: pose ->
cell conversion with typed errors, goal tolerance, chunked search with cancel / time /
iteration checks, and the conversion of the cell path into a ``nav_msgs/Path`` in the
costmap frame that starts at the start pose and ends at the goal pose (or, when the goal
had to be moved within ``tolerance``, at the centre of the free cell that was used).

Goal tolerance: if the goal cell is blocked or unreachable, the path ends at the
reachable free cell nearest to the goal whose centre lies within ``tolerance`` metres of
it (NavFn searches the square window around the goal for the nearest cell with a valid
potential; we use the disc, which is what "within tolerance" means).
"""

from __future__ import annotations

import math
import time
from abc import abstractmethod

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import (
    GoalOccupied,
    GoalOutsideMap,
    NoValidPath,
    PlannerCancelled,
    PlannerTimeout,
    StartOccupied,
    StartOutsideMap,
)
from navstack.core.interfaces import CancelFn, GlobalPlanner
from navstack.core.msgs import Path, Pose2D
from navstack.core.params import Params
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION, Costmap2D
from navstack.planning.budget import PlanningBudget
from navstack.planning.grid_search import FOUND, RUNNING, GridSearchWorkspace
from navstack.planning.path_utils import cells_to_world, make_path


def fmt_xy(p: Pose2D) -> str:
    return f"({p.x:.2f}, {p.y:.2f})"


class GridPlannerBase(GlobalPlanner):
    """Template for grid planners; subclasses implement :meth:`cost_model`."""

    #: Nav2 name of the planner, used in messages.
    name = "grid planner"

    def __init__(self, params: Params | None = None) -> None:
        super().__init__(params)
        self._ws: GridSearchWorkspace | None = None

    # --- to be provided by subclasses ------------------------------------------------
    tolerance: float = 0.0
    allow_unknown: bool = True
    use_final_approach_orientation: bool = False
    h_scale: float = 1.0
    max_iterations: int | None = None
    max_planning_time: float | None = None
    sim_expansion_rate: float = 5_000_000.0
    """Expansions per second of ``max_planning_time`` on simulated time."""
    chunk: int = 5000
    clear_start_cell: bool = False
    """A start cell in the inscribed band is planned from as free (Nav2 NavFn's
    ``clearRobotCell``); a lethal or forbidden start still raises ``StartOccupied``."""

    @abstractmethod
    def cost_model(self, data: NDArray[np.uint8]) -> tuple[NDArray[np.bool_],
                                                           NDArray[np.float64]]:
        """``(free[H, W], weight[H, W])`` for a costmap's cost array."""

    # --- planning --------------------------------------------------------------------
    def workspace(self, width: int, height: int) -> GridSearchWorkspace:
        """The planner's search buffers, reallocated only when the grid size changes."""
        if self._ws is None or (self._ws.width, self._ws.height) != (width, height):
            self._ws = GridSearchWorkspace(width, height)
        return self._ws

    def _cell(self, role: str, p: Pose2D, costmap: Costmap2D) -> tuple[int, int]:
        cell = costmap.world_to_map(p.x, p.y)
        if cell is None:
            x1 = costmap.origin_x + costmap.size_x_m
            y1 = costmap.origin_y + costmap.size_y_m
            msg = (f"{role} {fmt_xy(p)} is outside the costmap, which spans x "
                   f"[{costmap.origin_x:.2f}, {x1:.2f}] y [{costmap.origin_y:.2f}, {y1:.2f}] "
                   f"in frame '{costmap.frame_id}'; give a {role} inside the map")
            raise (StartOutsideMap if role == "start" else GoalOutsideMap)(msg)
        return cell

    def _blocked_reason(self, role: str, p: Pose2D, cost: int) -> str:
        if cost == NO_INFORMATION:
            return (f"{role} {fmt_xy(p)} is in unknown space (cost {cost}) and "
                    f"allow_unknown is false")
        return f"{role} {fmt_xy(p)} is in an obstacle (cost {cost})"

    def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap2D,
             cancel: CancelFn | None = None) -> Path:
        """Plan from ``start`` to ``goal`` (both in ``costmap.frame_id``).

        Raises ``StartOutsideMap``, ``GoalOutsideMap``, ``StartOccupied``,
        ``GoalOccupied``, ``NoValidPath``, ``PlannerTimeout`` or ``PlannerCancelled``.
        """
        t0 = time.perf_counter()
        s_cell = self._cell("start", start, costmap)
        g_cell = self._cell("goal", goal, costmap)
        free, weight = self.cost_model(costmap.data)
        if (self.clear_start_cell and not free[s_cell[1], s_cell[0]]
                and int(costmap.data[s_cell[1], s_cell[0]]) == INSCRIBED_INFLATED_OBSTACLE):
            # Nav2 NavFn clearRobotCell: the robot stands there, so its cell is free
            free[s_cell[1], s_cell[0]] = True
            weight[s_cell[1], s_cell[0]] = self.cost_model(np.zeros((1, 1), np.uint8))[1][0, 0]
        if not free[s_cell[1], s_cell[0]]:
            cost = int(costmap.data[s_cell[1], s_cell[0]])
            raise StartOccupied(self._blocked_reason("start", start, cost)
                                + "; clear the costmap or move the robot into free space")
        goal_free = bool(free[g_cell[1], g_cell[0]])
        candidates = self._goal_candidates(goal, g_cell, free, costmap)
        if not candidates:
            cost = int(costmap.data[g_cell[1], g_cell[0]])
            raise GoalOccupied(self._blocked_reason("goal", goal, cost)
                               + f" and no free cell lies within tolerance {self.tolerance:.2f} m"
                               + "; choose a goal in free space or raise tolerance")
        target = candidates[0]
        if s_cell == target:
            return self._to_path(cells_to_world(np.array([s_cell]), costmap), start, goal,
                                 target == g_cell, costmap)

        ws = self.workspace(costmap.size_x, costmap.size_y)
        ws.load(free, weight, corner_cutting=False)
        ws.begin(s_cell, target)
        status = self._search(ws, start, goal, cancel, t0)
        if status == FOUND:
            return self._to_path(self.path_points(ws, s_cell, target, free, weight, costmap),
                                 start, goal, target == g_cell, costmap)
        # exhausted: every reachable cell is closed; use the nearest reachable candidate
        for cell in candidates:
            if ws.is_closed(cell):
                return self._to_path(self.path_points(ws, s_cell, cell, free, weight, costmap),
                                     start, goal, cell == g_cell, costmap)
        if not goal_free:
            cost = int(costmap.data[g_cell[1], g_cell[0]])
            raise GoalOccupied(self._blocked_reason("goal", goal, cost)
                               + f" and no reachable free cell lies within tolerance "
                               f"{self.tolerance:.2f} m; choose a goal in free space")
        raise NoValidPath(
            f"no valid path from start {fmt_xy(start)} to goal {fmt_xy(goal)}: the goal is "
            f"not reachable through free space ({ws.expansions} cells searched); check the "
            f"costmap for a blocked passage or raise tolerance ({self.tolerance:.2f} m)")

    def _goal_candidates(self, goal: Pose2D, g_cell: tuple[int, int], free: NDArray[np.bool_],
                         costmap: Costmap2D) -> list[tuple[int, int]]:
        """Free cells acceptable as path end, nearest to the goal first."""
        out: list[tuple[int, int]] = []
        if free[g_cell[1], g_cell[0]]:
            out.append(g_cell)
        if self.tolerance <= 0.0:
            return out
        r = math.ceil(self.tolerance / costmap.resolution) + 1
        x0, x1 = max(0, g_cell[0] - r), min(costmap.size_x, g_cell[0] + r + 1)
        y0, y1 = max(0, g_cell[1] - r), min(costmap.size_y, g_cell[1] + r + 1)
        ys, xs = np.mgrid[y0:y1, x0:x1]
        cx = costmap.origin_x + (xs + 0.5) * costmap.resolution
        cy = costmap.origin_y + (ys + 0.5) * costmap.resolution
        d2 = (cx - goal.x) ** 2 + (cy - goal.y) ** 2
        ok = free[y0:y1, x0:x1] & (d2 <= self.tolerance ** 2)
        ok &= ~((xs == g_cell[0]) & (ys == g_cell[1]))
        order = np.argsort(d2[ok], kind="stable")
        out.extend(zip(xs[ok][order].tolist(), ys[ok][order].tolist(), strict=True))
        return out

    def _search(self, ws: GridSearchWorkspace, start: Pose2D, goal: Pose2D,
                cancel: CancelFn | None, t0: float) -> int:
        what = f"planning from start {fmt_xy(start)} to goal {fmt_xy(goal)}"
        limit = self.max_iterations
        clock = PlanningBudget(self.max_planning_time, self.sim_expansion_rate,
                               self.simulated_time)
        clock.restart(t0)
        sim_cap = clock.max_expansions  # simulated time: stop at exactly this many
        while True:
            if cancel is not None and cancel():
                raise PlannerCancelled(f"{what} was cancelled after {ws.expansions} expansions")
            budget = self.chunk if limit is None else min(self.chunk, limit - ws.expansions)
            if budget <= 0:
                raise PlannerTimeout(
                    f"{what} exceeded max_iterations {limit} ({ws.expansions} cells expanded "
                    f"without reaching the goal); raise max_iterations or set it to -1")
            if sim_cap is not None:
                if sim_cap - ws.expansions <= 0:
                    raise PlannerTimeout(f"{what} exceeded {clock.describe(ws.expansions)}; "
                                         f"raise max_planning_time")
                budget = min(budget, sim_cap - ws.expansions)
            status = ws.step(self.h_scale, budget)
            if status != RUNNING:
                return status
            if sim_cap is None and clock.exceeded(ws.expansions):
                raise PlannerTimeout(f"{what} exceeded {clock.describe(ws.expansions)}; "
                                     f"raise max_planning_time")

    def path_points(self, ws: GridSearchWorkspace, start: tuple[int, int],
                    end: tuple[int, int], free: NDArray[np.bool_], weight: NDArray[np.float64],
                    costmap: Costmap2D) -> NDArray[np.float64]:
        """``(K, 2)`` world points from the start cell to the closed ``end`` cell: the
        cell centres of the search's optimal cell path (NavFn overrides this)."""
        return cells_to_world(ws.cells_to(end), costmap)

    def refine_points(self, xy: NDArray[np.float64], costmap: Costmap2D) -> NDArray[np.float64]:
        """Post-process the path's points once its ends are the exact start and goal
        (identity here; NavFn thins and smooths its descent)."""
        return xy

    def _to_path(self, xy: NDArray[np.float64], start: Pose2D, goal: Pose2D,
                 reaches_goal: bool, costmap: Costmap2D) -> Path:
        xy = np.array(xy, dtype=np.float64).reshape(-1, 2)
        xy[0] = (start.x, start.y)
        if reaches_goal:
            if len(xy) == 1:
                xy = np.vstack((xy, [[goal.x, goal.y]]))
            else:
                xy[-1] = (goal.x, goal.y)
        if len(xy) == 2 and np.allclose(xy[0], xy[1], rtol=0.0, atol=1e-12):
            xy = xy[1:]
        xy = self.refine_points(xy, costmap)
        return make_path(xy, goal.theta, costmap.frame_id, self.use_final_approach_orientation)
