"""NavFn-style global planner: Dijkstra or A* over NavFn's cell costs.

Follows Nav2's ``nav2_navfn_planner/NavfnPlanner`` (parameters ``tolerance``,
``use_astar``, ``allow_unknown``, ``use_final_approach_orientation`` with Nav2's
defaults) and its cost mapping (``navfn.cpp`` ``setCostmap``): a costmap cell of cost
``c < 253`` costs ``COST_NEUTRAL + COST_FACTOR * c = 50 + 0.8 c`` (truncated to an
integer as NavFn stores it), inscribed (253) and lethal (254) cells are obstacles, and
unknown (255) cells cost the maximum ``COST_OBS - 1 = 253`` when ``allow_unknown`` is
true and are obstacles otherwise.

Where NavFn propagates a continuous potential and descends its gradient, this planner
searches the 8-connected cell graph (step cost = step length x cell cost) and returns the
optimal cell path; Dijkstra (``use_astar: false``) and A* (octile heuristic scaled by
``COST_NEUTRAL``, admissible since no cell costs less) return paths of the same cost.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.params import Params
from navstack.core.plugins import register_planner
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION
from navstack.planning.grid_planner import GridPlannerBase

COST_NEUTRAL = 50
"""NavFn cost of a free cell (``COST_NEUTRAL``)."""
COST_FACTOR = 0.8
"""NavFn scaling of costmap costs (``COST_FACTOR``)."""
COST_OBS = 254
"""NavFn obstacle cost; unknown space costs ``COST_OBS - 1`` when allowed."""

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
        self._table = navfn_cost_table(self.params.allow_unknown)

    def cost_model(self, data: NDArray[np.uint8]) -> tuple[NDArray[np.bool_],
                                                           NDArray[np.float64]]:
        weight = self._table[data]
        return weight >= 0.0, weight
