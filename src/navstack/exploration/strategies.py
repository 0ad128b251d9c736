"""Which frontier next: explore_lite's cost, and an information-gain utility.

* :class:`ExploreLiteCost` -- explore_lite's ``frontierCost``: ``potential_scale *
  distance - gain_scale * size + orientation_scale * |turn|``, lowest first.  Distance
  is the path distance [m] and size the frontier length [m] (explore_lite's code
  multiplies its straight-line distance, already in metres, by the resolution a second
  time; with the usual ``potential_scale`` 1e-3 the size term decides either way).
  The goal is the frontier's centroid, moved onto the nearest cell the robot can stand
  on (:mod:`.frontiers`).  ``turn`` is the heading change to face the goal [rad] (the
  original explore's ``orientation_scale`` term; 0 in the TurtleBot course).
* :class:`InformationGainUtility` -- the navstack default: every frontier offers
  viewpoints (its approach cells, one per ``viewpoint_spacing``); a viewpoint's utility
  is the unknown area a lidar there would see (:mod:`.gain`) discounted by its path
  distance, ``gain * exp(-distance_decay * (distance + turn_distance * turn))``
  (González-Baños & Latombe 2002), ``turn`` the heading change to face it.  A large far
  frontier no longer beats a small near one, which is what sends explore_lite back and
  forth across a building.  With ``path_gain`` the best viewpoint of each frontier is
  then scored on the unknown area visible from its path as well (one point per
  ``viewpoint_spacing`` along the wavefront's shortest path, each cell counted once): a
  target whose way passes the view of another frontier is worth both.

* :class:`NearestFrontier` -- Yamauchi's greedy nearest frontier (the benchmark's
  reference).

All return :class:`Target` lists, best first.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from navstack.core.geometry import normalize_angle
from navstack.exploration.frontiers import Frontier, FrontierSet
from navstack.exploration.gain import path_cells, visible_unknown, visible_unknown_along
from navstack.exploration.grid_view import GridView
from navstack.exploration.params import ExploreParams

__all__ = ["ExplorationStrategy", "ExploreLiteCost", "InformationGainUtility",
           "NearestFrontier", "Target", "make_strategy"]


@dataclass(frozen=True)
class Target:
    """A frontier to pursue: where to send the robot and the strategy's score."""

    frontier: Frontier
    goal: tuple[float, float]
    distance: float
    """Path distance [m] from the robot to ``goal``."""
    score: float
    """Cost (explore_lite, lower is better) or utility (information gain, higher)."""
    gain: float = 0.0
    """Unknown area [m^2] visible from ``goal`` (information gain only)."""


class ExplorationStrategy(ABC):
    """Ranks the reachable frontiers of a :class:`FrontierSet`."""

    name: ClassVar[str]
    higher_is_better: ClassVar[bool]
    follows_best: ClassVar[bool] = True
    """Switch to the best target at every plan (explore_lite); otherwise keep the current
    target unless another beats it by ``retarget_hysteresis``."""

    def __init__(self, params: ExploreParams) -> None:
        self.params = params

    @abstractmethod
    def rank(self, frontiers: FrontierSet, view: GridView,
             robot: tuple[float, float, float]) -> list[Target]:
        """Targets for the reachable frontiers, best first."""

    def viewpoint_utility(self, frontiers: FrontierSet, view: GridView,
                          robot: tuple[float, float, float],
                          goal: tuple[float, float]) -> float | None:
        """The score of sending the robot to ``goal`` for its frontier, for strategies
        that score viewpoints (higher is better); ``None`` for those that do not."""
        return None

    def better(self, a: float, b: float, margin: float = 0.0) -> bool:
        """True when score ``a`` beats ``b`` by more than ``margin`` (a fraction)."""
        if self.higher_is_better:
            return a > b * (1.0 + margin) + 1e-12
        return a < b - abs(b) * margin - 1e-12


def _turn(robot: tuple[float, float, float], goal: tuple[float, float]) -> float:
    dx, dy = goal[0] - robot[0], goal[1] - robot[1]
    if math.hypot(dx, dy) < 1e-9:
        return 0.0
    return abs(float(normalize_angle(math.atan2(dy, dx) - robot[2])))


class ExploreLiteCost(ExplorationStrategy):
    """explore_lite's frontier cost (module docstring)."""

    name = "explore_lite"
    higher_is_better = False

    def rank(self, frontiers: FrontierSet, view: GridView,
             robot: tuple[float, float, float]) -> list[Target]:
        p = self.params
        out = []
        for f in frontiers.reachable:
            assert f.goal is not None
            cost = (p.potential_scale * f.distance - p.gain_scale * f.size_m
                    + p.orientation_scale * _turn(robot, f.goal))
            gx, gy = f.goal
            r, c = view.cell_of(gx, gy)
            out.append(Target(f, f.goal, float(frontiers.distances[r, c]), cost))
        out.sort(key=lambda t: t.score)
        return out


class NearestFrontier(ExplorationStrategy):
    """Yamauchi's greedy rule (1997): the frontier nearest by path, approached at its
    nearest cell.  The exploration benchmark's idealised reference explorer uses it."""

    name = "nearest"
    higher_is_better = False

    def rank(self, frontiers: FrontierSet, view: GridView,
             robot: tuple[float, float, float]) -> list[Target]:
        out = []
        for f in frontiers.reachable:
            assert f.nearest is not None
            out.append(Target(f, f.nearest, f.distance, f.distance))
        out.sort(key=lambda t: t.score)
        return out


class InformationGainUtility(ExplorationStrategy):
    """Visible unknown area discounted by path distance (module docstring)."""

    name = "information_gain"
    higher_is_better = True
    follows_best = False

    def rank(self, frontiers: FrontierSet, view: GridView,
             robot: tuple[float, float, float]) -> list[Target]:
        p = self.params
        spacing = max(1, round(p.viewpoint_spacing / view.resolution))
        rows, cols, owner = [], [], []
        for i, f in enumerate(frontiers.reachable):
            # one viewpoint per spacing x spacing block of approach cells: the nearest
            d = frontiers.distances[f.approach_rows, f.approach_cols]
            key = (f.approach_rows // spacing) * 1_000_003 + f.approach_cols // spacing
            order = np.lexsort((d, key))
            first = np.ones(order.size, dtype=bool)
            first[1:] = key[order][1:] != key[order][:-1]
            pick = order[first]
            rows.append(f.approach_rows[pick])
            cols.append(f.approach_cols[pick])
            owner.append(np.full(pick.size, i))
        if not rows:
            return []
        r = np.concatenate(rows)
        c = np.concatenate(cols)
        who = np.concatenate(owner)
        gain = visible_unknown(view, r, c, p.sensor_range) * view.resolution ** 2
        dist = frontiers.distances[r, c]
        pts = view.centres(r, c)
        discount = np.exp(-p.distance_decay * (dist + p.turn_distance * _turns(robot, pts)))
        utility = gain * discount
        best: dict[int, int] = {}
        for k in np.argsort(-utility, kind="stable"):
            best.setdefault(int(who[k]), int(k))
        score = {k: float(utility[k]) for k in best.values()}
        if p.path_gain and best:
            # what the robot sees on the way counts too: a target whose path passes
            # another frontier's view is worth that frontier as well
            every = max(1, round(p.viewpoint_spacing / view.resolution))
            ks = list(best.values())
            paths = [path_cells(frontiers.distances, int(r[k]), int(c[k]), every) for k in ks]
            seen = visible_unknown_along(view, paths, p.sensor_range,
                                         seen_from=frontiers.start) * view.resolution ** 2
            score = {k: float(seen[j] * discount[k]) for j, k in enumerate(ks)}
        out = [Target(frontiers.reachable[i], (float(pts[k, 0]), float(pts[k, 1])),
                      float(dist[k]), score[k], float(gain[k]))
               for i, k in best.items()]
        out.sort(key=lambda t: -t.score)
        return out

    def viewpoint_utility(self, frontiers: FrontierSet, view: GridView,
                          robot: tuple[float, float, float],
                          goal: tuple[float, float]) -> float | None:
        """The goal-only utility of one viewpoint (no path gain): 0 when it is off the
        map, not reachable, or sees no unknown cell any more."""
        p = self.params
        r, c = view.cell_of(*goal)
        if not view.inside(r, c) or not math.isfinite(float(frontiers.distances[r, c])):
            return 0.0
        rows, cols = np.array([r]), np.array([c])
        gain = float(visible_unknown(view, rows, cols, p.sensor_range)[0]) * view.resolution ** 2
        turn = float(_turns(robot, view.centres(rows, cols))[0])
        return gain * math.exp(-p.distance_decay * (float(frontiers.distances[r, c])
                                                    + p.turn_distance * turn))


def _turns(robot: tuple[float, float, float], pts: np.ndarray) -> np.ndarray:
    """The turn [rad] to head for each point: metres the robot would have driven meanwhile
    once scaled by ``turn_distance``."""
    bearing = np.arctan2(pts[:, 1] - robot[1], pts[:, 0] - robot[0]) - robot[2]
    turn = np.abs(np.remainder(bearing + math.pi, 2.0 * math.pi) - math.pi)
    turn[np.hypot(pts[:, 0] - robot[0], pts[:, 1] - robot[1]) < 1e-9] = 0.0
    return turn


STRATEGIES: dict[str, type[ExplorationStrategy]] = {
    cls.name: cls for cls in (ExploreLiteCost, InformationGainUtility, NearestFrontier)}


def make_strategy(params: ExploreParams) -> ExplorationStrategy:
    """The strategy ``params.strategy`` names."""
    return STRATEGIES[params.strategy](params)
