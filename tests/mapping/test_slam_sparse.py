"""Sparse scans of a short-range lidar (issue 16's warehouse exploration, docs/mapping.md
"Sparse scans"): the coupled match covariance, the odometry placement of near-empty scans
and the TurtleBot3 profile on the first stretch of the warehouse LDS drive."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.benchmarks.slam_lds import LDS_ROUTE, lds_params, map_online, record_lds
from navstack.mapping.scan_matcher import (
    LikelihoodGrid,
    SearchWindow,
    coupled_covariance,
    match_scan,
    response_covariance,
)
from navstack.mapping.slam import LaserGeometry, SlamMapper
from navstack.mapping.slam_params import SlamParams

UNIT = np.array([0.02, 0.02, 2 * 0.00349])  # SlamMapper.match_unit() with the defaults
#: the sparse-scan rules off: Karto's behaviour and the odometry defaults
RULES_OFF = {"link_match_coupled_variance_ratio": 0.0, "link_match_weak_direction_ratio": 0.0,
             "link_match_minimum_points": 0, "odometry_edges_on_every_link": False,
             "odometry_noise_from_degenerate_matches": True, "odometry_edge_robust_kernel": 1.0,
             "odometry_linear_error_floor": 0.02,
             "odometry_angular_error_floor": math.radians(1.0)}


def _segment(a, b, step=0.02):
    a, b = np.asarray(a, float), np.asarray(b, float)
    n = int(np.hypot(*(b - a)) / step) + 1
    return a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)


def _match(points):
    grid = LikelihoodGrid.around(points, points, 1.0, 0.02, 0.05)
    window = SearchWindow()
    return grid, window, match_scan(grid, points, np.zeros(3), window)


def test_a_lone_corner_far_away_has_a_coupled_weak_direction():
    """A rack corner 3 m off (two 0.4 m faces), the only returns of a scan: turning about
    the corner with the translation that keeps it in place fits as well as the match.
    The x / y / theta response surface does not see it (each axis alone is sharp); the
    coupled covariance does, along a direction that mixes rotation and translation,
    with a standard deviation along it of several match units."""
    corner = np.vstack((_segment((3.0, 0.4), (3.0, 0.0)), _segment((3.0, 0.0), (3.4, 0.0))))
    grid, window, match = _match(corner)
    surface = response_covariance(grid, corner, match.pose, window)
    assert math.sqrt(surface[2, 2]) < math.radians(1.5)
    assert match.hessian is not None
    coupled = coupled_covariance(grid, corner, match.pose, match.hessian, UNIT, 4.0)
    assert coupled is not None
    w, v = np.linalg.eigh(coupled / np.outer(UNIT, UNIT))
    weak = v[:, -1]
    assert math.sqrt(w[-1]) > 5.0  # match units
    assert abs(weak[2]) > 0.3 and math.hypot(weak[0], weak[1]) > 0.3  # mixed


def test_a_room_around_the_scan_has_no_coupled_direction():
    """Walls all round constrain every direction: no coupled term."""
    room = np.vstack((_segment((-2.0, -1.5), (2.5, -1.5)), _segment((2.5, -1.5), (2.5, 2.0)),
                      _segment((2.5, 2.0), (-2.0, 2.0)), _segment((-2.0, 2.0), (-2.0, -1.5))))
    grid, _, match = _match(room)
    assert match.hessian is not None
    assert coupled_covariance(grid, room, match.pose, match.hessian, UNIT, 4.0) is None


def _corridor_ranges(angles, half_width, length):
    """Ranges in a corridor along x, ``half_width`` to either wall, ``length`` ahead."""
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        side = np.where(np.abs(s) > 1e-9, half_width / np.abs(s), np.inf)
        end = np.where(c > 1e-9, length / c, np.inf)
    return np.minimum(side, end)


def test_a_scan_with_too_few_returns_is_placed_by_odometry():
    """Nodes whose scans hold fewer than link_match_minimum_points returns in range are
    placed by their odometry (counted in sparse_nodes), with no scan match and no wide
    search; a full scan in between is matched as before."""
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    laser = LaserGeometry(angles, 0.12, 3.5)
    params = SlamParams(max_laser_range=3.5, minimum_travel_distance=0.3,
                        minimum_time_interval=0.0, link_match_minimum_points=40,
                        do_loop_closing=False)
    mapper = SlamMapper(params, laser)
    wide = _corridor_ranges(angles, 1.0, 3.0)
    empty = np.full(360, np.inf)  # open space: nothing within 3.5 m
    odometry = [(0.0, 0.0, 0.0), (0.35, 0.0, 0.0), (0.7, 0.02, 0.01), (1.05, 0.0, 0.0)]
    scans = [wide, empty, empty, _corridor_ranges(angles, 1.0, 1.95)]
    for k, (odom, ranges) in enumerate(zip(odometry, scans, strict=True)):
        assert mapper.process_scan(ranges, odom, float(k))
    assert mapper.stats.sparse_nodes == 2
    assert mapper.stats.wide_searches == 0 and mapper.stats.match_failures == 0
    poses = mapper.poses()
    np.testing.assert_allclose(poses[1], odometry[1], atol=1e-6)
    np.testing.assert_allclose(poses[2], odometry[2], atol=1e-6)


@pytest.fixture(scope="module")
def south_aisle():
    """The LDS drive's first stretch: the spawn, the open corner, the south cross aisle
    to x = 15 m (340 scans, 68 s)."""
    return record_lds(LDS_ROUTE[:4])


def test_the_turtlebot_profile_stays_better_than_its_odometry(south_aisle):
    """With the TurtleBot3's own SLAM parameters (the sparse-scan rules on) the online
    estimate never strays further from the truth than the wheel odometry does, and the
    final trajectory is within 5 cm (ATE); some nodes were placed by odometry."""
    assert south_aisle.collisions == 0
    run = map_online(south_aisle.log, lds_params(south_aisle.log.reference[0]))
    assert run.online_max_m < run.odometry_max_m
    assert run.ate_m < 0.05
    assert run.mapper.stats.sparse_nodes > 0


def test_without_the_sparse_rules_the_same_drive_is_worse_than_odometry(south_aisle):
    """The failure the rules fix: Karto's link matching on the same scans (a rack corner
    or nothing in range) turns the map, and the online estimate ends up twice as far off
    as dead reckoning."""
    run = map_online(south_aisle.log, lds_params(south_aisle.log.reference[0], RULES_OFF))
    assert run.online_max_m > 1.5 * run.odometry_max_m
    assert run.ate_m > 0.05
