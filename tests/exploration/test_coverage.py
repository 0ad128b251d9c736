"""Coverage search: the 0.8 m cell split with the +-3-cell free box, and the visit order."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navstack.exploration.coverage import (
    coverage_cells,
    order_visits,
    path_distances,
    tour_length,
)


def test_cell_filter_on_a_map_with_a_known_answer() -> None:
    """A 4 x 2.4 m map at 0.05 m: 5 x 3 cells of 0.8 m.  Obstacles are placed so the
    free-box test (+-3 cells = +-0.15 m around the centre) keeps exactly the cells listed."""
    res = 0.05
    free = np.ones((48, 80), dtype=bool)             # 2.4 m x 4.0 m
    # cell (col 0, row 0), centre (0.4, 0.4): an obstacle 0.10 m from the centre -> dropped
    free[8, 10] = False                               # cell centre (0.525, 0.425)
    # cell (col 1, row 0), centre (1.2, 0.4): obstacle 0.20 m away -> kept
    free[8, 28] = False                               # (1.425, 0.425)
    # cell (col 2, row 1), centre (2.0, 1.2): unknown/occupied block on the centre
    free[22:26, 38:42] = False
    # cell (col 4, row 2), centre (3.6, 2.0): obstacle exactly on the box edge (3 cells)
    r, c = int(2.0 / res), int(3.6 / res)
    free[r + 3, c] = False
    # cell (col 3, row 2), centre (2.8, 2.0): obstacle one cell outside the box
    r, c = int(2.0 / res), int(2.8 / res)
    free[r + 4, c] = False
    got = coverage_cells(free, res, 10.0, -5.0, cell_size=0.8, box_cells=3)
    expected = [(x + 10.0, y - 5.0) for y in (0.4, 1.2, 2.0) for x in (0.4, 1.2, 2.0, 2.8, 3.6)
                if (x, y) not in {(0.4, 0.4), (2.0, 1.2), (3.6, 2.0)}]
    np.testing.assert_allclose(got, expected, atol=1e-9)
    # a map smaller than one cell has none
    assert coverage_cells(np.ones((10, 10), bool), res).shape == (0, 2)


def test_order_is_nearest_neighbour_improved_by_two_opt() -> None:
    # points on a 3 x 3 lattice, start in a corner: the optimal closed tour is 8 unit steps
    # + the way back; check against brute force over all orders
    pts = np.array([(x, y) for y in range(3) for x in range(3)], dtype=float)
    d = np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
    order = order_visits(d, start=0)
    assert sorted(order) == list(range(1, 9))
    best = min(tour_length(d, [0, *p]) for p in itertools.permutations(range(1, 9)))
    assert tour_length(d, [0, *order]) == pytest.approx(best)


def test_two_opt_removes_a_crossing_left_by_nearest_neighbour() -> None:
    # nearest neighbour from 0 goes 0-1-2-3 then crosses back; 2-opt finds the square
    pts = np.array([[0, 0], [1, 0.1], [1, 1], [0, 1.2], [2, 0.5]], dtype=float)
    d = np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
    order = order_visits(d, 0)
    best = min(tour_length(d, [0, *p]) for p in itertools.permutations(range(1, 5)))
    assert tour_length(d, [0, *order]) == pytest.approx(best)


def test_path_distances_go_round_walls_and_mark_unreachable() -> None:
    res = 0.1
    trav = np.ones((30, 30), dtype=bool)
    trav[0:25, 15] = False            # a wall from the bottom, open at the top
    trav[:, 25] = False               # a full wall: x > 2.5 is cut off
    pts = np.array([[0.55, 0.55], [2.05, 0.55], [2.85, 0.55]])
    d = path_distances(trav, res, 0.0, 0.0, pts)
    straight = 1.5
    assert d[0, 1] > straight + 3.0   # up to the gap at y 2.5 and down again
    assert d[0, 1] == pytest.approx(d[1, 0])
    assert math.isinf(d[0, 2]) and math.isinf(d[2, 1])
    assert order_visits(d, 0) == [1]  # the unreachable cell is not in the tour
