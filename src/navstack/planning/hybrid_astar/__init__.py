"""Smac Hybrid-A* (Nav2 ``nav2_smac_planner::SmacPlannerHybrid``): SE(2) lattice search
with Dubins / Reeds-Shepp motion primitives, analytic expansions, footprint collision
checks and the Smac smoother.  See ``docs/hybrid_astar.md``.
"""

from navstack.planning.hybrid_astar.checks import (
    max_curvature,
    path_collision,
    pose_collision,
    travel_directions,
)
from navstack.planning.hybrid_astar.curves import DUBIN, REEDS_SHEPP, sample, shortest
from navstack.planning.hybrid_astar.params import (
    HybridAStarParams,
    SmacSmootherParams,
    TurningRadiusTooSmall,
    golf_cart_hybrid_params,
)
from navstack.planning.hybrid_astar.plan_types import HybridPlan
from navstack.planning.hybrid_astar.planner import HybridAStar

__all__ = [
    "DUBIN", "REEDS_SHEPP", "HybridAStar", "HybridAStarParams", "HybridPlan",
    "SmacSmootherParams", "TurningRadiusTooSmall", "golf_cart_hybrid_params", "max_curvature",
    "path_collision", "pose_collision", "sample", "shortest", "travel_directions",
]
