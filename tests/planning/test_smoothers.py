"""Simple and Savitzky-Golay smoothers: straight stays straight, zig-zags relax, cusps and
end points stay fixed, and smoothing never introduces a collision."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Path
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning.smoothers import (
    SavitzkyGolaySmoother,
    SimpleSmoother,
    find_directional_path_segments,
    savitzky_golay_coefficients,
)
from navstack.planning.smoothers.common import blocked_weights, collision_flags

SMOOTHERS = [SimpleSmoother, SavitzkyGolaySmoother]


def _path(xy: np.ndarray, theta: np.ndarray | None = None) -> Path:
    if theta is None:
        d = np.diff(xy, axis=0)
        theta = np.append(np.arctan2(d[:, 1], d[:, 0]), math.atan2(d[-1, 1], d[-1, 0]))
    return Path.from_array(np.column_stack((xy, theta)), frame_id="map")


def _turning(xy: np.ndarray) -> float:
    d = np.diff(xy, axis=0)
    h = np.arctan2(d[:, 1], d[:, 0])
    return float(np.sum(np.abs(np.angle(np.exp(1j * np.diff(h))))))


def _zigzag() -> np.ndarray:
    x = np.arange(0.0, 4.0001, 0.1)
    y = 0.05 * (np.arange(len(x)) % 2)  # +-26.6 deg kinks, no cusp
    return np.column_stack((x, y))


@pytest.mark.parametrize("cls", SMOOTHERS)
def test_straight_line_stays_exactly_straight(cls: type) -> None:
    t = np.linspace(0.0, 1.0, 41) ** 1.5  # uneven spacing along the line
    xy = np.column_stack((1.0 + 3.0 * t, 2.0 + 1.5 * t))
    out = cls().smooth(_path(xy)).as_array()
    d = out[:, :2] - xy[0]
    assert np.abs(d[:, 0] * 1.5 - d[:, 1] * 3.0).max() < 1e-12  # on the line
    np.testing.assert_array_equal(out[[0, -1], :2], xy[[0, -1]])
    np.testing.assert_allclose(out[:-1, 2], math.atan2(1.5, 3.0), atol=1e-12)


def test_savitzky_golay_keeps_an_evenly_sampled_line_in_place() -> None:
    xy = np.column_stack((np.linspace(0.0, 4.0, 41), np.linspace(0.0, 2.0, 41)))
    once = SavitzkyGolaySmoother({"do_refinement": False}).smooth(_path(xy)).as_array()
    np.testing.assert_allclose(once[3:-3, :2], xy[3:-3], atol=1e-12)  # polynomial reproduction
    assert np.abs(once[1:3, :2] - xy[1:3]).max() > 1e-3  # the clamped ends do move
    out = SavitzkyGolaySmoother().smooth(_path(xy)).as_array()  # 3 passes: 9 poses each end
    np.testing.assert_allclose(out[9:-9, :2], xy[9:-9], atol=1e-12)


def test_savitzky_golay_default_coefficients_are_nav2s() -> None:
    np.testing.assert_allclose(savitzky_golay_coefficients(7, 3),
                               np.array([-2, 3, 6, 7, 6, 3, -2]) / 21.0, atol=1e-14)
    np.testing.assert_allclose(savitzky_golay_coefficients(5, 2),
                               np.array([-3, 12, 17, 12, -3]) / 35.0, atol=1e-14)
    np.testing.assert_allclose(SavitzkyGolaySmoother().coefficients,
                               np.array([-2, 3, 6, 7, 6, 3, -2]) / 21.0, atol=1e-14)


@pytest.mark.parametrize("cls", SMOOTHERS)
def test_zigzag_turning_decreases_and_end_points_stay(cls: type) -> None:
    xy = _zigzag()
    out = cls().smooth(_path(xy)).as_array()[:, :2]
    np.testing.assert_array_equal(out[[0, -1]], xy[[0, -1]])
    assert _turning(out) < 0.5 * _turning(xy)
    assert len(out) == len(xy)


def test_find_directional_path_segments_splits_at_cusps_and_rotations() -> None:
    xyt = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [1.5, 0.5, 0], [1, 1, 0], [1, 1, 1.0],
                    [1, 2, 1.0], [1, 3, 1.0]], dtype=float)
    assert find_directional_path_segments(xyt) == [(0, 2), (2, 4), (4, 7)]


def _cusp_path() -> Path:
    """Forward along a wavy line to (3, 0), then reverse up-left along another wavy line,
    the robot keeping its forward heading (theta 0) on the reversing leg."""
    s = np.arange(0.0, 3.0001, 0.1)
    fwd = np.column_stack((s, 0.05 * np.sin(4.0 * s) * (s < 2.9)))
    fwd[-1] = (3.0, 0.0)
    r = np.arange(0.1, 2.0001, 0.1)
    back = np.column_stack((3.0 - r, r * 0.5 + 0.04 * np.sin(5.0 * r)))
    xy = np.vstack((fwd, back))
    theta = np.zeros(len(xy))
    theta[: len(fwd)] = np.append(np.arctan2(*np.diff(fwd, axis=0).T[::-1]), 0.0)
    return Path.from_array(np.column_stack((xy, theta)), frame_id="map")


@pytest.mark.parametrize("cls", SMOOTHERS)
def test_cusp_segments_are_smoothed_separately(cls: type) -> None:
    path = _cusp_path()
    xyt = path.as_array()
    cusp = 30
    assert find_directional_path_segments(xyt) == [(0, cusp), (cusp, len(xyt) - 1)]
    out = cls().smooth(path).as_array()
    np.testing.assert_array_equal(out[[0, cusp, -1], :2], xyt[[0, cusp, -1], :2])
    # the same as smoothing each leg on its own
    first = cls().smooth(Path.from_array(xyt[: cusp + 1], "map")).as_array()
    second = cls().smooth(Path.from_array(xyt[cusp:], "map")).as_array()
    np.testing.assert_allclose(out[: cusp + 1, :2], first[:, :2], atol=1e-12)
    np.testing.assert_allclose(out[cusp:, :2], second[:, :2], atol=1e-12)
    # the reversing leg keeps headings opposite to its direction of travel
    d = np.diff(out[cusp:, :2], axis=0)
    travel = np.arctan2(d[:, 1], d[:, 0])
    flipped = np.angle(np.exp(1j * (out[cusp:-1, 2] - travel - math.pi)))
    assert np.abs(flipped).max() < 1e-9
    # without path inversion the cusp is smoothed away
    merged = cls({"enforce_path_inversion": False}).smooth(path).as_array()
    assert np.hypot(*(merged[cusp, :2] - xyt[cusp, :2])) > 1e-3


def _corner_case() -> tuple[Path, Costmap2D]:
    """An L-shaped path hugging a lethal block inside its corner."""
    a = np.arange(0.0, 2.0001, 0.05)
    leg1 = np.column_stack((a, np.zeros_like(a)))
    leg2 = np.column_stack((np.full(40, 2.0), np.arange(1, 41) * 0.05))
    cm = Costmap2D(400, 400, 0.01, -1.0, -1.0)
    # block x in [1.0, 1.99), y in [0.01, 1.0): just inside the corner
    cm.data[101:200, 200:299] = 254
    return _path(np.vstack((leg1, leg2))), cm


@pytest.mark.parametrize("cls", SMOOTHERS)
def test_smoothing_never_introduces_a_collision(cls: type) -> None:
    path, cm = _corner_case()
    w = blocked_weights(cm)
    geo = (cm.origin_x, cm.origin_y, cm.resolution, cm.size_x, cm.size_y)
    pts0, segs0 = collision_flags(np.ascontiguousarray(path.as_array()[:, :2]), w, *geo)
    assert not pts0.any() and not segs0.any()
    free = cls().smooth(path).as_array()[:, :2]  # no costmap: cuts into the block
    pts, segs = collision_flags(np.ascontiguousarray(free), w, *geo)
    assert pts.any() or segs.any()
    guarded = cls().smooth(path, cm).as_array()[:, :2]
    pts, segs = collision_flags(np.ascontiguousarray(guarded), w, *geo)
    assert not pts.any() and not segs.any()
    np.testing.assert_array_equal(guarded[[0, -1]], path.as_array()[[0, -1], :2])


def test_simple_smoother_keeps_last_collision_free_iterate() -> None:
    path, tight = _corner_case()
    smoother = SimpleSmoother()
    out = smoother.smooth(path, tight).as_array()
    assert smoother.last_status == [2]  # the very first iteration collides: COLLISION
    np.testing.assert_array_equal(out, path.as_array())  # so the input comes back unchanged
    loose = Costmap2D(80, 80, 0.05, -1.0, -1.0)
    loose.data[21:40, 40:59] = 254  # x in [1.0, 1.95), y in [0.05, 1.0)
    out = smoother.smooth(path, loose).as_array()[:, :2]
    assert smoother.last_status == [0, 0, 2]  # two passes converge, the 3rd would collide
    assert np.abs(out - path.as_array()[:, :2]).max() > 0.01  # the kept passes did smooth
    w = blocked_weights(loose)
    pts, segs = collision_flags(np.ascontiguousarray(out), w, -1.0, -1.0, 0.05, 80, 80)
    assert not pts.any() and not segs.any()


def test_short_paths_are_returned_unchanged() -> None:
    xy = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 0.0], [3.0, 0.5]])
    path = _path(xy)
    np.testing.assert_array_equal(SimpleSmoother().smooth(path).as_array(), path.as_array())
    assert SavitzkyGolaySmoother().smooth(path) is not None


def test_params_validation() -> None:
    with pytest.raises(ConfigError) as err:
        SavitzkyGolaySmoother({"window_size": 6})
    assert "window_size must be odd and >= 3, got 6" in str(err.value)
    with pytest.raises(ConfigError, match="unknown key"):
        SimpleSmoother({"w_smoth": 0.3})
    assert SimpleSmoother().params.max_its == 1000
    assert SimpleSmoother().params.enforce_path_inversion is True
