"""Global planners: NavFn-style grid search, cost-aware A*, MovingAI grid benchmarks.

``NavfnPlanner(NavfnParams(...)).plan(start, goal, costmap, cancel=None) -> Path`` and
``CostAwareAStar(AStarParams(...)).plan(...)`` share one numba search kernel
(:mod:`navstack.planning.grid_search`); :mod:`navstack.planning.movingai` runs the same
kernel on MovingAI benchmark maps; :mod:`navstack.planning.path_utils` holds path
orientation, length and Nav2-style simple smoothing.
"""

from navstack.planning.astar import AStarParams, CostAwareAStar
from navstack.planning.grid_search import GridSearchWorkspace
from navstack.planning.movingai import MovingAISolver, Scenario, load_map, load_scen, solve
from navstack.planning.navfn import NavfnParams, NavfnPlanner
from navstack.planning.path_utils import (
    SimpleSmootherParams,
    make_path,
    orientations,
    path_length,
    smooth_path,
)

__all__ = [
    "AStarParams", "CostAwareAStar", "GridSearchWorkspace", "MovingAISolver", "NavfnParams",
    "NavfnPlanner", "Scenario", "SimpleSmootherParams", "load_map", "load_scen", "make_path",
    "orientations", "path_length", "smooth_path", "solve",
]
