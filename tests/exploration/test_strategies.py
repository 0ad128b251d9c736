"""Frontier ranking: explore_lite's cost formula, information gain, nearest frontier."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.exploration.frontiers import find_frontiers
from navstack.exploration.gain import visible_unknown
from navstack.exploration.grid_view import GridView
from navstack.exploration.params import ExploreParams
from navstack.exploration.strategies import (
    ExploreLiteCost,
    InformationGainUtility,
    NearestFrontier,
    make_strategy,
)

RES = 0.1


def corridor_view() -> GridView:
    """A 6 m free strip; a short frontier (0.5 m) at the near end and a long one
    (2.0 m) 4 m away, both opening onto unknown space."""
    h, w = 30, 60
    unknown = np.zeros((h, w), bool)
    free = np.zeros((h, w), bool)
    free[10:20, :] = True            # the strip, rows 10..19
    unknown[20:, 0:5] = True         # unknown north of the strip's first 0.5 m
    unknown[20:, 40:60] = True       # unknown north of x 4..6 m
    free[20:, 5:40] = False
    occupied = ~unknown & ~free
    occupied[:10, :] = True
    return GridView(unknown, free, free.copy(), RES)


def test_explore_lite_cost_is_potential_times_distance_minus_gain_times_size() -> None:
    v = corridor_view()
    fs = find_frontiers(v, (0.25, 1.5), min_frontier_size=0.3)
    assert len(fs.reachable) == 2
    p = ExploreParams(strategy="explore_lite", potential_scale=0.5, gain_scale=1.0,
                      orientation_scale=0.0)
    ranked = ExploreLiteCost(p).rank(fs, v, (0.25, 1.5, 0.0))
    for t in ranked:
        assert t.score == pytest.approx(0.5 * t.frontier.distance - 1.0 * t.frontier.size_m)
    # the course's potential_scale 1e-3: size wins, the far long frontier comes first
    course = ExploreLiteCost(ExploreParams(strategy="explore_lite"))
    assert course.rank(fs, v, (0.25, 1.5, 0.0))[0].frontier.size_m == pytest.approx(2.0)
    # a strong potential_scale prefers the near short one
    assert ranked[0].frontier.size_m == pytest.approx(0.5)
    # orientation_scale adds |turn| to the goal: facing away from both, turn ~ pi/2
    turned = ExploreLiteCost(p.updated(orientation_scale=1.0)).rank(fs, v, (0.25, 1.5, -1.0))
    by_size = {round(t.frontier.size_m, 1): t for t in turned}
    near = by_size[0.5]
    gx, gy = near.goal
    turn = abs(math.remainder(math.atan2(gy - 1.5, gx - 0.25) + 1.0, 2 * math.pi))
    assert near.score == pytest.approx(0.5 * near.frontier.distance - 0.5 + turn)


def test_information_gain_discounts_by_path_distance() -> None:
    v = corridor_view()
    fs = find_frontiers(v, (0.25, 1.5), min_frontier_size=0.3)
    ig = InformationGainUtility(ExploreParams(distance_decay=0.35, sensor_range=3.5,
                                              turn_distance=0.0, path_gain=False))
    ranked = ig.rank(fs, v, (0.25, 1.5, 0.0))
    assert len(ranked) == 2
    for t in ranked:
        assert t.score == pytest.approx(t.gain * math.exp(-0.35 * t.distance))
        assert t.gain > 0
    # with the turn term: the path is lengthened by turn_distance x the heading change
    turned = InformationGainUtility(ExploreParams(distance_decay=0.35, turn_distance=0.26,
                                                  path_gain=False)).rank(fs, v, (0.25, 1.5, 0.0))
    for t in turned:
        turn = abs(math.remainder(math.atan2(t.goal[1] - 1.5, t.goal[0] - 0.25), 2 * math.pi))
        assert t.score == pytest.approx(t.gain * math.exp(-0.35 * (t.distance + 0.26 * turn)))
    # more unknown area is visible from the long frontier; without decay it wins
    flat = InformationGainUtility(ExploreParams(distance_decay=0.0, path_gain=False)).rank(
        fs, v, (0.25, 1.5, 0.0))
    assert flat[0].frontier.size_m == pytest.approx(2.0)
    assert flat[0].gain > flat[1].gain
    # a steep decay prefers the near frontier
    steep = InformationGainUtility(ExploreParams(distance_decay=2.0, path_gain=False)).rank(
        fs, v, (0.25, 1.5, 0.0))
    assert steep[0].frontier.size_m == pytest.approx(0.5)


def test_nearest_frontier_and_registry() -> None:
    v = corridor_view()
    fs = find_frontiers(v, (0.25, 1.5), min_frontier_size=0.3)
    ranked = NearestFrontier(ExploreParams()).rank(fs, v, (0.25, 1.5, 0.0))
    assert [t.frontier.size_m for t in ranked] == [pytest.approx(0.5), pytest.approx(2.0)]
    assert ranked[0].goal == ranked[0].frontier.nearest
    for name, cls in (("explore_lite", ExploreLiteCost), ("nearest", NearestFrontier),
                      ("information_gain", InformationGainUtility)):
        assert isinstance(make_strategy(ExploreParams(strategy=name)), cls)


def test_visible_unknown_counts_cells_in_range_until_an_obstacle() -> None:
    h = w = 41
    unknown = np.ones((h, w), bool)
    free = np.zeros((h, w), bool)
    v = GridView(unknown, free, free.copy(), 0.1)
    # all unknown, no obstacle: the disc of radius 1 m (10 cells) minus nothing
    n = int(visible_unknown(v, np.array([20]), np.array([20]), 1.0, beams=720)[0])
    assert abs(n - math.pi * 10.5 ** 2) < 0.08 * math.pi * 10.5 ** 2
    # a wall ring at 3 cells stops every ray: only the inside counts
    blocked = np.zeros((h, w), bool)
    r, c = np.mgrid[0:h, 0:w]
    ring = np.abs(np.hypot(r - 20, c - 20) - 3.0) < 0.75
    blocked[ring] = True
    inside = visible_unknown(v, np.array([20]), np.array([20]), 2.0, beams=720,
                             blocked=blocked)[0]
    assert inside <= int((np.hypot(r - 20, c - 20) < 3.0).sum())


def test_information_gain_prefers_the_target_ahead_of_the_robot() -> None:
    """Two equal frontiers at the ends of a strip, the robot midway: the one it faces
    wins (``turn_distance`` lengthens the other's path by the turn); without the term
    the two score the same."""
    h, w = 20, 61
    unknown = np.zeros((h, w), bool)
    unknown[:, :5] = True
    unknown[:, -5:] = True
    free = ~unknown
    v = GridView(unknown, free, free.copy(), RES)
    robot_xy = (3.05, 1.0)
    fs = find_frontiers(v, robot_xy, min_frontier_size=0.3)
    assert len(fs.reachable) == 2
    for yaw, side in ((0.0, 1.0), (math.pi, -1.0)):
        ranked = InformationGainUtility(ExploreParams(turn_distance=0.26, path_gain=False)
                                        ).rank(fs, v, (*robot_xy, yaw))
        assert (ranked[0].goal[0] - robot_xy[0]) * side > 0
        assert ranked[0].score > ranked[1].score
    flat = InformationGainUtility(ExploreParams(turn_distance=0.0, path_gain=False)).rank(
        fs, v, (*robot_xy, 0.0))
    assert flat[0].score == pytest.approx(flat[1].score, rel=1e-6)
    # facing one end, the other is behind: about pi rad x 0.26 m/rad more path
    turned = InformationGainUtility(ExploreParams(turn_distance=0.26, path_gain=False)).rank(
        fs, v, (*robot_xy, 0.0))
    behind = min(turned, key=lambda t: t.goal[0])
    turn = abs(math.remainder(math.atan2(behind.goal[1] - robot_xy[1],
                                         behind.goal[0] - robot_xy[0]), 2 * math.pi))
    assert turn == pytest.approx(math.pi, abs=0.1)
    assert behind.score == pytest.approx(
        behind.gain * math.exp(-0.35 * (behind.distance + 0.26 * turn)), rel=1e-6)


def test_path_gain_counts_what_the_way_to_a_target_sees_but_not_what_the_robot_sees_now(
        ) -> None:
    """An 8 m corridor with unknown space at its far end and a side room half way: the
    far target's path passes the room's door, so with ``path_gain`` its score counts the
    room too; what is visible from the robot's own cell counts for no target."""
    from navstack.exploration.gain import path_cells, visible_unknown_along

    h, w = 20, 80
    unknown = np.zeros((h, w), bool)
    free = np.zeros((h, w), bool)
    free[8:12, :75] = True               # the corridor, rows 8..11
    unknown[8:12, 75:] = True            # its unknown far end
    unknown[12:20, 38:46] = True         # the side room, door at row 12
    v = GridView(unknown, free, free.copy(), RES)
    robot = (0.25, 1.0, 0.0)
    fs = find_frontiers(v, robot[:2], min_frontier_size=0.3)
    params = ExploreParams(turn_distance=0.0)
    plain = {round(t.goal[0]): t for t in InformationGainUtility(
        params.updated(path_gain=False)).rank(fs, v, robot)}
    along = {round(t.goal[0]): t for t in InformationGainUtility(params).rank(fs, v, robot)}
    far_plain, far_along = plain[7], along[7]
    discount = math.exp(-0.35 * far_plain.distance)
    assert far_plain.score == pytest.approx(far_plain.gain * discount)
    # the room (0.64 m^2) seen from the corridor on the way
    assert far_along.score / discount - far_plain.gain > 0.4
    # from the robot's cell alone nothing new is seen
    start = fs.start
    assert start is not None
    assert visible_unknown_along(v, [np.array([start])], 3.5, seen_from=start)[0] == 0
    path = path_cells(fs.distances, *v.cell_of(*far_along.goal), every=5)
    assert tuple(path[-1]) == start and tuple(path[0]) == v.cell_of(*far_along.goal)
