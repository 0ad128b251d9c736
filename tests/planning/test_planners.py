"""NavfnPlanner and CostAwareAStar on Costmap2D: geometry, cost model, errors."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navstack.core.errors import (
    ConfigError,
    GoalOccupied,
    NoValidPath,
    PlannerCancelled,
    PlannerTimeout,
    StartOccupied,
    StartOutsideMap,
)
from navstack.core.msgs import Path, Pose2D
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning import AStarParams, CostAwareAStar, NavfnParams, NavfnPlanner
from navstack.planning.grid_planner import GridPlannerBase
from navstack.planning.navfn import navfn_cost_table

RES = 0.1


def _costmap(data: np.ndarray) -> Costmap2D:
    return Costmap2D.from_array(data.astype(np.uint8), RES, origin_x=-1.0, origin_y=2.0)


def _cells(path: Path, cm: Costmap2D) -> np.ndarray:
    """The cells the path's points lie in, consecutive repeats dropped (NavFn's descent
    puts points every half cell)."""
    mx, my, inside = cm.world_to_map_array(path.as_array()[:, :2])
    assert inside.all()
    cells = np.column_stack((mx, my))
    keep = np.ones(len(cells), dtype=bool)
    keep[1:] = np.any(np.diff(cells, axis=0) != 0, axis=1)
    return cells[keep]


def _samples_cost(xy: np.ndarray, cm: Costmap2D) -> np.ndarray:
    """Costs of points every 1 cm along the polyline."""
    pts = [xy[:1]]
    for a, b in itertools.pairwise(xy):
        n = max(1, math.ceil(np.hypot(*(b - a)) / 0.01))
        pts.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    mx, my, inside = cm.world_to_map_array(np.vstack(pts))
    assert inside.all()
    return cm.data[my, mx]


def _cost(cells: np.ndarray, table: np.ndarray, data: np.ndarray) -> float:
    """Step-length x weight cost of a cell path (the planners' objective)."""
    steps = np.abs(np.diff(cells, axis=0)).sum(axis=1)
    w = table[data[cells[1:, 1], cells[1:, 0]]]
    return float(np.sum(np.where(steps == 2, math.sqrt(2), 1.0) * w))


def _wall_map() -> np.ndarray:
    """60 x 40 free map with a lethal wall (x = 30) and inflation (253) around it."""
    d = np.zeros((40, 60), dtype=np.uint8)
    d[:30, 30] = 254
    d[:31, 29] = d[:31, 31] = 253
    d[30, 29:32] = 253
    return d


PLANNERS = [NavfnPlanner(), NavfnPlanner(NavfnParams(use_astar=True)), CostAwareAStar()]


@pytest.mark.parametrize("planner", PLANNERS, ids=["navfn-dijkstra", "navfn-astar", "astar"])
def test_path_avoids_obstacles_and_joins_start_to_goal(planner: GridPlannerBase) -> None:
    cm = _costmap(_wall_map())
    start, goal = Pose2D(-0.47, 2.53, 0.3), Pose2D(4.55, 2.51, -1.2)
    path = planner.plan(start, goal, cm)
    xyt = path.as_array()
    assert path.header.frame_id == "map"
    np.testing.assert_allclose(xyt[0, :2], [start.x, start.y], atol=1e-12)
    np.testing.assert_allclose(xyt[-1], [goal.x, goal.y, goal.theta], atol=1e-12)
    cells = _cells(path, cm)
    assert (_samples_cost(xyt[:, :2], cm) < 253).all()  # every cm of every segment
    if isinstance(planner, CostAwareAStar):
        assert np.abs(np.diff(cells, axis=0)).max() == 1  # 8-connected cell steps
    d = np.diff(xyt[:, :2], axis=0)
    np.testing.assert_allclose(xyt[:-1, 2], np.arctan2(d[:, 1], d[:, 0]), atol=1e-12)
    assert cells[:, 1].max() >= 31  # it went around the top of the wall


def test_navfn_dijkstra_and_astar_give_the_same_cost() -> None:
    rng = np.random.default_rng(11)
    data = rng.integers(0, 200, size=(50, 50)).astype(np.uint8)
    data[rng.random((50, 50)) < 0.15] = 254
    data[5, 5] = data[44, 40] = 0
    cm = _costmap(data)
    start = Pose2D(*cm.map_to_world(5, 5))
    goal = Pose2D(*cm.map_to_world(40, 44))
    table = navfn_cost_table(True)
    dij = _cells(NavfnPlanner().plan(start, goal, cm), cm)
    ast = _cells(NavfnPlanner(NavfnParams(use_astar=True)).plan(start, goal, cm), cm)
    assert _cost(dij, table, data) == pytest.approx(_cost(ast, table, data), abs=1e-6)
    assert table[0] == 50 and table[100] == 130 and table[252] == 251 and table[253] == -1


def test_cost_aware_search_takes_the_cheap_detour() -> None:
    # a band of cost 200 between start and goal, free space above it (y >= 18)
    data = np.zeros((21, 31), dtype=np.uint8)
    data[:18, 10:21] = 200
    cm = _costmap(data)
    start, goal = Pose2D(*cm.map_to_world(2, 10)), Pose2D(*cm.map_to_world(28, 10))
    for planner in (NavfnPlanner(), CostAwareAStar(AStarParams(cost_travel_multiplier=5.0))):
        cells = _cells(planner.plan(start, goal, cm), cm)
        assert (data[cells[:, 1], cells[:, 0]] == 0).all()  # never enters the band
        assert cells[:, 1].max() >= 18
    # with cost ignored, the straight line through the band is shortest
    blind = CostAwareAStar(AStarParams(cost_travel_multiplier=0.0))
    cells = _cells(blind.plan(start, goal, cm), cm)
    assert (cells[:, 1] == 10).all() and len(cells) == 27


def test_allow_unknown_true_plans_through_unknown_false_does_not() -> None:
    data = np.zeros((20, 30), dtype=np.uint8)
    data[:, 15] = 255  # an unknown column splits the map
    cm = _costmap(data)
    start, goal = Pose2D(*cm.map_to_world(2, 10)), Pose2D(*cm.map_to_world(27, 10))
    for planner in (NavfnPlanner(NavfnParams(tolerance=0.0)), CostAwareAStar()):
        cells = _cells(planner.plan(start, goal, cm), cm)
        assert (data[cells[:, 1], cells[:, 0]] == 255).sum() == 1
    strict = NavfnPlanner(NavfnParams(allow_unknown=False, tolerance=0.0))
    with pytest.raises(NoValidPath, match=r"^no valid path from start \(-0\.75, 3\.05\)"):
        strict.plan(start, goal, cm)
    with pytest.raises(StartOccupied) as exc:
        strict.plan(Pose2D(*cm.map_to_world(15, 3)), goal, cm)
    assert str(exc.value) == ("start (0.55, 2.35) is in unknown space (cost 255) and "
                              "allow_unknown is false; clear the costmap or move the robot "
                              "into free space")


def test_tolerance_ends_near_a_blocked_goal() -> None:
    data = np.zeros((30, 30), dtype=np.uint8)
    data[12:19, 12:19] = 254  # 0.7 m lethal block
    cm = _costmap(data)
    start = Pose2D(*cm.map_to_world(2, 2))
    goal = Pose2D(*cm.map_to_world(15, 15), 0.7)  # centre of the block
    path = NavfnPlanner(NavfnParams(tolerance=0.5)).plan(start, goal, cm)
    end = path.as_array()[-1]
    cell = cm.world_to_map(end[0], end[1])
    assert cell is not None and data[cell[1], cell[0]] == 0
    assert math.hypot(end[0] - goal.x, end[1] - goal.y) == pytest.approx(0.4, abs=1e-9)
    assert end[2] == pytest.approx(0.7)
    with pytest.raises(GoalOccupied) as exc:
        NavfnPlanner(NavfnParams(tolerance=0.0)).plan(start, goal, cm)
    assert str(exc.value) == ("goal (0.55, 3.55) is in an obstacle (cost 254) and no free "
                              "cell lies within tolerance 0.00 m; choose a goal in free space "
                              "or raise tolerance")


def test_error_messages() -> None:
    cm = _costmap(_wall_map())
    planner = CostAwareAStar()
    free = Pose2D(0.0, 3.0)
    with pytest.raises(StartOutsideMap) as exc:
        planner.plan(Pose2D(-2.0, 3.0), free, cm)
    assert str(exc.value) == ("start (-2.00, 3.00) is outside the costmap, which spans x "
                              "[-1.00, 5.00] y [2.00, 6.00] in frame 'map'; give a start "
                              "inside the map")
    with pytest.raises(StartOccupied) as exc:
        planner.plan(Pose2D(2.05, 2.25), free, cm)
    assert str(exc.value) == ("start (2.05, 2.25) is in an obstacle (cost 254); clear the "
                              "costmap or move the robot into free space")
    with pytest.raises(GoalOccupied) as exc:
        CostAwareAStar(AStarParams(tolerance=0.0)).plan(free, Pose2D(1.95, 2.25), cm)
    assert str(exc.value).startswith("goal (1.95, 2.25) is in an obstacle (cost 253)")


def test_walled_off_goal_raises_no_valid_path() -> None:
    data = np.zeros((30, 30), dtype=np.uint8)
    data[18:25, 18] = data[18:25, 24] = data[18, 18:25] = data[24, 18:25] = 254
    cm = _costmap(data)
    start, goal = Pose2D(*cm.map_to_world(2, 2)), Pose2D(*cm.map_to_world(21, 21))
    with pytest.raises(NoValidPath) as exc:
        CostAwareAStar().plan(start, goal, cm)
    reachable = 30 * 30 - 7 * 7
    assert str(exc.value) == (f"no valid path from start (-0.75, 2.25) to goal (1.15, 4.15): "
                              f"the goal is not reachable through free space ({reachable} "
                              f"cells searched); check the costmap for a blocked passage or "
                              f"raise tolerance (0.12 m)")


def test_cancel_and_iteration_budget() -> None:
    cm = _costmap(np.zeros((100, 100), dtype=np.uint8))
    start, goal = Pose2D(*cm.map_to_world(0, 0)), Pose2D(*cm.map_to_world(99, 50))
    with pytest.raises(PlannerCancelled) as exc:
        NavfnPlanner().plan(start, goal, cm, cancel=lambda: True)
    assert str(exc.value) == ("planning from start (-0.95, 2.05) to goal (8.95, 7.05) was "
                              "cancelled after 0 expansions")
    calls: list[int] = []

    def cancel_later() -> bool:
        calls.append(1)
        return len(calls) > 2

    big = _costmap(np.zeros((200, 200), dtype=np.uint8))
    with pytest.raises(PlannerCancelled, match="cancelled after 10000 expansions"):
        NavfnPlanner().plan(start, Pose2D(*big.map_to_world(199, 199)), big,
                            cancel=cancel_later)
    with pytest.raises(PlannerTimeout) as texc:
        CostAwareAStar(AStarParams(max_iterations=50)).plan(
            start, Pose2D(*cm.map_to_world(99, 99)), _costmap(_maze_like()))
    assert str(texc.value) == ("planning from start (-0.95, 2.05) to goal (8.95, 11.95) "
                               "exceeded max_iterations 50 (50 cells expanded without reaching "
                               "the goal); raise max_iterations or set it to -1")
    slow = CostAwareAStar(AStarParams(max_planning_time=1e-9, terminal_checking_interval=1))
    with pytest.raises(PlannerTimeout, match=r"exceeded max_planning_time 0\.000 s"):
        slow.plan(start, goal, cm)


def _maze_like() -> np.ndarray:
    d = np.zeros((100, 100), dtype=np.uint8)
    d[10::20, :90] = 254
    d[20::20, 10:] = 254
    return d


def test_final_approach_orientation_and_params_validation() -> None:
    cm = _costmap(np.zeros((20, 20), dtype=np.uint8))
    start, goal = Pose2D(*cm.map_to_world(2, 2)), Pose2D(*cm.map_to_world(12, 2), 2.0)
    path = NavfnPlanner(NavfnParams(use_final_approach_orientation=True)).plan(start, goal, cm)
    assert path.as_array()[-1, 2] == pytest.approx(0.0)  # heading of the last (+x) segment
    same = NavfnPlanner().plan(start, start, cm)
    assert len(same.poses) == 1
    with pytest.raises(ConfigError, match=r"use_astr: unknown key \(did you mean 'use_astar'"):
        NavfnParams.from_mapping({"use_astr": True})
    with pytest.raises(ConfigError, match="max_iterations: Value error, must be positive, or -1"):
        AStarParams.from_mapping({"max_iterations": 0})
    assert AStarParams.from_mapping({"max_iterations": -1}).max_iterations == -1


def test_navfn_plans_out_of_an_inscribed_start_cell_as_nav2_clears_the_robot_cell() -> None:
    """Nav2 NavFn's clearRobotCell: a robot whose cell is inscribed (a wall inflated
    into it) is planned from; a lethal start is still StartOccupied, and the A* planner
    (no such rule) refuses the inscribed start."""
    data = np.zeros((20, 30), dtype=np.uint8)
    data[10, 5] = 253  # the robot's cell, inscribed
    data[3, 5] = 254
    cm = _costmap(data)
    start, goal = Pose2D(*cm.map_to_world(5, 10)), Pose2D(*cm.map_to_world(25, 10))
    path = NavfnPlanner(NavfnParams(tolerance=0.0)).plan(start, goal, cm)
    ends = path.as_array()[[0, -1], :2]
    assert np.allclose(ends, [[start.x, start.y], [goal.x, goal.y]])
    with pytest.raises(StartOccupied, match=r"is in an obstacle \(cost 254\)"):
        NavfnPlanner(NavfnParams(tolerance=0.0)).plan(Pose2D(*cm.map_to_world(5, 3)), goal, cm)
    with pytest.raises(StartOccupied, match=r"is in an obstacle \(cost 253\)"):
        CostAwareAStar().plan(start, goal, cm)
