"""Lidar ray casting: exact grid distances, analytic circles/segments, range semantics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.sim.raycast import cast_rays
from navstack.sim.world import MovingObstacle, World

NO_CIRCLES = np.zeros((0, 3))
NO_SEGMENTS = np.zeros((0, 4))


def room(res: float = 0.1, origin: tuple[float, float] = (-2.0, -1.0)) -> np.ndarray:
    """100 x 60 cells with a one-cell wall ring: free interior x in [ox + res, ox + 10 - res]."""
    occ = np.zeros((60, 100), dtype=bool)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
    return occ


def box_exit_distance(x: float, y: float, ang: np.ndarray, xmin: float, xmax: float,
                      ymin: float, ymax: float) -> np.ndarray:
    dx, dy = np.cos(ang), np.sin(ang)
    with np.errstate(divide="ignore"):
        tx = np.where(dx > 0, (xmax - x) / dx, np.where(dx < 0, (xmin - x) / dx, np.inf))
        ty = np.where(dy > 0, (ymax - y) / dy, np.where(dy < 0, (ymin - y) / dy, np.inf))
    return np.minimum(tx, ty)


def test_rectangular_room_matches_analytic_distances() -> None:
    occ = room()
    x, y, theta = 1.234, 2.345, 0.3
    angles = np.linspace(-math.pi, math.pi, 1441)
    ranges = cast_rays(occ, -2.0, -1.0, 0.1, x, y, theta, angles, 0.05, 30.0,
                       NO_CIRCLES, NO_SEGMENTS)
    expected = box_exit_distance(x, y, theta + angles, -1.9, 7.9, -0.9, 4.9)
    assert ranges.shape == (1441,) and ranges.dtype == np.float64
    np.testing.assert_allclose(ranges, expected, rtol=0, atol=1e-9)


def test_axis_aligned_beams() -> None:
    occ = room()
    angles = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2])
    r = cast_rays(occ, -2.0, -1.0, 0.1, 0.0, 0.0, 0.0, angles, 0.0, 30.0)
    np.testing.assert_allclose(r, [7.9, 4.9, 1.9, 0.9], atol=1e-9)


def brute_force(occ: np.ndarray, ox: float, oy: float, res: float, x: float, y: float,
                ang: float, rmax: float) -> float:
    """First occupied cell along the ray by dense sampling (1e-3 cell steps)."""
    t = np.arange(0.0, rmax, res * 1e-3)
    c = np.floor((x + t * math.cos(ang) - ox) / res).astype(int)
    r = np.floor((y + t * math.sin(ang) - oy) / res).astype(int)
    inside = (c >= 0) & (c < occ.shape[1]) & (r >= 0) & (r < occ.shape[0])
    stop = np.argmin(inside) if not inside.all() else len(t)
    hits = np.nonzero(occ[r[:stop], c[:stop]])[0]
    return float(t[hits[0]]) if hits.size else math.inf


def test_random_grid_matches_dense_sampling() -> None:
    rng = np.random.default_rng(3)
    occ = rng.random((40, 50)) < 0.08
    occ[20, 25] = False
    res, ox, oy = 0.05, 0.3, -0.7
    x, y = ox + 25.37 * res, oy + 20.61 * res
    angles = rng.uniform(-math.pi, math.pi, 64)
    ranges = cast_rays(occ, ox, oy, res, x, y, 0.0, angles, 0.0, 5.0)
    for a, r in zip(angles, ranges, strict=True):
        expected = brute_force(occ, ox, oy, res, x, y, float(a), 5.0)
        if math.isinf(expected):
            assert math.isinf(r)
        else:
            assert abs(r - expected) <= res * 1e-3 + 1e-12


def test_circle_analytic_distance() -> None:
    free = np.zeros((10, 10), dtype=bool)
    circles = np.array([[5.0, 1.0, 1.0]])
    angles = np.array([0.0, 0.1, 0.2, 0.3, -0.1, math.pi])
    r = cast_rays(free, -20.0, -20.0, 4.0, 0.0, 1.0, 0.0, angles, 0.1, 30.0, circles,
                  NO_SEGMENTS)
    for a, got in zip(angles, r, strict=True):
        u = np.array([math.cos(a), math.sin(a)])
        c = np.array([5.0, 0.0])
        b = float(c @ u)
        disc = b * b - (c @ c - 1.0)
        expect = b - math.sqrt(disc) if disc >= 0 and b > 0 else math.inf
        assert got == pytest.approx(expect, abs=1e-12) if math.isfinite(expect) \
            else math.isinf(got)
    assert r[0] == pytest.approx(4.0)
    assert math.isinf(r[3]) and math.isinf(r[5])  # sin(0.3)*5 > 1: misses; behind: misses


def test_sensor_inside_circle_or_occupied_cell_reads_zero() -> None:
    occ = np.zeros((10, 10), dtype=bool)
    occ[5, 5] = True
    angles = np.array([0.0, 2.0])
    r = cast_rays(occ, 0.0, 0.0, 1.0, 5.5, 5.5, 0.0, angles, 0.1, 30.0)
    np.testing.assert_array_equal(r, [0.0, 0.0])
    r2 = cast_rays(np.zeros((4, 4), bool), 0.0, 0.0, 1.0, 2.0, 2.0, 0.0, angles, 0.1, 30.0,
                   np.array([[2.1, 2.0, 0.5]]))
    np.testing.assert_array_equal(r2, [0.0, 0.0])


def test_segments_analytic() -> None:
    free = np.zeros((10, 10), dtype=bool)
    segs = np.array([[3.0, -1.0, 3.0, 1.0], [10.0, -5.0, 10.0, 5.0]])
    edge = math.atan2(1.0, 3.0)
    angles = np.array([0.0, edge, edge + 1e-6, 0.35, math.pi])
    r = cast_rays(free, -50.0, -50.0, 10.0, 0.0, 0.0, 0.0, angles, 0.0, 30.0, None, segs)
    assert r[0] == pytest.approx(3.0)
    assert r[1] == pytest.approx(math.hypot(3.0, 1.0))
    assert r[2] == pytest.approx(10.0 / math.cos(edge + 1e-6))  # past the end: far segment
    assert r[3] == pytest.approx(10.0 / math.cos(0.35))
    assert math.isinf(r[4])


def test_nothing_hit_and_range_max() -> None:
    free = np.zeros((50, 50), dtype=bool)
    r = cast_rays(free, 0.0, 0.0, 0.1, 2.5, 2.5, 0.0, np.array([0.0, 1.0]), 0.1, 30.0)
    assert np.isinf(r).all()  # beams leave the grid without a hit
    occ = np.zeros((10, 1000), dtype=bool)
    occ[:, 400] = True  # wall face at x = 40.0
    angles = np.array([0.0])
    assert math.isinf(cast_rays(occ, 0.0, 0.0, 0.1, 0.05, 0.5, 0.0, angles, 0.1, 30.0)[0])
    assert cast_rays(occ, 0.0, 0.0, 0.1, 0.05, 0.5, 0.0, angles, 0.1, 40.0)[0] == \
        pytest.approx(39.95)
    assert cast_rays(occ, 0.0, 0.0, 0.1, 10.05, 0.5, 0.0, angles, 0.1, 30.0)[0] == \
        pytest.approx(29.95)
    far_circle = np.array([[40.0, 0.5, 1.0]])
    assert math.isinf(cast_rays(free, 0.0, 0.0, 0.1, 0.0, 0.5, 0.0, angles, 0.1, 30.0,
                                far_circle)[0])


def test_hits_below_range_min_are_reported() -> None:
    occ = np.zeros((10, 10), dtype=bool)
    occ[:, 6] = True
    r = cast_rays(occ, 0.0, 0.0, 0.1, 0.55, 0.5, 0.0, np.array([0.0]), 0.2, 30.0)
    assert r[0] == pytest.approx(0.05)
    with pytest.raises(ValueError, match="range_min <= range_max"):
        cast_rays(occ, 0.0, 0.0, 0.1, 0.55, 0.5, 0.0, np.array([0.0]), 5.0, 1.0)


def test_sensor_outside_grid_enters_it() -> None:
    occ = np.zeros((10, 10), dtype=bool)
    occ[:, 5] = True
    r = cast_rays(occ, 0.0, 0.0, 0.1, -1.0, 0.25, 0.0, np.array([0.0, math.pi, 0.5]), 0.0,
                  30.0)
    assert r[0] == pytest.approx(1.5)
    assert math.isinf(r[1]) and math.isinf(r[2])


def test_world_cast_rays_sees_moving_obstacle_at_time_t() -> None:
    occ = room()
    walker = MovingObstacle("w", "circle", np.array([[3.0, 0.0], [3.0, 4.0]]), 1.0,
                            radius=0.5)
    world = World(occ, 0.1, -2.0, -1.0, moving_obstacles=(walker,))
    angles = np.array([0.0])
    assert world.cast_rays(0.0, 2.0, 0.0, angles, 0.1, 30.0, t=2.0)[0] == pytest.approx(2.5)
    assert world.cast_rays(0.0, 2.0, 0.0, angles, 0.1, 30.0, t=0.0)[0] == pytest.approx(7.9)


def test_output_buffer_is_reused() -> None:
    occ = room()
    out = np.empty(3)
    got = cast_rays(occ, -2.0, -1.0, 0.1, 0.0, 0.0, 0.0, np.array([0.0, 1.0, 2.0]), 0.0,
                    30.0, out=out)
    assert got is out and np.isfinite(out).all()
