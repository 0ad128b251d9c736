"""OdometryNoise's scale calibration and the weak-direction odometry edge."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.mapping.odometry_check import OdometryNoise
from navstack.mapping.slam_links import weak_part as _weak_part
from navstack.mapping.slam_params import SlamParams


def test_scale_is_learned_from_the_matches_and_corrects_the_steps() -> None:
    noise = OdometryNoise(SlamParams())
    assert noise.scale() == (1.0, 1.0)
    rng = np.random.default_rng(3)
    for k in range(60):
        # the wheels report 4 % too much distance and 10 % too little turning
        d, a = 0.3 + 0.01 * (k % 5), 0.5 * math.sin(k)
        odo = np.array([1.04 * d * math.cos(0.1), 1.04 * d * math.sin(0.1), 0.9 * a])
        true = np.array([d * math.cos(0.1), d * math.sin(0.1), a])
        noise.observe(odo, true + rng.normal(0.0, 1e-4, 3))
    s_lin, s_ang = noise.scale()
    assert s_lin == pytest.approx(1 / 1.04, abs=1e-3)
    assert s_ang == pytest.approx(1 / 0.9, abs=5e-3)
    step = noise.calibrated_step(np.array([1.04, 0.0, 0.09]))
    assert step == pytest.approx([1.0, 0.0, 0.09], abs=5e-3)  # rotation not rescaled
    # the noise is learned from the raw steps: the 10 % turn error raises the angular
    # factor above its default, the 4 % distance error (0.02 per metre) does not
    lin, ang = noise.factors()
    assert lin == SlamParams().odometry_linear_error
    assert ang > SlamParams().odometry_angular_error


def test_scale_needs_enough_motion_and_is_clamped() -> None:
    noise = OdometryNoise(SlamParams())
    for _ in range(5):  # 5 x 0.3^2 = 0.45 m^2 < SCALE_MINIMUM
        noise.observe(np.array([0.3, 0.0, 0.0]), np.array([0.6, 0.0, 0.0]))
    assert noise.scale()[0] == 1.0
    for _ in range(20):
        noise.observe(np.array([0.3, 0.0, 0.0]), np.array([0.6, 0.0, 0.0]))
    assert noise.scale()[0] == OdometryNoise.SCALE_LIMITS[1]
    # steps compared with degenerate matches teach the noise, not the scale
    other = OdometryNoise(SlamParams())
    for _ in range(30):
        other.observe(np.array([0.3, 0.0, 0.0]), np.array([0.6, 0.0, 0.0]), scale=False)
    assert other.scale() == (1.0, 1.0)
    assert other.factors()[0] > 0.5


def test_odometry_edge_informs_only_the_weak_direction_of_the_match() -> None:
    unit = np.array([0.02, 0.02, 0.007])
    # a corridor along x: the match is 10 x longer along it than across
    cov = np.diag([0.2**2, 0.02**2, 0.007**2])
    odo_info = np.linalg.inv(np.diag([0.03**2, 0.03**2, 0.02**2]))
    part = _weak_part(odo_info, cov, unit)
    assert part[0, 0] == pytest.approx(odo_info[0, 0], rel=1e-5)
    # across and in heading only the negligible regularisation (1000 unit deviations)
    assert part[1, 1] == pytest.approx(1.0 / (1e3 * 0.02) ** 2)
    assert part[2, 2] == pytest.approx(1.0 / (1e3 * 0.007) ** 2)
    assert np.all(np.linalg.eigvalsh(part) > 0.0)
    # a corridor at 45 degrees: the information lies along (1, 1)
    c = math.sqrt(0.5)
    rot = np.array([[c, -c, 0.0], [c, c, 0.0], [0.0, 0.0, 1.0]])
    part = _weak_part(odo_info, rot @ cov @ rot.T, unit)
    along = np.array([c, c, 0.0])
    assert along @ part @ along == pytest.approx(odo_info[0, 0], rel=1e-5)
    across = np.array([-c, c, 0.0])
    assert across @ part @ across == pytest.approx(1.0 / (1e3 * 0.02) ** 2, rel=1e-6)
