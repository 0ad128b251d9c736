"""AMCL motion and laser models against closed forms and hand-computed cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose, Quaternion
from navstack.localization.amcl import (
    AmclMap,
    AmclMapError,
    AmclParams,
    DifferentialMotionModel,
    LaserData,
    LaserModel,
    OmniMotionModel,
    prepare_scan,
)
from navstack.localization.amcl.sensor_model import ray_range

N = 200_000


def _moments(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return poses.mean(axis=0), np.cov(poses.T)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_differential_straight_move_matches_closed_form(direction: float) -> None:
    """A 1 m move along the heading (or straight back): rot1 = 0 (pi when reversing,
    folded to 0 for the noise), trans = 1, rot2 = 0.  With rot1_hat ~ N(0, a2) and
    trans_hat ~ N(1, a3): E[x] = +-exp(-a2/2), var(y) = (1 + a3)(1 - exp(-2 a2))/2,
    var(x) = (1 + a3)(1 + exp(-2 a2))/2 - exp(-a2), var(yaw) = 2 a2,
    cov(y, yaw) = +-a2 exp(-a2/2); alpha1 and alpha4 do not enter a straight move."""
    a2, a3 = 0.05, 0.1
    model = DifferentialMotionModel(alpha1=0.7, alpha2=a2, alpha3=a3, alpha4=0.9)
    start = np.zeros((N, 3))
    delta = np.array([direction, 0.0, 0.0])
    poses = model.sample(start, delta, delta, np.random.default_rng(0))
    mean, cov = _moments(poses)
    e = math.exp(-a2 / 2)
    assert mean == pytest.approx([direction * e, 0.0, 0.0], abs=3e-3)
    assert cov[0, 0] == pytest.approx((1 + a3) * (1 + math.exp(-2 * a2)) / 2 - e * e, rel=0.03)
    assert cov[1, 1] == pytest.approx((1 + a3) * (1 - math.exp(-2 * a2)) / 2, rel=0.03)
    assert cov[2, 2] == pytest.approx(2 * a2, rel=0.03)
    assert cov[1, 2] == pytest.approx(direction * a2 * e, rel=0.03)
    assert abs(cov[0, 1]) < 2e-3 and abs(cov[0, 2]) < 2e-3


def test_differential_rotation_in_place_uses_alpha1_only() -> None:
    """Turning 0.5 rad on the spot: rot1 = 0 (translation < 1 cm), rot2 = 0.5, so
    var(yaw) = a1 * 0.25 and the position moves by trans noise a4 * 0.25 only."""
    a1, a4 = 0.2, 0.08
    model = DifferentialMotionModel(alpha1=a1, alpha2=0.3, alpha3=0.3, alpha4=a4)
    delta = np.array([0.0, 0.0, 0.5])
    poses = model.sample(np.zeros((N, 3)), delta, delta, np.random.default_rng(1))
    mean, cov = _moments(poses)
    assert mean[2] == pytest.approx(0.5, abs=2e-3)
    assert cov[2, 2] == pytest.approx(a1 * 0.25, rel=0.03)
    assert cov[0, 0] == pytest.approx(a4 * 0.25, rel=0.03)  # trans_hat along yaw 0
    assert abs(mean[0]) < 2e-3 and abs(cov[1, 1]) < 1e-12


def test_omni_straight_move_has_alpha5_strafe() -> None:
    """Omni model, 1 m forward: x ~ N(1, a3), strafe y ~ N(0, a5), yaw ~ N(0, a2)."""
    a2, a3, a5 = 0.02, 0.05, 0.11
    model = OmniMotionModel(alpha1=0.4, alpha2=a2, alpha3=a3, alpha4=0.6, alpha5=a5)
    delta = np.array([1.0, 0.0, 0.0])
    poses = model.sample(np.zeros((N, 3)), delta, delta, np.random.default_rng(2))
    mean, cov = _moments(poses)
    assert mean == pytest.approx([1.0, 0.0, 0.0], abs=3e-3)
    assert np.diag(cov) == pytest.approx([a3, a5, a2], rel=0.03)


def test_motion_is_relative_to_each_particle() -> None:
    """Odometry moved 1 m east while heading east; a particle heading north moves north."""
    model = DifferentialMotionModel(0.0, 0.0, 0.0, 0.0)
    moved = model.sample(np.array([[2.0, 3.0, math.pi / 2]]), np.array([5.0, 0.0, 0.0]),
                         np.array([1.0, 0.0, 0.0]), np.random.default_rng(0))
    assert moved[0] == pytest.approx([2.0, 4.0, math.pi / 2], abs=1e-12)


# --- laser models ----------------------------------------------------------------------
def _grid(occupied: list[tuple[int, int]], size: int = 20, res: float = 0.1) -> OccupancyGrid:
    data = np.zeros((size, size), np.int8)
    for r, c in occupied:
        data[r, c] = 100
    info = MapMetaData(resolution=res, width=size, height=size, origin=Pose(Point(0.0, 0.0)))
    return OccupancyGrid(Header(0.0, "map"), info, data)


def test_likelihood_field_by_hand() -> None:
    """One obstacle cell at (row 10, col 15), centre (1.55, 1.05); particle at (0.55, 1.05)
    heading east.  Beam 0.8 m east ends in the cell centred (1.35, 1.05): z = 0.2 m.  Beam
    0.35 m north ends at (0.55, 1.40): z = hypot(1.0, 0.35) > 1.0 -> clamped to 1.0.  Beam
    1.0 m west ends off the map: z = 1.0.  With z_hit = z_rand = 0.5, sigma 0.2,
    range_max 10: pz = 0.5 exp(-z^2 / 0.08) + 0.05 and p = 1 + sum pz^3."""
    params = AmclParams(laser_likelihood_max_dist=1.0)
    amcl_map = AmclMap.from_occupancy_grid(_grid([(10, 15)]), 1.0)
    assert amcl_map.occ_dist[10, 13] == pytest.approx(0.2)
    assert amcl_map.occ_dist[14, 5] == 1.0  # clamped
    model = LaserModel(params, amcl_map)
    scan = LaserData(np.array([0.8, 0.35, 1.0]), np.array([0.0, math.pi / 2, math.pi]),
                     (0.0, 0.0), 10.0, 0)
    pz_near = 0.5 * math.exp(-0.04 / 0.08) + 0.05
    pz_far = 0.5 * math.exp(-1.0 / 0.08) + 0.05
    expected = math.log(1.0 + pz_near ** 3 + 2 * pz_far ** 3)
    ll = model.log_likelihood(np.array([[0.55, 1.05, 0.0]]), scan)
    assert ll[0] == pytest.approx(expected, rel=1e-12)
    # the same beams seen by a particle turned 90 degrees left, placed so the first beam
    # ends in the same cell: rotation is applied to the end points
    ll_rot = model.log_likelihood(np.array([[1.35, 0.25, math.pi / 2]]),
                                  LaserData(np.array([0.8]), np.array([0.0]), (0.0, 0.0),
                                            10.0, 0))
    assert ll_rot[0] == pytest.approx(math.log(1.0 + pz_near ** 3), rel=1e-12)
    # likelihood_field_prob: the product of the same pz
    prob = LaserModel(params.updated(laser_model_type="likelihood_field_prob"), amcl_map)
    ll_prob = prob.log_likelihood(np.array([[0.55, 1.05, 0.0]]), scan)
    assert ll_prob[0] == pytest.approx(math.log(pz_near) + 2 * math.log(pz_far), rel=1e-12)


def test_scan_preparation_subsamples_and_drops_invalid_beams() -> None:
    """360 beams, max_beams 60: amcl's step (360 - 1) // 59 = 6 takes beams 0, 6, ... 354.
    NaN and -inf are invalid; +inf and readings <= range_min become max-range readings."""
    params = AmclParams(max_beams=60, laser_max_range=8.0)
    ranges = np.full(360, 2.0, np.float32)
    ranges[[0, 6]] = np.nan
    ranges[12] = -np.inf
    ranges[18] = np.inf
    ranges[24] = 0.05
    data = prepare_scan(ranges, -math.pi, 2 * math.pi / 360, 0.1, 12.0, (0.1, 0.0, 0.5),
                        params)
    assert data.invalid == 3 and len(data.ranges) == 57 and data.range_max == 8.0
    assert data.ranges[0] == 8.0 and data.ranges[1] == 8.0  # beams 18 and 24
    assert data.bearings[0] == pytest.approx(0.5 - math.pi + 18 * 2 * math.pi / 360)
    assert data.laser_xy == (0.1, 0.0)


def test_beam_skipping_leaves_out_beams_most_particles_disagree_with() -> None:
    """Converged particles: the beam ending on the obstacle agrees for all of them, the
    beam ending 1 m from anything for none -> it is skipped.  If every beam disagrees
    (>= beam_skip_error_threshold), all beams are used again."""
    params = AmclParams(laser_model_type="likelihood_field_prob", do_beamskip=True,
                        laser_likelihood_max_dist=1.0)
    model = LaserModel(params, AmclMap.from_occupancy_grid(_grid([(10, 15)]), 1.0))
    poses = np.tile([[0.55, 1.05, 0.0]], (10, 1))
    scan = LaserData(np.array([1.0, 0.35]), np.array([0.0, math.pi / 2]), (0.0, 0.0), 10.0, 0)
    pz_hit = 0.5 + 0.05
    pz_far = 0.5 * math.exp(-1.0 / 0.08) + 0.05
    ll = model.log_likelihood(poses, scan, converged=True)
    assert ll == pytest.approx(np.full(10, math.log(pz_hit)))
    assert model.skipped_beams == 1 and not model.beamskip_error
    assert model.log_likelihood(poses, scan, converged=False) == pytest.approx(
        np.full(10, math.log(pz_hit) + math.log(pz_far)))
    lost = LaserData(np.array([0.35, 0.35]), np.array([math.pi / 2, -math.pi / 2]),
                     (0.0, 0.0), 10.0, 0)
    assert model.log_likelihood(poses, lost, converged=True) == pytest.approx(
        np.full(10, 2 * math.log(pz_far)))
    assert model.skipped_beams == 2 and model.beamskip_error


def test_beam_model_by_hand() -> None:
    """A wall filling column 15 (x in [1.5, 1.6)); from (0.55, 1.05) heading east the ray
    reaches it at 0.95 m.  A 0.9 m reading is short by 0.05 m:
    pz = z_hit exp(-0.05^2 / (2 0.2^2)) + z_short lambda exp(-lambda 0.9) + z_rand / 10;
    a max-range reading adds z_max instead of z_rand: p = 1 + sum pz^3."""
    params = AmclParams(laser_model_type="beam")
    grid = _grid([(r, 15) for r in range(20)])
    amcl_map = AmclMap.from_occupancy_grid(grid, 2.0)
    assert ray_range(amcl_map.occ_state, 0.0, 0.0, 0.1, 0.55, 1.05, 1.0, 0.0, 10.0) == \
        pytest.approx(0.95)
    assert ray_range(amcl_map.occ_state, 0.0, 0.0, 0.1, 0.55, 1.05, 0.0, 1.0, 10.0) == \
        pytest.approx(0.95)  # north: the map edge (off the grid) at y = 2.0
    scan = LaserData(np.array([0.9, 10.0]), np.array([0.0, 0.0]), (0.0, 0.0), 10.0, 0)
    pz1 = (0.5 * math.exp(-0.05 ** 2 / 0.08) + 0.05 * 0.1 * math.exp(-0.1 * 0.9)
           + 0.5 / 10.0)
    z2 = 10.0 - 0.95
    pz2 = 0.5 * math.exp(-z2 * z2 / 0.08) + 0.05
    ll = LaserModel(params, amcl_map).log_likelihood(np.array([[0.55, 1.05, 0.0]]), scan)
    assert ll[0] == pytest.approx(math.log(1.0 + pz1 ** 3 + pz2 ** 3), rel=1e-12)


def test_maps_amcl_cannot_use_are_refused() -> None:
    grid = _grid([])
    rotated = OccupancyGrid(grid.header, MapMetaData(
        resolution=0.1, width=20, height=20,
        origin=Pose(Point(0.0, 0.0), Quaternion.from_yaw(0.3))), grid.data)
    with pytest.raises(AmclMapError, match=r"origin yaw 0\.3000 rad is not supported"):
        AmclMap.from_occupancy_grid(rotated, 2.0)
    bad = OccupancyGrid(grid.header, MapMetaData(resolution=0.1, width=5, height=5), grid.data)
    with pytest.raises(AmclMapError) as err:
        AmclMap.from_occupancy_grid(bad, 2.0)
    assert str(err.value) == ("map is 5 x 5 cells but carries 400 values; publish a non-empty "
                              "grid whose data has height * width values")
    empty = AmclMap.from_occupancy_grid(grid, 2.0)
    assert (empty.occ_dist == 2.0).all() and len(empty.free_cells) == 400


def test_likelihood_field_reads_both_faces_of_a_wall_alike() -> None:
    """A one-cell wall (row 10: y 1.0..1.1) seen from the south (end point on y = 1.0)
    and from the north (y = 1.1): both end points lie half a cell from the wall's cell
    centres, so both read the mean of the table at z = 0 and z = 0.1 (bilinear between
    cell centres).  Reading the cell an end point falls in would give z = 0 from one side
    and z = 0.1 from the other: a half-cell pull in corridors."""
    wall = [(10, c) for c in range(20)]
    params = AmclParams(laser_likelihood_max_dist=1.0)
    model = LaserModel(params, AmclMap.from_occupancy_grid(_grid(wall), 1.0))
    beam = LaserData(np.array([0.5]), np.array([0.0]), (0.0, 0.0), 10.0, 0)
    from_south = model.log_likelihood(np.array([[1.05, 0.5, math.pi / 2]]), beam)[0]
    from_north = model.log_likelihood(np.array([[1.05, 1.6, -math.pi / 2]]), beam)[0]
    pz = [0.5 * math.exp(-z * z / 0.08) + 0.05 for z in (0.0, 0.1)]
    assert from_south == pytest.approx(from_north, abs=1e-12)
    assert from_south == pytest.approx(math.log(1.0 + (pz[0] ** 3 + pz[1] ** 3) / 2), rel=1e-9)
