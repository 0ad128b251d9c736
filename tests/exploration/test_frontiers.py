"""Frontier search: explore_lite's definitions, path distances, reachability, blacklist."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose
from navstack.exploration.blacklist import Blacklist
from navstack.exploration.frontiers import find_frontiers, frontier_cells
from navstack.exploration.grid_view import ExplorationError, GridView
from navstack.exploration.wavefront import Wavefront, dilate

RES = 0.1


def view_from(rows: list[str], res: float = RES) -> GridView:
    """'.' free, '#' obstacle, '?' unknown; row 0 is the top line (largest y)."""
    chars = np.array([list(r) for r in rows[::-1]])
    unknown = chars == "?"
    free = chars == "."
    return GridView(unknown, free, free.copy(), res)


def test_frontier_cells_are_unknown_with_a_free_4_neighbour() -> None:
    v = view_from(["??????",
                   "?....?",
                   "?.##.?",
                   "??????"])
    got = frontier_cells(v)
    expected = np.zeros_like(got)
    # row indices count from the bottom: bottom line is row 0
    expected[0, 1:5] = [True, False, False, True]   # below '.', '#', '#', '.'
    expected[1, 0] = expected[1, 5] = True
    expected[2, 0] = expected[2, 5] = True
    expected[3, 1:5] = True
    np.testing.assert_array_equal(got, expected)


def test_distance_is_the_path_round_a_wall_not_the_straight_line() -> None:
    # robot left of a wall; the frontier is just right of the wall, reached round its top
    v = view_from(["...........",
                   ".....#.....",
                   ".....#.....",
                   ".....#.....",
                   ".....#....?",
                   ".....#....?",
                   ".....#....?",
                   "######....?"])
    fs = find_frontiers(v, (0.25, 0.25), min_frontier_size=0.3, frontier_reach=0.1)
    assert len(fs.reachable) == 1
    f = fs.reachable[0]
    assert f.size == 4 and f.size_m == pytest.approx(0.4)
    # straight line from (0.25, 0.25) to the approach column x = 0.95 is ~0.7 m; the
    # way round the wall top (row 7) is much longer
    assert f.distance > 1.3
    ideal = fs.distances[3, 9]  # the approach cell nearest the wall top
    assert f.distance == pytest.approx(ideal)
    assert f.goal is not None and f.goal[0] == pytest.approx(0.95)


def test_min_frontier_size_drops_short_frontiers() -> None:
    v = view_from(["?...", "....", "....", "...."])
    fs = find_frontiers(v, (0.25, 0.15), min_frontier_size=0.15)
    assert fs.reachable == [] and fs.too_small == 1
    fs = find_frontiers(v, (0.25, 0.15), min_frontier_size=0.1)
    assert len(fs.reachable) == 1


def test_frontier_behind_a_gap_narrower_than_the_robot_is_unreachable() -> None:
    rows = ["??????????",
            "..........",
            "####.#####",   # a one-cell gap: free but not traversable
            "..........",
            ".........."]
    v0 = view_from(rows)
    trav = v0.traversable.copy()
    trav[2, 4] = False  # the gap cell is inside the inscribed band
    v = GridView(v0.unknown, v0.free, trav, RES)
    fs = find_frontiers(v, (0.05, 0.05), min_frontier_size=0.3, frontier_reach=0.1)
    assert fs.reachable == []
    assert len(fs.unreachable) == 1 and fs.unreachable[0].size == 10
    assert not fs.unreachable[0].reachable and fs.unreachable[0].goal is None


def test_robot_touching_a_wall_starts_from_the_nearest_traversable_cell() -> None:
    v0 = view_from(["?????", ".....", ".....", "....."])
    trav = v0.traversable.copy()
    trav[0, 0] = False  # the robot's cell
    v = GridView(v0.unknown, v0.free, trav, RES)
    fs = find_frontiers(v, (0.05, 0.05), min_frontier_size=0.3, frontier_reach=0.1)
    assert fs.start == (0, 1)  # the first of the two nearest, in row-major order
    assert len(fs.reachable) == 1
    # 0.1 m to the start cell, then two rows up to the approach cells under the frontier
    assert fs.reachable[0].distance == pytest.approx(0.3, abs=1e-9)


def test_blacklisted_cells_are_not_frontier() -> None:
    v = view_from(["??????????", "..........", ".........."])
    bl = Blacklist(tolerance=0.0)
    bl.add(v.centres(np.full(5, 2), np.arange(5)), "aborted", 0.0)
    fs = find_frontiers(v, (0.05, 0.05), min_frontier_size=0.3, blacklist=bl.mask(v))
    assert len(fs.reachable) == 1 and fs.reachable[0].size == 5
    assert set(fs.reachable[0].cols.tolist()) == {5, 6, 7, 8, 9}
    # blacklisting overlapping cells again counts a second attempt
    e = bl.add(v.centres(np.full(2, 2), np.arange(2)), "no progress", 1.0)
    assert e.attempts == 2
    assert [x.attempts for x in bl.release_retryable()] == [1]


def test_wavefront_is_the_octile_distance_on_an_open_grid() -> None:
    trav = np.ones((20, 30), dtype=bool)
    d = Wavefront().distances(trav, (0, 0), 0.05)
    r, c = np.mgrid[0:20, 0:30]
    octile = (np.maximum(r, c) + (math.sqrt(2) - 1) * np.minimum(r, c)) * 0.05
    np.testing.assert_allclose(d, octile, atol=1e-9)
    cells = Wavefront()
    cells.distances(trav, (0, 0), 0.05)
    path = cells.path_to((19, 29))
    assert tuple(path[0]) == (0, 0) and tuple(path[-1]) == (19, 29) and len(path) == 30


def test_grid_view_from_costmap_topic_and_errors() -> None:
    data = np.array([[-1, 0, 50], [99, 100, 10]], dtype=np.int8)
    grid = OccupancyGrid(Header(3.0, "map"), MapMetaData(0.0, 0.05, 3, 2, Pose(Point(1.0, 2.0))),
                         data.ravel())
    v = GridView.from_occupancy(grid, occupied_threshold=100, lethal_threshold=99)
    np.testing.assert_array_equal(v.unknown, data == -1)
    np.testing.assert_array_equal(v.free, (data >= 0) & (data < 100))
    np.testing.assert_array_equal(v.traversable, (data >= 0) & (data < 99))
    assert (v.origin_x, v.origin_y, v.stamp) == (1.0, 2.0, 3.0)
    assert v.cell_of(1.07, 2.01) == (0, 1)
    with pytest.raises(ExplorationError, match="must have one shape"):
        GridView(np.zeros((2, 2), bool), np.zeros((2, 3), bool), np.zeros((2, 2), bool), 0.1)


def test_dilate_is_the_iterated_3x3_dilation_sparse_or_dense() -> None:
    """Boxes painted around sparse cells equal scipy's iterated 3 x 3 dilation, at the
    grid's borders too; a dense mask takes scipy's path and gives the same."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        h, w = (int(v) for v in rng.integers(1, 50, 2))
        mask = rng.random((h, w)) < rng.random() * (0.6 if rng.random() < 0.2 else 0.05)
        k = int(rng.integers(1, 7))
        expected = ndimage.binary_dilation(mask, np.ones((3, 3), bool), iterations=k)
        assert np.array_equal(dilate(mask, k), expected)
    corner = np.zeros((6, 6), bool)
    corner[0, 5] = True
    assert dilate(corner, 2).sum() == 9 and dilate(corner, 0).sum() == 1


def _pocket_world() -> GridView:
    """A frontier at the end of a 0.2 m pocket above a room; a second room left of the
    pocket's wall is nearer the frontier but cannot see it."""
    occ = np.ones((14, 16), dtype=bool)
    unknown = np.zeros_like(occ)
    occ[1:7, 1:15] = False        # bottom room
    occ[7:11, 9:11] = False       # the pocket
    occ[11, 9:11] = False
    unknown[11, 9:11] = True      # its unknown end: the frontier
    occ[8:13, 1:8] = False        # left room, behind the pocket's wall (column 8)
    occ[7, 2:5] = False           # its door to the bottom room
    free = ~occ & ~unknown
    return GridView(unknown, free, free.copy(), RES)


def test_goals_go_where_the_robot_can_turn_and_see_the_frontier() -> None:
    v = _pocket_world()
    tight = find_frontiers(v, (0.55, 0.35), min_frontier_size=0.2)
    (f,) = tight.reachable
    assert f.goal is not None and f.goal[1] >= 0.8 and 0.9 <= f.goal[0] <= 1.1  # in the pocket
    roomy = find_frontiers(v, (0.55, 0.35), min_frontier_size=0.2, goal_clearance=0.25,
                           goal_reach=1.0)
    (g,) = roomy.reachable
    assert g.goal is not None
    rows, cols = g.approach_rows, g.approach_cols
    occupied = ~v.unknown & ~v.free
    clearance = ndimage.distance_transform_edt(~occupied, sampling=RES)
    assert (clearance[rows, cols] >= 0.3 - 1e-9).all()
    # every approach cell is in the bottom room (the left room is nearer but walled off)
    assert (rows <= 6).all() and rows.size > 0
    assert math.hypot(g.goal[0] - 1.0, g.goal[1] - 1.15) <= 1.0 + 1e-9


def test_a_frontier_only_tight_spots_reach_keeps_its_near_cells() -> None:
    v = _pocket_world()
    fs = find_frontiers(v, (0.55, 0.35), min_frontier_size=0.2, goal_clearance=0.25,
                        goal_reach=0.3)
    (f,) = fs.reachable
    assert f.goal is not None and f.goal[1] >= 0.8  # no roomy cell within 0.3 m: the pocket


def test_line_of_sight_stops_at_the_first_obstacle_sample() -> None:
    from navstack.exploration.frontiers import _sees

    rng = np.random.default_rng(3)
    occupied = rng.random((40, 50)) < 0.05
    v = GridView(np.zeros_like(occupied), ~occupied, ~occupied, RES)
    rows, cols = rng.integers(0, 40, 300), rng.integers(0, 50, 300)
    trows = np.clip(rows + rng.integers(-12, 13, 300), 0, 39)
    tcols = np.clip(cols + rng.integers(-12, 13, 300), 0, 49)
    steps = int(max(np.abs(trows - rows).max(), np.abs(tcols - cols).max())) * 4 + 1
    expected = []
    for r, c, tr, tc in zip(rows, cols, trows, tcols, strict=True):
        samples = [(math.floor(r + 0.5 + t * (tr - r)), math.floor(c + 0.5 + t * (tc - c)))
                   for t in np.linspace(0.0, 1.0, steps + 1)]
        expected.append(not any(occupied[a, b] for a, b in samples))
    seen = _sees(v, rows, cols, trows, tcols)
    assert seen.tolist() == expected and 0 < seen.sum() < seen.size


# 0.46097722286464443 is where the distances of 85 squared cells -- (9, 2) and (7, 6) --
# round to two floats: the transform's answer there depends on the cell it picks
_AMBIGUOUS = 0.46097722286464443 - 0.025


@pytest.mark.parametrize("clearance", [0.1, 0.2, 0.2978, 0.35, _AMBIGUOUS])
def test_roomy_cells_looked_up_locally_match_the_distance_transform(clearance: float) -> None:
    from navstack.exploration.frontiers import _clearance_offsets, _roomy, _roomy_at

    rng = np.random.default_rng(5)
    shape = (70, 90)
    unknown = rng.random(shape) < 0.3
    occupied = ~unknown & (rng.random(shape) < 0.03)
    v = GridView(unknown, ~unknown & ~occupied, ~unknown & ~occupied, 0.05)
    rows, cols = rng.integers(0, 70, 3000), rng.integers(0, 90, 3000)
    expected = _roomy(v, (0, 70, 0, 90), clearance)[rows, cols]
    assert 0 < expected.sum() < expected.size
    np.testing.assert_array_equal(_roomy_at(v, rows, cols, clearance), expected)
    # that clearance is left to the transform
    assert (_clearance_offsets(0.05, clearance + 0.025) is None) == (clearance == _AMBIGUOUS)


@pytest.mark.parametrize("res", [0.05, 0.025, 0.1, 0.07])
def test_clearance_offsets_are_one_symmetric_run_of_columns_per_row(res: float) -> None:
    """What the roomy lookup's running-count form relies on."""
    from navstack.exploration.frontiers import _clearance_offsets

    for clearance in np.linspace(0.03, 0.6, 40):
        offsets = _clearance_offsets(res, float(clearance) + res / 2)
        if offsets is None:
            continue
        for d in np.unique(offsets[:, 0]):
            dc = np.sort(offsets[offsets[:, 0] == d, 1])
            np.testing.assert_array_equal(dc, np.arange(-dc.max(), dc.max() + 1))


@pytest.mark.parametrize(("density", "radius"), [(0.005, 6), (0.03, 3), (0.2, 1)])
def test_nearest_within_picks_the_cell_the_distance_transform_picks(density: float,
                                                                    radius: int) -> None:
    from navstack.exploration.frontiers import nearest_within

    rng = np.random.default_rng(int(density * 1000))
    cells = rng.random((45, 60)) < density
    dist, (ir, ic) = ndimage.distance_transform_edt(~cells, return_indices=True)
    rows, cols = np.nonzero(cells)
    sq, jr, jc = nearest_within(rows, cols, cells.shape, radius)
    within = dist <= radius
    assert within.any() and (~within).any()
    np.testing.assert_array_equal(sq <= radius * radius, within)
    np.testing.assert_array_equal(np.sqrt(sq[within]), dist[within])
    np.testing.assert_array_equal(jr[within], ir[within])  # same cell on every tie
    np.testing.assert_array_equal(jc[within], ic[within])
