"""Cost-aware 8-connected A* (Nav2 Smac Planner 2D semantics).

Parameters follow ``nav2_smac_planner/SmacPlanner2D`` (names and defaults): a step into
a cell of cost ``c`` costs ``step_length * (1 + cost_travel_multiplier * c / 252)``
(Smac's ``Node2D::getTraversalCost``), inscribed and lethal cells are obstacles, unknown
cells are traversable at cost 255 when ``allow_unknown`` is true.  The search stops with
``PlannerTimeout`` after ``max_iterations`` expansions (-1: unlimited) or
``max_planning_time`` seconds (on simulated time: an expansion budget,
:mod:`navstack.planning.budget`), and checks the cancel callback every
``terminal_checking_interval`` expansions.  The heuristic is the octile distance, which
is admissible because every step costs at least its length.

The same kernel in "MovingAI mode" (unit weights, no corner cutting) is
:class:`navstack.planning.movingai.MovingAISolver`; :meth:`CostAwareAStar.movingai`
builds one.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from navstack.core.params import Params
from navstack.core.plugins import register_planner
from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
)
from navstack.planning.grid_planner import GridPlannerBase
from navstack.planning.movingai import MovingAISolver


def smac2d_cost_table(cost_travel_multiplier: float,
                      allow_unknown: bool) -> NDArray[np.float64]:
    """Traversal weight for every costmap value 0..255; ``-1`` marks obstacles."""
    c = np.arange(256, dtype=np.float64)
    table = 1.0 + cost_travel_multiplier * c / MAX_NON_OBSTACLE
    table[INSCRIBED_INFLATED_OBSTACLE:] = -1.0
    if allow_unknown:
        table[NO_INFORMATION] = 1.0 + cost_travel_multiplier * NO_INFORMATION / MAX_NON_OBSTACLE
    return table


class AStarParams(Params):
    """Nav2 ``SmacPlanner2D`` parameters implemented here (Nav2 names and defaults)."""

    tolerance: float = Field(0.125, ge=0.0)
    """Goal tolerance [m]: end at the nearest reachable free cell this close if needed."""
    allow_unknown: bool = True
    max_iterations: int = Field(1_000_000, ge=-1)
    """Expansion budget before ``PlannerTimeout``; -1 disables it."""
    max_planning_time: float = Field(2.0, gt=0.0)
    """Time budget [s] before ``PlannerTimeout``: wall time (Nav2), or on simulated time
    ``max_planning_time x sim_expansion_rate`` expansions (:mod:`navstack.planning.budget`)."""
    sim_expansion_rate: float = Field(5_000_000.0, gt=0.0)
    """navstack: expansions that count as one second of ``max_planning_time`` on
    simulated time (about this kernel's rate on the reference machine)."""
    cost_travel_multiplier: float = Field(2.0, ge=0.0)
    """Weight of cell cost against distance: higher keeps the path away from obstacles."""
    use_final_approach_orientation: bool = False
    terminal_checking_interval: int = Field(5000, ge=1)
    """Expansions between checks of the cancel callback and the time budget."""

    @field_validator("max_iterations")
    @classmethod
    def _positive_or_disabled(cls, v: int) -> int:
        if v == 0:
            raise ValueError("must be positive, or -1 to disable the limit")
        return v


@register_planner("CostAwareAStar", nav2="nav2_smac_planner::SmacPlanner2D")
class CostAwareAStar(GridPlannerBase):
    """``plan(start, goal, costmap, cancel=None) -> Path`` with Smac 2D's cost model."""

    name = "CostAwareAStar"
    params_model = AStarParams
    params: AStarParams

    def __init__(self, params: AStarParams | None = None) -> None:
        super().__init__(params)
        p = self.params
        self.tolerance = p.tolerance
        self.allow_unknown = p.allow_unknown
        self.use_final_approach_orientation = p.use_final_approach_orientation
        self.h_scale = 1.0
        self.max_iterations = None if p.max_iterations < 0 else p.max_iterations
        self.max_planning_time = p.max_planning_time
        self.sim_expansion_rate = p.sim_expansion_rate
        self.chunk = p.terminal_checking_interval
        self._table = smac2d_cost_table(p.cost_travel_multiplier, p.allow_unknown)

    def cost_model(self, data: NDArray[np.uint8]) -> tuple[NDArray[np.bool_],
                                                           NDArray[np.float64]]:
        weight = self._table[data]
        return weight >= 0.0, weight

    @staticmethod
    def movingai(passable: NDArray[np.bool_]) -> MovingAISolver:
        """A MovingAI-mode solver (octile metric, no corner cutting) for one map."""
        return MovingAISolver(passable)
