"""Branch and bound on precomputed grids: exact against brute force, wide windows, the
uniqueness exclusion and the minimum score."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.mapping.fast_matcher import (
    Exclusion,
    PrecomputedGrids,
    WideWindow,
    voxel_filter,
    wide_match,
)

RES = 0.05


def room(seed: int = 0) -> np.ndarray:
    """A 10 x 8 m room with 30 short random wall pieces, points every 2 cm."""
    rng = np.random.default_rng(seed)
    pts = [np.column_stack((np.arange(-5, 5, 0.02), np.full(500, y))) for y in (-4.0, 4.0)]
    pts += [np.column_stack((np.full(400, x), np.arange(-4, 4, 0.02))) for x in (-5.0, 5.0)]
    for _ in range(30):
        c, a = rng.uniform(-4, 4, 2), rng.uniform(0, math.pi)
        t = np.arange(0, 0.6, 0.02)
        pts.append(np.column_stack((c[0] + t * math.cos(a), c[1] + t * math.sin(a))))
    return np.vstack(pts)


def seen_from(world: np.ndarray, pose: np.ndarray, count: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pts = world[rng.choice(len(world), count, replace=False)]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return (pts - pose[:2]) @ np.array([[c, -s], [s, c]])


def brute_force(grids: PrecomputedGrids, local: np.ndarray, center: np.ndarray,
                half_cells: int, angles: np.ndarray) -> tuple[float, tuple[int, int, int]]:
    level0 = grids.levels[0].astype(np.int64)
    best, arg = -1, (0, 0, 0)
    for a, th in enumerate(angles):
        c, s = math.cos(th), math.sin(th)
        world = local @ np.array([[c, s], [-s, c]]) + center[:2]
        rows, cols = grids.cells(world)
        for dr in range(-half_cells, half_cells + 1):
            for dc in range(-half_cells, half_cells + 1):
                r, q = rows + dr, cols + dc
                ok = (r >= 0) & (r < level0.shape[0]) & (q >= 0) & (q < level0.shape[1])
                score = int(level0[r[ok], q[ok]].sum())
                if score > best:
                    best, arg = score, (a, dr, dc)
    return best / (255.0 * len(local)), arg


def test_branch_and_bound_is_exact() -> None:
    world = room()
    grids = PrecomputedGrids(world, RES, 0.05, depth=3)
    truth = np.array([0.8, -0.4, 0.7])
    local = seen_from(world, truth, 60)
    center = truth + np.array([0.23, -0.31, 0.05])
    step = 0.02
    window = WideWindow(0.5, 0.5, 0.06, angle_step=step)
    match = wide_match(grids, local, center, window)
    assert match is not None
    angles = center[2] + np.arange(-3, 4) * step
    best, (a, dr, dc) = brute_force(grids, local, center, 10, angles)
    assert match.score == pytest.approx(best, abs=1e-12)
    np.testing.assert_allclose(match.pose, [center[0] + dc * RES, center[1] + dr * RES,
                                            angles[a]], atol=1e-9)
    np.testing.assert_allclose(match.pose, truth, atol=0.03)


def test_full_circle_and_metres_of_window_find_the_pose() -> None:
    world = room(2)
    grids = PrecomputedGrids(world, RES, 0.05, depth=6)
    truth = np.array([1.3, -0.7, 2.0])
    local = voxel_filter(seen_from(world, truth, 400) + 0.005, RES)
    assert 200 < len(local) <= 400
    guess = truth + np.array([2.2, -2.9, 2.6])    # 2.6 rad off: only a full circle works
    match = wide_match(grids, local, guess, WideWindow(3.0, 3.0, math.pi))
    assert match is not None and match.score > 0.8
    assert math.hypot(*(match.pose[:2] - truth[:2])) < 0.05
    assert abs(math.remainder(match.pose[2] - truth[2], 2 * math.pi)) < 0.02
    # far fewer leaves than the 121 x 121 x ~3000 poses of the window
    assert match.leaves < 1000
    # the same search told to skip the winner finds a much worse second place
    other = wide_match(grids, local, guess, WideWindow(3.0, 3.0, math.pi),
                       exclusion=Exclusion((match.pose[0], match.pose[1]), (1.0, 0.0), 0.5,
                                           0.5, match.pose[2], 0.3))
    assert other is not None and other.score < 0.8 * match.score
    assert math.hypot(*(other.pose[:2] - match.pose[:2])) > 0.5 or \
        abs(math.remainder(other.pose[2] - match.pose[2], 2 * math.pi)) > 0.3


def test_minimum_score_and_empty_input() -> None:
    world = room(3)
    grids = PrecomputedGrids(world, RES, 0.05, depth=4)
    local = seen_from(world, np.zeros(3), 100)
    local += np.random.default_rng(4).normal(0.0, 0.03, local.shape)   # a noisy scan
    best = wide_match(grids, local, np.zeros(3), WideWindow(0.2, 0.2, 0.1))
    assert best is not None and 0.3 < best.score < 0.95
    assert wide_match(grids, local, np.zeros(3), WideWindow(0.2, 0.2, 0.1),
                      min_score=best.score + 1e-6) is None
    again = wide_match(grids, local, np.zeros(3), WideWindow(0.2, 0.2, 0.1),
                       min_score=best.score - 1e-6)
    assert again is not None and again.score == best.score
    assert wide_match(grids, np.zeros((0, 2)), np.zeros(3), WideWindow(0.2, 0.2, 0.1)) is None
    far = local + 100.0                           # nothing of the room in reach
    assert wide_match(grids, far, np.zeros(3), WideWindow(1.0, 1.0, 0.1),
                      min_score=0.1) is None
    with pytest.raises(ValueError, match="at least one point"):
        PrecomputedGrids(np.zeros((0, 2)), RES, 0.05)
