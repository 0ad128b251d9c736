"""AMCL particle set: KLD bound, low-variance resampling, recovery, clusters, budget."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.localization.amcl import (
    AmclFilter,
    AmclParams,
    InvalidInitialPose,
    ParticleFilter,
    kld_limit,
    prepare_scan,
)
from navstack.localization.amcl.particle_filter import low_variance_indices
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world


def _pf(min_n: int = 500, max_n: int = 2000, seed: int = 0, slow: float = 0.0,
        fast: float = 0.0) -> ParticleFilter:
    return ParticleFilter(min_n, max_n, 0.05, 0.99, slow, fast, np.random.default_rng(seed))


def test_kld_limit_closed_form() -> None:
    """n = ceil((k-1)/(2 err) * (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) z)^3): k = 2 -> 19.27
    -> 20, k = 100 -> 1128.65 -> 1129; one bin (or none) -> max; clamped to [min, max]."""
    assert kld_limit([0, 1, 2, 100], 0.05, 0.99, 1, 5000).tolist() == [5000, 5000, 20, 1129]
    assert kld_limit([2, 100, 10_000], 0.05, 0.99, 500, 2000).tolist() == [500, 1129, 2000]


def test_low_variance_resampling_is_systematic() -> None:
    """Systematic resampling draws each particle floor or ceil of N * w_i times."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        idx = low_variance_indices(np.array([0.5, 0.25, 0.125, 0.125]), 8, rng)
        assert np.bincount(idx, minlength=4).tolist() == [4, 2, 1, 1]
    counts = np.bincount(low_variance_indices(np.array([0.7, 0.2, 0.1]), 10, rng), minlength=3)
    assert counts.tolist() == [7, 2, 1]


def test_kld_shrinks_a_converged_set_and_keeps_a_spread_one() -> None:
    pf = _pf()
    pf.set_free_space(np.array([[x + 0.025, y + 0.025] for x in np.arange(0, 10, 0.05)
                                for y in np.arange(0, 10, 0.05)]), 0.05)
    pf.init_uniform()
    assert len(pf) == 2000 and not pf.converged
    assert pf.resample() == 2000  # ~2000 occupied bins need the maximum
    # tightly around a bin corner: a handful of bins -> min_particles + 1 (amcl's n > limit)
    pf.init_gaussian([5.0, 5.0, 0.0], np.diag([0.05 ** 2, 0.05 ** 2, 0.03 ** 2]))
    assert pf.converged
    assert pf.resample() == 501
    assert np.allclose(pf.weights, 1 / 501)


def test_clusters_pick_the_heaviest_hypothesis_with_a_circular_yaw_mean() -> None:
    """Two groups: 300 particles at (2, 2) with yaws around +-pi (weight 0.7) and 100 at
    (8, 8) heading 0 (weight 0.3).  The estimate is the first group's mean with yaw pi
    (not the arithmetic mean ~0); the covariance is that group's spread, not the whole
    set's (which counts the distance between the two hypotheses)."""
    pf = _pf()
    rng = np.random.default_rng(5)
    a = np.column_stack((2 + 0.05 * rng.standard_normal(300), 2 + 0.05 * rng.standard_normal(300),
                         np.where(rng.random(300) < 0.5, math.pi - 0.02, -math.pi + 0.02)))
    b = np.column_stack((8 + 0.05 * rng.standard_normal(100), 8 + 0.05 * rng.standard_normal(100),
                         np.zeros(100)))
    pf.poses = np.vstack((a, b))
    pf.weights = np.concatenate((np.full(300, 0.7 / 300), np.full(100, 0.3 / 100)))
    clusters = pf.clusters()
    assert len(clusters) == 2
    assert clusters[0].weight == pytest.approx(0.7) and clusters[0].count == 300
    assert clusters[1].weight == pytest.approx(0.3)
    mean, cov = pf.estimate()
    assert mean[:2] == pytest.approx(a[:, :2].mean(axis=0))
    assert abs(abs(mean[2]) - math.pi) < 0.01
    assert clusters[0].covariance[2, 2] == pytest.approx(0.02 ** 2, rel=0.01)
    assert cov == pytest.approx(clusters[0].covariance)
    assert cov[0, 0] == pytest.approx(np.var(a[:, 0]), rel=1e-9)
    # the whole set's x variance: 0.7 * 0.3 * 6^2 between the groups + the small spread
    assert pf.set_statistics()[1][0, 0] == pytest.approx(0.21 * 36, rel=0.01)


def test_gaussian_initialisation_and_rejection() -> None:
    pf = _pf(max_n=20000)
    cov = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.01]])
    pf.init_gaussian([1.0, 2.0, 3.1], cov)
    assert len(pf) == 20000
    mean, est_cov = pf.estimate()
    assert mean == pytest.approx([1.0, 2.0, 3.1], abs=0.01)
    assert est_cov == pytest.approx(cov, abs=0.004)
    before = pf.poses.copy()
    with pytest.raises(InvalidInitialPose) as err:
        pf.init_gaussian([math.nan, 0.0, 0.0], cov)
    assert str(err.value) == ("initial pose must be 3 finite numbers (x, y, yaw), "
                              "got [nan, 0.0, 0.0]")
    with pytest.raises(InvalidInitialPose, match="symmetric positive semi-definite"):
        pf.init_gaussian([0.0, 0.0, 0.0], -cov)
    with pytest.raises(InvalidInitialPose, match="NaN or infinite entries"):
        pf.init_gaussian([0.0, 0.0, 0.0], np.full((3, 3), np.inf))
    assert np.array_equal(pf.poses, before)


def test_recovery_injects_the_w_fast_w_slow_shortfall() -> None:
    """w_slow, w_fast start at the first average likelihood, then low-pass it; when the
    likelihood drops the fraction 1 - w_fast / w_slow of candidates is drawn uniformly."""
    pf = _pf(slow=0.1, fast=0.5)
    pf.set_free_space(np.array([[50.0, 50.0]]), 1.0)  # far from the particles
    pf.init_gaussian([0.0, 0.0, 0.0], np.diag([0.01, 0.01, 0.01]))
    pf.update_weights(np.full(len(pf), math.log(8.0)))
    assert (pf.w_slow, pf.w_fast) == pytest.approx((8.0, 8.0))
    assert pf.recovery_fraction() == 0.0
    pf.update_weights(np.full(len(pf), math.log(4.0)))
    assert pf.w_slow == pytest.approx(7.6) and pf.w_fast == pytest.approx(6.0)
    assert pf.recovery_fraction() == pytest.approx(1 - 6.0 / 7.6)
    n = pf.resample()
    injected = np.abs(pf.poses[:, 0] - 50.0) < 0.5 + 1e-9
    assert pf.injected_total == pf.injected
    assert pf.injected / 2000 == pytest.approx(1 - 6.0 / 7.6, abs=0.03)
    assert injected.sum() == pytest.approx(n * (1 - 6.0 / 7.6), rel=0.2)
    assert pf.w_slow == pytest.approx(7.6)  # Augmented_MCL: no reset of the averages


def test_updates_with_2000_particles_and_60_beams_keep_the_set_and_time_each_update() -> None:
    """Motion + likelihood field (60 beams) + KLD resampling + clusters for 2000 particles;
    every update is timed (the 5 ms budget is ``navstack bench localization``'s)."""
    world = load_world("office")
    sim = Simulator(world, load_robot("diff_drive"), seed=0)
    params = AmclParams(base_frame_id="base_link")
    f = AmclFilter(params, np.random.default_rng(0))
    f.set_map(world.to_occupancy_grid())
    scan = sim.scan(0.0)
    data = prepare_scan(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min,
                        scan.range_max, (0.0, 0.0, 0.0), params)
    assert len(data.ranges) == 60
    spawn = world.spawn
    times = []
    for i in range(110):
        f.initialize_pose([spawn.x, spawn.y, spawn.theta], np.diag([0.25, 0.25, 0.07]))
        assert len(f.pf) == 2000
        f.update(np.array([0.3, 0.0, 0.1]), np.array([0.3, 0.0, 0.1]), data)
        if i >= 10:  # first calls load the numba cache
            times.append(f.last_update_ms)
    assert len(times) == 100 and all(t > 0.0 for t in times)


def test_recovery_averages_follow_the_per_beam_likelihood_of_a_product_model() -> None:
    """Weights use the full likelihood; w_avg = sum_i w_i p_i^(1/factors)."""
    pf = _pf(slow=0.5, fast=0.5)
    pf._reset(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    ll = np.array([-100.0, -120.0])
    w_avg = pf.update_weights(ll, factors=100)
    assert pf.weights[1] / pf.weights[0] == pytest.approx(math.exp(-20.0), rel=1e-9)
    assert w_avg == pytest.approx(0.5 * math.exp(-1.0) + 0.5 * math.exp(-1.2), rel=1e-12)
    assert pf.w_slow == pf.w_fast == pytest.approx(w_avg)


def test_tempered_update_softens_the_weights_but_not_the_recovery_averages() -> None:
    pf = _pf(slow=0.5, fast=0.5)
    pf._reset(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    w_avg = pf.update_weights(np.array([-100.0, -120.0]), factors=100, temper=0.25)
    assert pf.weights[1] / pf.weights[0] == pytest.approx(math.exp(-5.0), rel=1e-9)
    assert w_avg == pytest.approx(0.5 * math.exp(-1.0) + 0.5 * math.exp(-1.2), rel=1e-12)


def test_global_initialisation_anneals_the_configured_number_of_updates() -> None:
    world = load_world("office")
    params = AmclParams(global_localization_anneal_updates=3, max_particles=3000,
                        laser_model_type="likelihood_field_prob")
    f = AmclFilter(params, np.random.default_rng(0))
    f.set_map(world.to_occupancy_grid())
    f.initialize_global()
    assert f.anneal_left == 3
    f.initialize_pose([3.0, 3.0, 0.0], np.diag([0.1, 0.1, 0.05]))
    assert f.anneal_left == 0  # a known pose is never tempered
    with pytest.raises(ConfigError, match="global_localization_anneal_updates"):
        AmclParams.from_mapping({"global_localization_anneal_updates": -1})
