"""Theta*: exact straight lines, near-optimal any-angle paths, free lines of sight, errors."""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np
import pytest

from navstack.core.errors import (
    ConfigError,
    GoalOccupied,
    GoalOutsideMap,
    NoValidPath,
    PlannerCancelled,
    StartOccupied,
    StartOutsideMap,
)
from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning.theta_star import (
    ThetaStarParams,
    ThetaStarPlanner,
    drop_collinear,
    interpolate_polyline,
    segment_cost,
    theta_star_weight_table,
)

RES = 0.05


def _empty(size: int = 200) -> Costmap2D:
    return Costmap2D(size, size, RES)


def _square_map() -> Costmap2D:
    """10 m x 10 m, a lethal 2 m x 2 m square over [4, 6] x [4, 6]."""
    cm = _empty()
    cm.data[80:120, 80:120] = 254
    return cm


def _crosses_interior(a: np.ndarray, b: np.ndarray, lo: float, hi: float) -> bool:
    """True if segment a-b passes through the open square (lo, hi)^2 (Liang-Barsky)."""
    t0, t1 = 0.0, 1.0
    d = b - a
    for k in range(2):
        if abs(d[k]) < 1e-15:
            if not lo < a[k] < hi:
                return False
            continue
        ta, tb = (lo - a[k]) / d[k], (hi - a[k]) / d[k]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    if t1 - t0 <= 1e-12:
        return False
    mid = a + 0.5 * (t0 + t1) * d
    return bool(np.all((mid > lo + 1e-12) & (mid < hi - 1e-12)))


def _visibility_optimum(start: np.ndarray, goal: np.ndarray, lo: float, hi: float) -> float:
    """Shortest any-angle path around the square: Dijkstra on the visibility graph."""
    nodes = [start, goal, np.array([lo, lo]), np.array([hi, lo]), np.array([hi, hi]),
             np.array([lo, hi])]
    dist = [math.inf] * len(nodes)
    dist[0] = 0.0
    heap = [(0.0, 0)]
    while heap:
        d, u = heapq.heappop(heap)
        if d > dist[u]:
            continue
        for v in range(len(nodes)):
            if v != u and not _crosses_interior(nodes[u], nodes[v], lo, hi):
                nd = d + float(np.hypot(*(nodes[v] - nodes[u])))
                if nd < dist[v]:
                    dist[v] = nd
                    heapq.heappush(heap, (nd, v))
    return dist[1]


def _assert_segments_free(xy: np.ndarray, cm: Costmap2D, limit: int = 253) -> None:
    """Every point sampled every res/50 along every segment lies in a cell of cost < limit."""
    for a, b in itertools.pairwise(xy):
        n = max(2, int(np.hypot(*(b - a)) / (RES / 50)) + 1)
        pts = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
        mx, my, inside = cm.world_to_map_array(pts)
        assert inside.all()
        assert int(cm.data[my, mx].max()) < limit, f"segment {a} -> {b} crosses an obstacle"


def test_empty_grid_is_one_exact_straight_segment() -> None:
    cm = _empty()
    start, goal = Pose2D(1.0, 1.3), Pose2D(8.7, 6.2, 0.4)
    planner = ThetaStarPlanner()
    path = planner.plan(start, goal, cm)
    np.testing.assert_array_equal(planner.last_waypoints, [[1.0, 1.3], [8.7, 6.2]])
    xyt = path.as_array()
    assert path.header.frame_id == "map"
    assert path.length() == pytest.approx(math.hypot(7.7, 4.9), rel=1e-12)
    d = xyt[:, :2] - xyt[0, :2]
    cross = d[:, 0] * 4.9 - d[:, 1] * 7.7
    assert np.abs(cross).max() < 1e-9  # every pose on the line
    assert np.all(np.diff(np.hypot(d[:, 0], d[:, 1])) > 0.0)  # monotone along it
    np.testing.assert_allclose(xyt[0], [1.0, 1.3, math.atan2(4.9, 7.7)], atol=1e-12)
    np.testing.assert_allclose(xyt[-1], [8.7, 6.2, 0.4], atol=1e-12)  # goal heading at the end
    spacing = np.hypot(*np.diff(xyt[:, :2], axis=0).T)
    assert spacing[:-1] == pytest.approx(RES, abs=1e-9)  # Nav2 interpolation step


@pytest.mark.parametrize("corners", [8, 4])
def test_square_obstacle_within_one_percent_of_any_angle_optimum(corners: int) -> None:
    cm = _square_map()
    start, goal = Pose2D(1.0, 4.6), Pose2D(9.0, 5.6)
    optimum = _visibility_optimum(np.array([1.0, 4.6]), np.array([9.0, 5.6]), 4.0, 6.0)
    assert optimum == pytest.approx(math.hypot(3.0, 1.4) + 2.0 + math.hypot(3.0, 0.4), abs=1e-12)
    planner = ThetaStarPlanner(ThetaStarParams(how_many_corners=corners))
    path = planner.plan(start, goal, cm)
    length = path.length()
    assert optimum <= length <= 1.01 * optimum
    _assert_segments_free(planner.last_waypoints, cm)
    assert len(planner.last_waypoints) <= 6  # any-angle: a handful of vertices, not a staircase


def test_every_line_of_sight_is_free_on_a_cluttered_map() -> None:
    rng = np.random.default_rng(7)
    cm = _empty()
    for _ in range(25):
        x, y = rng.integers(10, 180, size=2)
        w, h = rng.integers(3, 20, size=2)
        cm.data[y:y + h, x:x + w] = 254
    cm.data[:12, :12] = 0
    cm.data[-12:, -12:] = 0
    planner = ThetaStarPlanner(ThetaStarParams(w_traversal_cost=0.0))
    path = planner.plan(Pose2D(0.2, 0.2), Pose2D(9.8, 9.8), cm)
    _assert_segments_free(planner.last_waypoints, cm)
    _assert_segments_free(path.as_array()[:, :2], cm)
    assert path.length() >= math.hypot(9.6, 9.6)


def test_traversal_cost_steers_around_a_high_cost_band() -> None:
    cm = _empty()
    cm.data[40:160, 80:120] = 250  # passable but expensive band, x in [4, 6], y in [2, 8]
    start, goal = Pose2D(1.0, 5.0), Pose2D(9.0, 5.0)
    straight = ThetaStarPlanner(ThetaStarParams(w_traversal_cost=0.0))
    straight.plan(start, goal, cm)
    np.testing.assert_array_equal(straight.last_waypoints, [[1.0, 5.0], [9.0, 5.0]])
    aware = ThetaStarPlanner()  # w_traversal_cost 2: a cost-250 cell costs ~2.98 per cell
    path = aware.plan(start, goal, cm)
    _assert_segments_free(aware.last_waypoints, cm, limit=250)  # never enters the band
    assert path.length() > 8.0


def test_segment_cost_integrates_weights_exactly() -> None:
    w = np.ones(16)
    assert segment_cost(0.5, 0.5, 3.5, 0.5, w, 4, 4) == pytest.approx(3.0, abs=1e-12)
    w[2] = 2.0  # cell (2, 0)
    assert segment_cost(0.5, 0.5, 3.5, 0.5, w, 4, 4) == pytest.approx(4.0, abs=1e-12)
    w = np.ones(16)
    assert segment_cost(0.5, 0.5, 2.5, 2.5, w, 4, 4) == pytest.approx(2 * math.sqrt(2), abs=1e-12)
    w[1] = -1.0  # cell (1, 0) touches the diagonal only at the corner (1, 1): still blocked
    assert segment_cost(0.5, 0.5, 1.5, 1.5, w, 4, 4) == -1.0
    assert segment_cost(0.5, 0.5, 4.5, 0.5, np.ones(16), 4, 4) == -1.0  # leaves the grid


def test_weight_table_follows_nav2_cost_model() -> None:
    t = theta_star_weight_table(1.0, 2.0, allow_unknown=True)
    assert t[0] == pytest.approx(1.0 + 2.0 * 26.0 ** 2 / 252.0 ** 2, abs=1e-15)
    assert t[100] == pytest.approx(1.0 + 2.0 * 116.0 ** 2 / 252.0 ** 2, abs=1e-15)
    assert t[253] == t[254] == -1.0
    assert t[255] == pytest.approx(1.0 + 2.0 * 253.0 ** 2 / 252.0 ** 2, abs=1e-15)
    assert theta_star_weight_table(1.0, 2.0, allow_unknown=False)[255] == -1.0


def test_helpers_interpolate_and_drop_collinear() -> None:
    xy = np.array([[0.0, 0.0], [0.2, 0.0], [0.2, 0.1]])
    expected = np.array([[0, 0], [0.05, 0], [0.1, 0], [0.15, 0], [0.2, 0], [0.2, 0.05],
                         [0.2, 0.1]], dtype=float)
    np.testing.assert_allclose(interpolate_polyline(xy, 0.05), expected, atol=1e-12)
    np.testing.assert_array_equal(drop_collinear(np.array([[0.0, 0], [1, 1], [2, 2], [3, 2]])),
                                  [[0, 0], [2, 2], [3, 2]])


def test_same_cell_gives_one_pose() -> None:
    path = ThetaStarPlanner().plan(Pose2D(1.01, 1.01, 0.1), Pose2D(1.02, 1.03, 0.7), _empty())
    np.testing.assert_allclose(path.as_array(), [[1.01, 1.01, 0.7]])


def test_start_in_inscribed_band_is_cleared_as_nav2() -> None:
    cm = _empty()
    cm.data[20, 20] = 253  # start cell (1.0..1.05, 1.0..1.05)
    path = ThetaStarPlanner().plan(Pose2D(1.02, 1.02), Pose2D(3.0, 1.02), cm)
    assert path.length() == pytest.approx(1.98, abs=1e-12)


def test_typed_errors_name_the_cause() -> None:
    cm = _empty(100)
    cm.data[50, 50] = 254
    cm.data[10, 10] = 253
    cm.data[30, 30] = 255
    planner = ThetaStarPlanner()
    with pytest.raises(StartOutsideMap) as e1:
        planner.plan(Pose2D(-1.0, 1.0), Pose2D(1.0, 1.0), cm)
    assert str(e1.value) == ("start (-1.00, 1.00) is outside the costmap, which spans x "
                             "[0.00, 5.00] y [0.00, 5.00] in frame 'map'; give a start inside "
                             "the map")
    with pytest.raises(GoalOutsideMap):
        planner.plan(Pose2D(1.0, 1.0), Pose2D(1.0, 7.0), cm)
    with pytest.raises(StartOccupied) as e2:
        planner.plan(Pose2D(2.52, 2.52), Pose2D(1.0, 1.0), cm)
    assert str(e2.value) == ("start (2.52, 2.52) is in an obstacle (cost 254); clear the "
                             "costmap or move the robot into free space")
    with pytest.raises(GoalOccupied) as e3:
        planner.plan(Pose2D(1.0, 1.0), Pose2D(0.52, 0.52), cm)
    assert str(e3.value) == ("goal (0.52, 0.52) is in an obstacle (cost 253); choose a goal "
                             "in free space")
    strict = ThetaStarPlanner({"allow_unknown": False})
    with pytest.raises(GoalOccupied) as e4:
        strict.plan(Pose2D(1.0, 1.0), Pose2D(1.52, 1.52), cm)
    assert str(e4.value) == ("goal (1.52, 1.52) is in unknown space (cost 255) and "
                             "allow_unknown is false; choose a goal in free space")


def test_unreachable_goal_and_cancel() -> None:
    cm = _empty(100)
    cm.data[40:61, 40] = cm.data[40:61, 60] = 254
    cm.data[40, 40:61] = cm.data[60, 40:61] = 254  # closed box around (2.5, 2.5)
    planner = ThetaStarPlanner()
    with pytest.raises(NoValidPath, match="no valid path from start"):
        planner.plan(Pose2D(0.5, 0.5), Pose2D(2.5, 2.5), cm)
    assert planner.last_expansions == 100 * 100 - 21 * 21  # every outside cell searched
    with pytest.raises(PlannerCancelled, match="was cancelled after 0 expansions"):
        planner.plan(Pose2D(0.5, 0.5), Pose2D(4.5, 4.5), _empty(100), cancel=lambda: True)


def test_params_validation() -> None:
    with pytest.raises(ConfigError) as err:
        ThetaStarPlanner({"how_many_corners": 6})
    assert "how_many_corners must be 4 or 8, got 6" in str(err.value)
    with pytest.raises(ConfigError, match="unknown key"):
        ThetaStarPlanner({"w_euc": 1.0})
