"""Inflation layer: Nav2 cost formula, windows, unknown handling, uncertainty radius."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt
from scipy.stats import chi2

from navstack.core.polygon import Footprint
from navstack.costmap import (
    InflationLayer,
    InflationLayerParams,
    LayeredCostmap,
    StaticLayer,
)
from navstack.costmap.inflation_kernel import cost_lut, inflate
from navstack.costmap.inflation_layer import UncertaintyInflationParams, uncertainty_radius
from navstack.costmap.layer import CellWindow

from .helpers import grid, inflation_cost


def _single_obstacle(radius: float = 1.0, k: float = 5.0, inscribed: float = 0.22,
                     **kw: object) -> LayeredCostmap:
    lc = LayeredCostmap(81, 81, 0.05, footprint=Footprint.from_radius(inscribed))
    static = lc.add_plugin(StaticLayer())
    lc.add_plugin(InflationLayer(params=InflationLayerParams(
        inflation_radius=radius, cost_scaling_factor=k, **kw)))
    m = np.zeros((81, 81), np.int8)
    m[40, 40] = 100
    assert isinstance(static, StaticLayer)
    static.set_map(grid(m, 0.05))
    lc.update_map(2.0, 2.0, 0.0)
    return lc


@pytest.mark.parametrize(("dx", "dy"), [(0, 0), (4, 0), (3, 3), (5, 0), (3, 4), (8, 6),
                                        (12, 16), (20, 0), (0, -20), (20, 1), (15, 15)])
def test_inflation_matches_nav2_formula(dx: int, dy: int) -> None:
    lc = _single_obstacle()
    d = math.hypot(dx, dy) * 0.05
    expected = inflation_cost(d, 0.22, 5.0) if math.hypot(dx, dy) <= 20 else 0
    assert int(lc.costmap.data[40 + dy, 40 + dx]) == expected


def test_known_values() -> None:
    lc = _single_obstacle()
    c = lc.costmap.data
    assert c[40, 40] == 254
    assert c[40, 44] == 253 and c[43, 43] == 253  # 0.20 m and 0.212 m <= 0.22 m
    assert c[40, 45] == 216  # int(252 * exp(-5 * 0.03))
    assert c[40, 60] == 5  # 1.0 m: int(252 * exp(-3.9))
    assert c[41, 60] == 0  # sqrt(401) cells > 20 cells: beyond the inflation radius
    inscribed = np.argwhere(c == 253) - 40
    assert np.all(np.hypot(inscribed[:, 0], inscribed[:, 1]) * 0.05 <= 0.22)


def test_obstacle_outside_window_inflates_into_it() -> None:
    lc = _single_obstacle()
    lc.costmap.data[:, 50:] = 0  # forget the right half, then re-inflate only that window
    lc.plugins[1].update_costs(lc.costmap, CellWindow(50, 0, 81, 81))
    assert lc.costmap.data[40, 50] == inflation_cost(0.5, 0.22, 5.0)
    assert lc.costmap.data[40, 40] == 254


def test_kernel_equals_exact_edt() -> None:
    rng = np.random.default_rng(3)
    data = np.where(rng.random((120, 150)) < 0.02, 254, 0).astype(np.uint8)
    data[rng.random(data.shape) < 0.3] = 40
    lut = cost_lut(12, 0.05, 0.2, 2.0)
    out = data.copy()
    inflate(out, (0, 0, 150, 120), (0, 0, 150, 120), 12, lut)
    d2 = np.rint(distance_transform_edt(data != 254) ** 2).astype(np.int64)
    expected = np.maximum(data, np.where(d2 <= 144, lut[np.minimum(d2, 144)], 0))
    np.testing.assert_array_equal(out, expected)


def test_unknown_cells() -> None:
    data = np.full((21, 21), 255, np.uint8)
    data[10, 10] = 254
    lut = cost_lut(8, 0.1, 0.25, 1.0)
    plain = data.copy()
    inflate(plain, (0, 0, 21, 21), (0, 0, 21, 21), 8, lut)
    assert plain[10, 12] == 253  # within the inscribed radius: unknown -> INSCRIBED
    assert plain[10, 14] == 255  # lower costs leave unknown cells unknown
    inflate_unknown = data.copy()
    inflate(inflate_unknown, (0, 0, 21, 21), (0, 0, 21, 21), 8, lut, inflate_unknown=True)
    assert inflate_unknown[10, 14] == int(252 * math.exp(-1.0 * (0.4 - 0.25)))
    around = np.zeros((21, 21), np.uint8)
    around[0, :] = 255
    inflate(around, (0, 0, 21, 21), (0, 0, 21, 21), 8, lut, inflate_around_unknown=True)
    assert around[0, 5] == 254  # Nav2: unknown seeds become lethal
    assert around[3, 5] == int(252 * math.exp(-1.0 * (0.3 - 0.25)))


def test_uncertainty_radius_formula_matches_chi2() -> None:
    cov = np.array([[0.04, 0.01], [0.01, 0.02]])
    lam = np.linalg.eigvalsh(cov)[-1]
    for alpha in (0.5, 0.9, 0.95, 0.99):
        expected = math.sqrt(lam) * math.sqrt(chi2.ppf(alpha, 2))
        assert uncertainty_radius(cov, alpha) == pytest.approx(expected, rel=1e-12)


def test_uncertainty_inflation_grows_band() -> None:
    params = InflationLayerParams(
        inflation_radius=0.5, cost_scaling_factor=5.0,
        uncertainty_inflation=UncertaintyInflationParams(enabled=True, alpha=0.95,
                                                         max_radius_increase=0.3))
    lc = LayeredCostmap(81, 81, 0.05, footprint=Footprint.from_radius(0.22))
    static = lc.add_plugin(StaticLayer())
    layer = lc.add_plugin(InflationLayer(params=params))
    assert isinstance(static, StaticLayer) and isinstance(layer, InflationLayer)
    m = np.zeros((81, 81), np.int8)
    m[40, 40] = 100
    static.set_map(grid(m, 0.05))
    lc.update_map(2.0, 2.0, 0.0)
    assert lc.costmap.data[40, 52] == 0  # 0.6 m > inflation_radius 0.5 m
    sigma = 0.05
    r = layer.set_pose_covariance(np.diag([sigma**2, sigma**2]))
    assert r == pytest.approx(sigma * math.sqrt(chi2.ppf(0.95, 2)))  # 0.1224 m
    assert layer.uncertainty_increase == pytest.approx(0.15)  # whole cells, rounded up
    assert layer.effective_inflation_radius == pytest.approx(0.65)
    lc.update_map(2.0, 2.0, 0.0)
    c = lc.costmap.data
    assert c[40, 44] == 253  # inscribed stays inscribed
    assert c[40, 47] == 252  # 0.35 m <= 0.22 + 0.15: uncertainty band
    assert c[40, 52] == int(252 * math.exp(-5.0 * (0.6 - 0.37)))
    assert c[40, 54] == 0  # 0.7 m > 0.65 m
    huge = layer.set_pose_covariance(np.diag([1.0, 1.0]))
    assert huge == pytest.approx(0.3)  # capped by max_radius_increase
    with pytest.raises(ValueError, match="positive semi-definite"):
        layer.set_pose_covariance(np.diag([-1.0, 0.1]))
