"""The numba search kernel against an independent Dijkstra (scipy.sparse.csgraph)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from navstack.planning.grid_search import (
    EXHAUSTED,
    FOUND,
    RUNNING,
    GridSearchWorkspace,
    make_moves,
)


def _oracle(free: np.ndarray, weight: np.ndarray, start: tuple[int, int],
            corner_cutting: bool) -> np.ndarray:
    """Optimal costs from ``start`` by scipy's Dijkstra on the same move rules."""
    h, w = free.shape
    rows, cols, vals = [], [], []
    for y in range(h):
        for x in range(w):
            if not free[y, x]:
                continue
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    nx, ny = x + dx, y + dy
                    if (dx, dy) == (0, 0) or not (0 <= nx < w and 0 <= ny < h):
                        continue
                    if not free[ny, nx]:
                        continue
                    if dx and dy and not corner_cutting and not (free[y, nx] and free[ny, x]):
                        continue
                    rows.append(y * w + x)
                    cols.append(ny * w + nx)
                    vals.append((math.sqrt(2) if dx and dy else 1.0) * weight[ny, nx])
    graph = coo_matrix((vals, (rows, cols)), shape=(h * w, h * w)).tocsr()
    return dijkstra(graph, indices=start[1] * w + start[0]).reshape(h, w)


@pytest.mark.parametrize("corner_cutting", [False, True])
def test_astar_and_dijkstra_match_scipy_on_random_weighted_grid(corner_cutting: bool) -> None:
    rng = np.random.default_rng(7)
    h, w = 30, 40
    free = rng.random((h, w)) > 0.25
    weight = 1.0 + rng.integers(0, 5, size=(h, w)).astype(float)
    start = (0, 0)
    free[0, 0] = True
    ref = _oracle(free, weight, start, corner_cutting)
    ws = GridSearchWorkspace(w, h)
    ws.load(free, weight, corner_cutting=corner_cutting)
    ws.begin(start, None)  # full Dijkstra
    assert ws.step(0.0, 10**9) == EXHAUSTED
    closed = ws.closed_mask()
    assert np.array_equal(closed, np.isfinite(ref))
    got = np.where(closed, ws.g.reshape(h + 2, w + 2)[1:-1, 1:-1], np.inf)
    np.testing.assert_allclose(got[closed], ref[closed], rtol=0, atol=1e-9)
    goals = np.argwhere(np.isfinite(ref))[::17]
    for gy, gx in goals:  # A* to single goals on the same workspace (generation reuse)
        ws.begin(start, (int(gx), int(gy)))
        assert ws.step(1.0, 10**9) == FOUND
        assert ws.cost_to((int(gx), int(gy))) == pytest.approx(ref[gy, gx], abs=1e-9)
        cells = ws.cells_to((int(gx), int(gy)))
        steps = np.diff(cells, axis=0)
        cost = sum((math.sqrt(2) if dx and dy else 1.0) * weight[y, x]
                   for (dx, dy), (x, y) in zip(steps, cells[1:], strict=True))
        assert cost == pytest.approx(ref[gy, gx], abs=1e-9)


def test_chunked_search_equals_one_shot() -> None:
    rng = np.random.default_rng(3)
    free = rng.random((60, 60)) > 0.2
    free[0, 0] = free[59, 59] = True
    ws = GridSearchWorkspace(60, 60)
    ws.load(free)
    ws.begin((0, 0), (59, 59))
    assert ws.step(1.0, 10**9) == FOUND
    expected = ws.cost_to((59, 59))
    ws.begin((0, 0), (59, 59))
    statuses = []
    while (status := ws.step(1.0, 7)) == RUNNING:
        statuses.append(status)
    assert status == FOUND and len(statuses) > 3
    assert ws.cost_to((59, 59)) == pytest.approx(expected, abs=1e-12)


def test_move_mask_bits() -> None:
    free = np.ones((3, 3), dtype=bool)
    m = make_moves(free, corner_cutting=False)
    assert m.shape == (5, 5)
    assert m[2, 2] == 0xFF  # centre: all 8 moves
    assert m[1, 1] == 1 | 4 | 16  # corner (0, 0): E, N(+y), NE
    assert m[0].sum() == 0 and m[:, 0].sum() == 0  # padding
    free[1, 2] = False  # block E of the centre: NE and SE of the centre go too
    m = make_moves(free, corner_cutting=False)
    assert m[2, 2] == 0xFF & ~(1 | 16 | 64)
    assert make_moves(free, corner_cutting=True)[2, 2] == 0xFF & ~1
