"""Parameters of the Smac Hybrid-A* planner (Nav2 ``SmacPlannerHybrid`` names and defaults).

Defaults are those the Nav2 plugin declares (``smac_planner_hybrid.cpp``, rolling), so a
Nav2 ``planner_server`` section loads unchanged.  Deviations, all deliberate:

* ``reverse_penalty`` below 1 is treated as 1 ("no penalty") with a warning: Nav2
  documents it as ``>= 1`` and a value below 1 would *reward* reversing, which makes the
  search prefer backing up over driving forward.
* ``travel_distance_scale`` is refused with a pointer to ``retrospective_penalty``: it is
  not a SmacPlannerHybrid parameter in any Nav2 release (checked foxy .. rolling).
* ``minimum_turning_radius`` smaller than one (downsampled) costmap cell is an error at
  plan time (:class:`TurningRadiusTooSmall`); Nav2 silently raises it to one cell.
"""

from __future__ import annotations

import warnings
from typing import Any, Literal

from pydantic import Field, model_validator

from navstack.core.errors import ConfigError, PlannerError
from navstack.core.params import Params


class TurningRadiusTooSmall(PlannerError, ConfigError):
    """``minimum_turning_radius`` is smaller than one cell of the search grid.

    Both a planner error (a planner server maps it to a failed plan) and a configuration
    error (``key_path`` names the parameter).
    """


class SmacSmootherParams(Params):
    """The ``smoother`` sub-section (Nav2 ``SmootherParams`` names and defaults)."""

    max_iterations: int = Field(1000, ge=0)
    """Gradient-descent iterations per pass; 0 disables smoothing."""
    tolerance: float = Field(1e-10, gt=0.0)
    """Stop when the summed point motion of one iteration falls below this [m]."""
    w_smooth: float = Field(0.3, ge=0.0)
    """Weight pulling each point toward the midpoint of its neighbours."""
    w_data: float = Field(0.2, ge=0.0)
    """Weight pulling each point back toward its unsmoothed position."""
    do_refinement: bool = True
    """Re-run the smoother on its own result ``refinement_num`` more times."""
    refinement_num: int = Field(2, ge=0)


class HybridAStarParams(Params):
    """``nav2_smac_planner::SmacPlannerHybrid`` parameters (Nav2 names and defaults)."""

    motion_model_for_search: Literal["DUBIN", "REEDS_SHEPP"] = "DUBIN"
    """DUBIN: forward-only arcs; REEDS_SHEPP: forward and reverse."""
    angle_quantization_bins: int = Field(72, ge=4, le=1024)
    """Heading bins of the search lattice."""
    minimum_turning_radius: float = Field(0.4, gt=0.0)
    """Smallest turning radius of the vehicle [m]."""
    allow_primitive_interpolation: bool = False
    """Also expand turns of fewer bins (on wider circles) than the minimum-radius turn
    (default of the released Nav2 distributions; rolling switched it on in 2026)."""
    analytic_expansion_ratio: float = Field(3.5, gt=0.0)
    """Try a Dubins/RS shot to the goal every ``h / ratio`` expansions."""
    analytic_expansion_max_length: float = Field(3.0, ge=0.0)
    """Longest analytic shot accepted [m]."""
    analytic_expansion_max_cost: float = Field(200.0, ge=0.0)
    """Highest cell cost a shot may cross except on its final approach."""
    analytic_expansion_max_cost_override: bool = False
    """Accept a high-cost shot anyway when it is shorter than ``2 pi R``."""
    reverse_penalty: float = Field(2.0, ge=0.0)
    """Multiplier on reverse primitives (REEDS_SHEPP); below 1 is treated as 1."""
    change_penalty: float = Field(0.0, ge=0.0)
    """Extra multiplier when a turn switches direction (left <-> right)."""
    non_straight_penalty: float = Field(1.2, ge=0.0)
    """Multiplier on turning primitives."""
    cost_penalty: float = Field(2.0, ge=0.0)
    """Weight of cell cost in the travel cost and the obstacle heuristic."""
    retrospective_penalty: float = Field(0.015, ge=0.0, le=1.0)
    """Prefer manoeuvres late in the path (travel reward ``1 - retrospective_penalty``)."""
    use_quadratic_cost_penalty: bool = False
    """Use ``(cost / 252)^2`` instead of ``cost / 252`` in the cost terms."""
    downsample_obstacle_heuristic: bool = True
    """Run the obstacle-heuristic Dijkstra on a 2x coarser grid."""
    tolerance: float = Field(0.25, ge=0.0)
    """Accept the best node whose heuristic is within this distance [m] of the goal."""
    max_iterations: int = 1_000_000
    """Expansion budget; <= 0 disables it."""
    max_on_approach_iterations: int = 1000
    """Expansions allowed once a node within ``tolerance`` exists; <= 0 disables."""
    terminal_checking_interval: int = Field(5000, ge=1)
    """Expansions between checks of the cancel callback and ``max_planning_time``."""
    max_planning_time: float = Field(5.0, gt=0.0)
    """Time budget of the search [s]: wall time (Nav2), or on simulated time
    ``max_planning_time x sim_expansion_rate`` expansions (:mod:`navstack.planning.budget`)."""
    sim_expansion_rate: float = Field(1_000_000.0, gt=0.0)
    """navstack: expansions that count as one second of ``max_planning_time`` when the
    planner runs on simulated time (about the reference machine's rate,
    docs/hybrid_astar.md: 0.7 us an expansion), so a seed plans the same everywhere."""
    allow_unknown: bool = True
    """Traverse NO_INFORMATION cells."""
    downsample_costmap: bool = False
    """Plan on a costmap coarsened by ``downsampling_factor`` (max cost per block)."""
    downsampling_factor: int = Field(1, ge=1)
    cache_obstacle_heuristic: bool = False
    """Keep the obstacle heuristic between plans to the same goal cell (static maps)."""
    lookup_table_size: float = Field(20.0, gt=0.0)
    """Side of the Dubins/RS distance lookup window around the goal [m]."""
    smooth_path: bool = True
    """Run the built-in smoother on the search result."""
    smoother: SmacSmootherParams = SmacSmootherParams()

    @model_validator(mode="before")
    @classmethod
    def _no_invented_keys(cls, data: Any) -> Any:
        if isinstance(data, dict) and "travel_distance_scale" in data:
            raise ValueError(
                "travel_distance_scale is not a SmacPlannerHybrid parameter in any Nav2 "
                "release; to weigh travel distance use retrospective_penalty (travel reward "
                "= 1 - retrospective_penalty) and remove travel_distance_scale")
        return data

    @property
    def effective_reverse_penalty(self) -> float:
        """``reverse_penalty``, or 1.0 (with a warning) when it is below 1."""
        if self.reverse_penalty < 1.0:
            msg = (f"reverse_penalty {self.reverse_penalty} is below 1; treating it as 1.0 "
                   f"(no penalty): a value below 1 would reward reversing over driving "
                   f"forward. Set reverse_penalty >= 1 to silence this warning.")
            warnings.warn(msg, UserWarning, stacklevel=3)
            return 1.0
        return self.reverse_penalty


def golf_cart_hybrid_params() -> dict[str, Any]:
    """The golf cart's planner section in Nav2's layout (``planner_server`` plugin dict).

    REEDS_SHEPP because the cart reverses (``min_vel_x`` -0.35 m/s) and a 4.25 m radius
    cannot turn around on most campus paths without it.  ``reverse_penalty`` 0.9 is
    kept as configured on the cart; the planner treats it as 1.0 and warns.
    ``analytic_expansion_max_length`` is 5 x the radius, Nav2's rule of thumb ("no less
    than 4-5x the minimum radius"): with the 3 m default a 4.25 m car almost never
    connects analytically and 4 of 6 campus goals exceeded the 5 s budget.
    ``config/golf_cart_nav2_params.yaml`` (the demo) searches with DUBIN instead: with
    reversing allowed the plans ended in reverse manoeuvres MPPI would not drive (the
    reason is a comment there).
    """
    return {
        "plugin": "nav2_smac_planner::SmacPlannerHybrid",
        "tolerance": 0.5,
        "allow_unknown": False,
        "max_iterations": 5_000_000,
        "motion_model_for_search": "REEDS_SHEPP",
        "minimum_turning_radius": 4.25,
        "analytic_expansion_max_length": 21.25,
        "reverse_penalty": 0.9,
        "change_penalty": 5.0,
        "non_straight_penalty": 3.0,
        "cost_penalty": 30.0,
        "retrospective_penalty": 0.025,
        "smoother": {"max_iterations": 1000, "tolerance": 1e-10},
    }
