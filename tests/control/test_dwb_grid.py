"""Grid kernels behind the DWB critics: wavefront, plan densification, footprint raster."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.control.dwb.grid import (
    FOOTPRINT_CENTER_OFF_GRID,
    FOOTPRINT_LETHAL,
    FOOTPRINT_OFF_GRID,
    FOOTPRINT_OK,
    FOOTPRINT_UNKNOWN,
    Wavefront,
    adjust_plan_resolution,
    footprint_costs,
    wavefront,
)
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION


def test_single_seed_gives_exact_manhattan_distance() -> None:
    cost = np.zeros((30, 40), np.uint8)
    v = wavefront(cost, np.array([7]), np.array([11]))
    yy, xx = np.mgrid[0:30, 0:40]
    np.testing.assert_array_equal(v, np.abs(xx - 7) + np.abs(yy - 11))


def test_line_of_seeds_gives_perpendicular_distance() -> None:
    cost = np.zeros((20, 20), np.uint8)
    v = wavefront(cost, np.arange(20), np.full(20, 5))
    np.testing.assert_array_equal(v, np.abs(np.arange(20) - 5)[:, None] * np.ones((1, 20)))


def test_walls_block_the_wave() -> None:
    cost = np.zeros((10, 10), np.uint8)
    cost[:, 4:6] = LETHAL_OBSTACLE  # two-cell thick wall splits the map
    v = wavefront(cost, np.array([1]), np.array([1]))
    n = cost.size
    assert np.all(v[:, 4] == n)          # wall face touched by the wave: obstacle
    assert np.all(v[:, 5] == n + 1)      # far side of the wall never touched: unreachable
    assert np.all(v[:, 6:] == n + 1)
    assert v[9, 0] == 1 + 8               # reachable side keeps Manhattan values
    cost[3, 4:6] = 0                      # open a gap at row 3
    v = wavefront(cost, np.array([1]), np.array([1]))
    assert v[3, 9] == 8 + 2               # still Manhattan to the seed (not a path length)
    assert v[9, 9] == 8 + 8


def test_need_limited_wave_matches_full_wave_on_needed_cells() -> None:
    rng = np.random.default_rng(3)
    cost = np.where(rng.random((60, 80)) < 0.15, LETHAL_OBSTACLE, 0).astype(np.uint8)
    sx, sy = np.arange(5, 60), np.full(55, 30)
    cost[sy, sx] = 0
    full = wavefront(cost, sx, sy)
    need = np.zeros(cost.shape, bool)
    need[25:40, 30:45] = True
    need &= cost < 253
    ws = Wavefront()
    limited = ws.compute(cost, sx, sy, True, need)
    np.testing.assert_array_equal(limited[need], full[need])
    assert np.count_nonzero(limited == cost.size + 1) > np.count_nonzero(full == cost.size + 1)


def test_no_seed_leaves_everything_unreachable() -> None:
    v = wavefront(np.zeros((5, 5), np.uint8), np.zeros(0, np.int64), np.zeros(0, np.int64))
    assert np.all(v == 26)


def test_adjust_plan_resolution() -> None:
    plan = np.array([[0.0, 0.0, 0.0], [0.23, 0.0, 0.0], [0.25, 0.0, 0.0], [0.25, 0.5, 1.0]])
    out = adjust_plan_resolution(plan, 0.05)
    # 0.23 m gap: ceil(0.18/0.05) = 4 poses inserted; 0.02 m gap: none; 0.5 m: 9 inserted
    assert len(out) == 4 + 4 + 9
    assert np.all(np.hypot(*np.diff(out[:, :2], axis=0).T) <= 0.05 + 1e-12)
    for p in plan:
        assert np.any(np.all(np.isclose(out, p), axis=1))
    np.testing.assert_allclose(out[-1], plan[-1])


SQUARE = np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]])


def _costs(data: np.ndarray, poses: list[list[float]]) -> tuple[np.ndarray, np.ndarray]:
    return footprint_costs(np.array(poses, float), SQUARE, data, 0.0, 0.0, 0.1)


def test_footprint_outline_costs() -> None:
    data = np.zeros((20, 20), np.uint8)
    data[10, 12] = 100        # on the right edge of a square centred at (1.05, 1.05)
    data[10, 10] = 200        # under the centre: inside the outline, not on it
    costs, codes = _costs(data, [[1.05, 1.05, 0.0]])
    assert codes[0] == FOOTPRINT_OK and costs[0] == 100.0
    data[8, 9] = LETHAL_OBSTACLE  # bottom-left corner cell
    costs, codes = _costs(data, [[1.05, 1.05, 0.0]])
    assert codes[0] == FOOTPRINT_LETHAL
    data[8, 9] = NO_INFORMATION
    assert _costs(data, [[1.05, 1.05, 0.0]])[1][0] == FOOTPRINT_UNKNOWN


def test_footprint_off_grid_codes() -> None:
    data = np.zeros((20, 20), np.uint8)
    _, codes = _costs(data, [[0.1, 1.0, 0.0], [-0.5, 1.0, 0.0], [1.0, 1.0, 0.7]])
    assert codes.tolist() == [FOOTPRINT_OFF_GRID, FOOTPRINT_CENTER_OFF_GRID, FOOTPRINT_OK]


RECT = np.array([[0.3, 0.1], [-0.3, 0.1], [-0.3, -0.1], [0.3, -0.1]])


@pytest.mark.parametrize("theta", [0.0, 0.4, 1.3, -2.0])
def test_footprint_follows_rotation(theta: float) -> None:
    data = np.zeros((40, 40), np.uint8)
    cx = cy = 2.05
    # the cell under the rotated front-left vertex (0.3, 0.1) is lethal
    vx = cx + 0.3 * np.cos(theta) - 0.1 * np.sin(theta)
    vy = cy + 0.3 * np.sin(theta) + 0.1 * np.cos(theta)
    data[int(vy / 0.1), int(vx / 0.1)] = LETHAL_OBSTACLE
    poses = np.array([[cx, cy, theta], [cx, cy, theta + np.pi / 2]])
    _, codes = footprint_costs(poses, RECT, data, 0.0, 0.0, 0.1)
    # turned a quarter turn the long sides are elsewhere and the outline is clear
    assert codes.tolist() == [FOOTPRINT_LETHAL, FOOTPRINT_OK]
