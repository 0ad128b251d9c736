"""NavFn's potential field and gradient-descent path (issue 18, part 8): exact potential
values, smooth near-straight paths in free space, the cost valley between obstacles, and
curvature that does not flip back and forth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import Costmap2D
from navstack.interfaces.motion_quality import curvature_sign_changes, path_length
from navstack.planning import AStarParams, CostAwareAStar, NavfnParams, NavfnPlanner
from navstack.planning import navfn as navfn_module
from navstack.planning.navfn_potential import POT_HIGH, navfn_path_cells, navfn_potential


def test_potential_follows_navfn_update_rule() -> None:
    w = np.full((5, 5), 50.0)
    free = np.ones((5, 5), dtype=bool)
    free[4, 4] = False
    pot = navfn_potential(w, free, 2, 2, 0, 0, 0.0, 1e9)
    assert pot[2, 2] == 0.0
    assert pot[2, 3] == pot[3, 2] == 50.0  # one side only: ta + h
    # a diagonal neighbour: both sides 50 -> 50 + 0.704 * 50 (NavFn's quadratic fit)
    assert pot[3, 3] == pytest.approx(50.0 + 0.704 * 50.0, abs=1e-9)
    assert pot[4, 4] == POT_HIGH  # not free: never reached
    # A* keys (0.7 * cost_neutral per cell of distance) finalise the same potentials
    astar = navfn_potential(w, free, 2, 2, 0, 0, 0.7 * 50.0, 1e9)
    np.testing.assert_allclose(astar[pot < POT_HIGH], pot[pot < POT_HIGH], rtol=1e-12)


@pytest.mark.parametrize("angle_deg", [0.0, 20.0, 30.0, 45.0, 70.0])
def test_free_space_path_is_nearly_straight(angle_deg: float) -> None:
    cm = Costmap2D.from_array(np.zeros((200, 300), dtype=np.uint8), 0.05)
    a = math.radians(angle_deg)
    start = Pose2D(1.0, 1.0, 0.0)
    goal = Pose2D(1.0 + 8.0 * math.cos(a) * 1.5, 1.0 + 8.0 * math.sin(a), 0.0)
    for smooth in (False, True):
        planner = NavfnPlanner(NavfnParams(smooth_path=smooth))
        xy = planner.plan(start, goal, cm).as_array()[:, :2]
        chord = math.hypot(goal.x - start.x, goal.y - start.y)
        u = np.array([goal.x - start.x, goal.y - start.y]) / chord
        lateral = (xy - [start.x, start.y]) @ np.array([-u[1], u[0]])
        assert path_length(xy) <= 1.003 * chord  # an 8-connected cell path: up to +8 %
        assert np.max(np.abs(lateral)) < 0.15
        assert planner.descent_fallbacks == 0
        if smooth:
            assert curvature_sign_changes(xy) <= 2
    # the cell path of the same search (what NavFn used to return) is a staircase
    cells = CostAwareAStar(AStarParams(cost_travel_multiplier=0.0)).plan(start, goal, cm)
    if angle_deg not in (0.0, 45.0):
        assert path_length(cells.as_array()[:, :2]) > 1.02 * chord


def test_path_runs_along_the_cost_valley_without_wiggles() -> None:
    # a 1.0 m wide passage between two inflated walls (cost rising toward each wall)
    res = 0.05
    data = np.zeros((80, 160), dtype=np.uint8)
    ys = (np.arange(80) + 0.5) * res
    wall_lo, wall_hi = 1.5, 2.5
    dist = np.minimum(np.abs(ys - wall_lo), np.abs(ys - wall_hi))
    cost = np.where(dist < 0.3, 253, np.clip(252 * np.exp(-3.0 * (dist - 0.3)), 0, 252))
    band = (ys > wall_lo) & (ys < wall_hi)
    data[band, 60:100] = cost[band, None].astype(np.uint8)
    data[~band, 60:100] = 254  # the walls, between x = 3 and 5 m
    cm = Costmap2D.from_array(data, res)
    start, goal = Pose2D(0.5, 0.5, 0.0), Pose2D(7.5, 3.5, 0.0)
    planner = NavfnPlanner()
    xy = planner.plan(start, goal, cm).as_array()[:, :2]
    inside = (xy[:, 0] > 3.2) & (xy[:, 0] < 4.8)
    assert inside.any()
    assert np.all(np.abs(xy[inside, 1] - 2.0) < 0.05)  # the valley floor is the centre
    assert curvature_sign_changes(xy) <= 2  # into the passage and out: one S, no wiggles
    raw = NavfnPlanner(NavfnParams(smooth_path=False)).plan(start, goal, cm).as_array()
    assert curvature_sign_changes(raw[:, :2]) > curvature_sign_changes(xy)


def test_a_failed_descent_falls_back_to_the_cell_path(monkeypatch: pytest.MonkeyPatch) -> None:
    cm = Costmap2D.from_array(np.zeros((40, 40), dtype=np.uint8), 0.1)
    monkeypatch.setattr(navfn_module, "navfn_path_cells",
                        lambda *args, **kwargs: np.zeros((0, 2)))
    planner = NavfnPlanner(NavfnParams(smooth_path=False))
    path = planner.plan(Pose2D(0.55, 0.55, 0.0), Pose2D(3.05, 1.55, 0.0), cm)
    assert planner.descent_fallbacks == 1
    xy = path.as_array()[:, :2]
    steps = np.round(np.abs(np.diff(xy[1:-1], axis=0)) / 0.1).astype(int)
    assert steps.max() == 1 and (steps.sum(axis=1) >= 1).all()  # cell-centre steps


def test_descent_reaches_the_source_in_half_cell_steps() -> None:
    w = np.full((30, 40), 50.0)
    free = np.ones((30, 40), dtype=bool)
    pts = navfn_path_cells(w, free, (3, 4), (35, 25), use_astar=False, neutral=50.0)
    np.testing.assert_array_equal(pts[0], [3, 4])  # from the source cell ...
    np.testing.assert_allclose(pts[-1], [35, 25])  # ... to the goal cell
    steps = np.hypot(*np.diff(pts[1:], axis=0).T)
    assert np.allclose(steps, 0.5)
