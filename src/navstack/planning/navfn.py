"""NavFn-style global planner: Dijkstra or A* over NavFn's cell costs.

Follows Nav2's ``nav2_navfn_planner/NavfnPlanner`` (parameters ``tolerance``,
``use_astar``, ``allow_unknown``, ``use_final_approach_orientation`` with Nav2's
defaults) and its cost mapping (``navfn.cpp`` ``setCostmap``): a costmap cell of cost
``c < 253`` costs ``COST_NEUTRAL + COST_FACTOR * c = 50 + 0.8 c`` (truncated to an
integer as NavFn stores it), inscribed (253) and lethal (254) cells are obstacles, and
unknown (255) cells cost the maximum ``COST_OBS - 1 = 253`` when ``allow_unknown`` is
true and are obstacles otherwise.

The path is NavFn's: the interpolated potential field propagated from the robot's cell
and descended from the goal along its gradient (:mod:`navstack.planning.navfn_potential`),
so it is smooth in free space and runs along the cost valley, not a staircase of cells.
The 8-connected cell search (step cost = step length x cell cost; Dijkstra, or A* with
the octile heuristic scaled by ``COST_NEUTRAL`` when ``use_astar``) runs first: it decides
reachability, the goal tolerance, cancel and time budgets and the typed errors, and its
optimal cell path is the fallback when the descent fails (counted in
``descent_fallbacks``; NavFn would fail the plan).

``smooth_path`` (navstack, default on) runs the smoother server's job on every plan: the
descent's points (every half cell) are thinned to one every :data:`THIN_CELLS` cells and
smoothed by Nav2's SimpleSmoother (its default parameters,
:func:`~navstack.planning.path_utils.smooth_path`) with ``keep_cost``: never into
inscribed or lethal cells, and no point into a cell costlier than the descent's, so the
plan stays in the cost valley.  The descent's heading ripples by +-10 degrees over 3-4
cells (the first-order potential's, whatever the gradient stencil); unsmoothed, that is a
curvature sign change every 0.1-0.2 m along the plan (issue 18 allows two per 10 m).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.params import Params
from navstack.core.plugins import register_planner
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION, Costmap2D
from navstack.planning.grid_planner import GridPlannerBase
from navstack.planning.grid_search import GridSearchWorkspace
from navstack.planning.navfn_potential import navfn_path_cells
from navstack.planning.path_utils import cells_to_world, smooth_path, straighten, thin_points
from navstack.planning.theta_star import interpolate_polyline

COST_NEUTRAL = 50
"""NavFn cost of a free cell (``COST_NEUTRAL``)."""
COST_FACTOR = 0.8
"""NavFn scaling of costmap costs (``COST_FACTOR``)."""
COST_OBS = 254
"""NavFn obstacle cost; unknown space costs ``COST_OBS - 1`` when allowed."""
THIN_CELLS = 4
"""Spacing [cells] of the points kept from the descent before smoothing (0.2 m at 5 cm)."""

def navfn_cost_table(allow_unknown: bool) -> NDArray[np.float64]:
    """NavFn cell cost for every costmap value 0..255; ``-1`` marks obstacles."""
    c = np.arange(256)
    table = np.floor(COST_NEUTRAL + COST_FACTOR * c).astype(np.float64)
    table = np.minimum(table, COST_OBS - 1)
    table[INSCRIBED_INFLATED_OBSTACLE:] = -1.0
    if allow_unknown:
        table[NO_INFORMATION] = COST_OBS - 1
    return table


class NavfnParams(Params):
    """Nav2 ``nav2_navfn_planner`` parameters (names and defaults as in Nav2)."""

    tolerance: float = Field(0.5, ge=0.0)
    """Goal tolerance [m]: end at the nearest reachable free cell this close if needed."""
    use_astar: bool = False
    """A* instead of Dijkstra's expansion (same path cost, fewer expansions)."""
    allow_unknown: bool = True
    """Plan through unknown (NO_INFORMATION) cells, at the highest non-lethal cost."""
    use_final_approach_orientation: bool = False
    """Last pose takes the heading of the last path segment instead of the goal's."""
    smooth_path: bool = True
    """navstack: thin the descent's points and smooth them with Nav2's SimpleSmoother,
    never into costlier cells (what Nav2's smoother server would do to every plan); false
    returns NavFn's raw descent."""
    straighten_deviation: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    """[m] navstack, with ``smooth_path``: then replace every stretch of the smoothed path
    that a straight chord within this distance of it can replace, never through a cell
    costlier than the chord's ends, and replace the small kinks that turn against both
    corners around them by a chord or by merging them into a corner beside them
    (:func:`~navstack.planning.path_utils.straighten`; the packaged nav2_params.yaml
    sets 0.15, which removes the walker-detour S-bends: docs/command_path.md, "Motion
    quality"); 0 keeps the smoothed path (Nav2)."""


@register_planner("Navfn", nav2="nav2_navfn_planner::NavfnPlanner")
class NavfnPlanner(GridPlannerBase):
    """``plan(start, goal, costmap, cancel=None) -> Path`` with NavFn's cost model."""

    name = "NavfnPlanner"
    params_model = NavfnParams
    params: NavfnParams

    def __init__(self, params: NavfnParams | None = None) -> None:
        super().__init__(params)
        self.tolerance = self.params.tolerance
        self.allow_unknown = self.params.allow_unknown
        self.use_final_approach_orientation = self.params.use_final_approach_orientation
        self.h_scale = float(COST_NEUTRAL) if self.params.use_astar else 0.0
        self.clear_start_cell = True  # Nav2 NavFn clearRobotCell
        self._table = navfn_cost_table(self.params.allow_unknown)
        self.descent_fallbacks = 0
        """Plans whose gradient descent failed and that returned the cell path."""

    def cost_model(self, data: NDArray[np.uint8]) -> tuple[NDArray[np.bool_],
                                                           NDArray[np.float64]]:
        weight = self._table[data]
        return weight >= 0.0, weight

    def path_points(self, ws: GridSearchWorkspace, start: tuple[int, int],
                    end: tuple[int, int], free: NDArray[np.bool_], weight: NDArray[np.float64],
                    costmap: Costmap2D) -> NDArray[np.float64]:
        """NavFn's gradient-descent path from ``start`` to ``end`` in world coordinates
        (cell points -> cell centres), or the search's cell path if the descent fails."""
        pts = navfn_path_cells(weight, free, start, end, self.params.use_astar,
                               float(COST_NEUTRAL))
        if len(pts) < 2:
            self.descent_fallbacks += 1
            return super().path_points(ws, start, end, free, weight, costmap)
        return cells_to_world(pts, costmap)

    def refine_points(self, xy: NDArray[np.float64], costmap: Costmap2D) -> NDArray[np.float64]:
        """With ``smooth_path``: one point every :data:`THIN_CELLS` cells of arc length
        (ends kept), then Nav2's SimpleSmoother, collision-aware."""
        if not self.params.smooth_path or len(xy) < 3:
            return xy
        spacing = THIN_CELLS * costmap.resolution
        thinned = thin_points(xy, spacing, costmap, self.allow_unknown)
        out = smooth_path(thinned, costmap, allow_unknown=self.allow_unknown, keep_cost=True)
        if self.params.straighten_deviation > 0.0:
            out = interpolate_polyline(straighten(out, costmap, self.params.straighten_deviation,
                                                  self.allow_unknown), spacing)
        return out
