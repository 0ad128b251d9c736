"""Frontier exploration and coverage, as pure algorithms (no bus, no I/O).

* :mod:`.grid_view` -- classify an occupancy grid / costmap into unknown, free and
  traversable cells;
* :mod:`.wavefront` -- path distances from the robot (the planner's Dijkstra kernel);
* :mod:`.frontiers` -- explore_lite's frontiers, ranked by path distance, reachable or
  not;
* :mod:`.gain` -- unknown area visible from a viewpoint (numba raycast);
* :mod:`.strategies` -- explore_lite's frontier cost and the information-gain utility;
* :mod:`.blacklist`, :mod:`.explorer` -- the decision loop (explore_lite ``makePlan``);
* :mod:`.coverage` -- the TurtleBot course's coverage search: 0.8 m cells, the free-box
  filter, nearest-neighbour + 2-opt visiting order.

The mission layer (:mod:`navstack.missions`) drives these on the bus; the benchmark's
idealised reference explorer runs them on the true world.  Everything takes numpy
arrays or an ``OccupancyGrid`` and can be used in a notebook.
"""

from navstack.exploration.explorer import Decision, DecisionKind, FrontierExplorer
from navstack.exploration.frontiers import Frontier, FrontierSet, find_frontiers
from navstack.exploration.grid_view import ExplorationError, GridView
from navstack.exploration.params import ExploreParams
from navstack.exploration.strategies import (
    ExploreLiteCost,
    InformationGainUtility,
    Target,
    make_strategy,
)

__all__ = ["Decision", "DecisionKind", "ExplorationError", "ExploreLiteCost", "ExploreParams",
           "Frontier", "FrontierExplorer", "FrontierSet", "GridView", "InformationGainUtility",
           "Target", "find_frontiers", "make_strategy"]
