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


def _office_costmap_with_person(px: float, py: float, radius: float) -> Costmap2D:
    """The office's map with a person (a disc of ``radius`` at ``px, py``), inflated as
    the packaged costmap does (inscribed 0.27 m, cost_scaling_factor 2.5, 0.7 m)."""
    from scipy import ndimage

    from navstack.sim.worlds import load_world

    w = load_world("office")
    res = w.resolution
    yy, xx = np.mgrid[0:w.occupied.shape[0], 0:w.occupied.shape[1]]
    person = np.hypot(w.origin_x + (xx + 0.5) * res - px,
                      w.origin_y + (yy + 0.5) * res - py) <= radius
    occ = w.occupied | person
    d = ndimage.distance_transform_edt(~occ) * res
    cost = np.where(d <= 0.27, 253, np.where(d <= 0.7, np.floor(252 * np.exp(-2.5 * (d - 0.27))),
                                             0))
    cost[occ] = 254
    return Costmap2D.from_array(cost.astype(np.uint8), res, w.origin_x, w.origin_y)


def test_straightened_plan_past_a_person_into_a_door_has_one_s() -> None:
    """The office corridor with a person marked on it, from the corridor to room E: NavFn's
    smoothed plan swerves around the person, swings back to the corridor's centre and
    turns into the door (4 curvature sign changes in 14.7 m, 2.7 per 10 m); straightened
    (``straighten_deviation`` 0.15 m) it runs from the pinch point to the door (1), no
    closer to the person and no costlier than the smoothed plan + 15 %."""
    cm = _office_costmap_with_person(12.6, 7.9, 0.3)
    start, goal = Pose2D(14.78, 7.45, math.pi), Pose2D(1.5, 10.0, math.pi)
    smoothed = NavfnPlanner().plan(start, goal, cm).as_array()[:, :2]
    straight = NavfnPlanner(NavfnParams(straighten_deviation=0.15)).plan(start, goal, cm)
    xy = straight.as_array()[:, :2]
    assert curvature_sign_changes(smoothed) == 4
    assert curvature_sign_changes(xy) == 1
    assert path_length(xy) <= path_length(smoothed)

    def costs(p: np.ndarray) -> np.ndarray:
        mx, my, _ = cm.world_to_map_array(p)
        return cm.data[my, mx]

    near = np.hypot(xy[:, 0] - 12.6, xy[:, 1] - 7.9).min()
    assert near >= np.hypot(smoothed[:, 0] - 12.6, smoothed[:, 1] - 7.9).min() - 0.05
    assert costs(xy).max() <= costs(smoothed).max() * 1.15


def test_straightened_plan_out_of_a_door_past_a_person_turns_one_way() -> None:
    """The office, a person standing at room F's door mouth on the corridor side, a plan
    from inside the room (next to the jamb) to room A: NavFn's smoothed plan goes east,
    south through the door, swings 18 deg east of the person and turns west (3 curvature
    sign changes in 12.8 m, 2.3 per 10 m).  The chord past the swing crosses the door
    nearer its jamb than the plan does; straightened, the door's line is carried on past
    the person to where the plan turns west (one corner instead of the swing and the
    turn): 1 sign change, no costlier and no longer than the smoothed plan."""
    cm = _office_costmap_with_person(9.45, 8.0, 0.12)
    start, goal = Pose2D(9.6, 9.11, -1.07), Pose2D(2.5, 4.0, 0.0)
    smoothed = NavfnPlanner().plan(start, goal, cm).as_array()[:, :2]
    xy = NavfnPlanner(NavfnParams(straighten_deviation=0.15)).plan(start, goal, cm)
    xy = xy.as_array()[:, :2]
    assert curvature_sign_changes(smoothed) == 3
    assert curvature_sign_changes(xy) == 1
    assert path_length(xy) <= path_length(smoothed)

    def costs(p: np.ndarray) -> np.ndarray:
        mx, my, _ = cm.world_to_map_array(p)
        return cm.data[my, mx]

    assert costs(xy).max() <= costs(smoothed).max()
    near = np.hypot(xy[:, 0] - 9.45, xy[:, 1] - 8.0).min()
    assert near >= np.hypot(smoothed[:, 0] - 9.45, smoothed[:, 1] - 8.0).min() - 0.05
