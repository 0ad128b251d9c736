"""Initial pose: magnetometer heading, GNSS guess into the map, scan-to-map refinement."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.benchmarks.initial_pose import initial_pose_trials
from navstack.core.errors import ConfigError, InvalidMessage
from navstack.core.msgs import (
    Header,
    MagneticField,
    NavSatFix,
    NavSatStatus,
    Pose2D,
    PoseWithCovarianceStamped,
    Vector3,
)
from navstack.geo.conversions import LocalCartesian
from navstack.localization.initial_pose import (
    InitialPoseParams,
    MapMatcher,
    gnss_pose_guess,
    magnetometer_yaw,
    scan_in_base,
    surface_points,
)
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world

DATUM = (47.3769, 8.5417, 400.0)


def mag(bx: float, by: float) -> MagneticField:
    return MagneticField(Header(0.0, "mag"), Vector3(bx, by, -4e-5))


def test_magnetometer_yaw_from_the_field_direction() -> None:
    assert magnetometer_yaw(mag(2e-5, 0.0)) == pytest.approx(math.pi / 2)  # facing north
    assert magnetometer_yaw(mag(0.0, 2e-5)) == pytest.approx(0.0)  # north on the left: east
    assert magnetometer_yaw(mag(2e-5, 0.0), declination=0.2, offset=0.05) == \
        pytest.approx(math.pi / 2 - 0.15)
    with pytest.raises(InvalidMessage, match=r"magnetic field \(0.0, 0.0\) has no usable "
                                             "horizontal component"):
        magnetometer_yaw(mag(0.0, 0.0))


def test_gnss_guess_goes_through_enu_and_map_from_enu() -> None:
    params = InitialPoseParams(datum=DATUM, map_from_enu=(1.0, 2.0, math.pi / 2))
    lat, lon, alt = LocalCartesian(*DATUM).reverse(10.0, 0.0, 0.0)
    fix = NavSatFix(Header(0.0, "gps"), NavSatStatus(0, 1), lat, lon, alt,
                    np.eye(3), NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN)
    # base_link faces ENU north; the antenna is 0.5 m ahead, so base_link is at ENU (10, -0.5)
    guess = gnss_pose_guess(fix, math.pi / 2, params, antenna=(0.5, 0.0))
    assert (guess.x, guess.y, guess.theta) == pytest.approx((1.5, 12.0, math.pi), abs=1e-9)
    bad = NavSatFix(Header(0.0, "gps"), NavSatStatus(-1, 1), lat, lon, alt)
    with pytest.raises(InvalidMessage, match=r"GNSS fix unusable for the initial pose "
                                             r"\(no_fix\)"):
        gnss_pose_guess(bad, 0.0, params)


def test_datum_is_required() -> None:
    with pytest.raises(ConfigError, match="datum: required key is missing"):
        InitialPoseParams.from_mapping({})


def test_surface_points_lie_on_the_faces() -> None:
    occ = np.zeros((6, 5), bool)
    occ[2:4, :] = True  # a wall two cells thick across the grid
    pts = surface_points(occ, 0.5)
    ys = sorted(set(np.round(pts[:, 1], 9)))
    assert ys == [1.0, 2.0]  # the south face y = 2 * 0.5 and the north face y = 4 * 0.5
    single = surface_points(np.pad(np.ones((1, 1), bool), 1), 1.0)
    assert single.tolist() == [[1.5, 1.5]]  # free on all sides: stays at the centre


@pytest.fixture(scope="module")
def office_matcher() -> tuple[MapMatcher, Simulator]:
    world = load_world("office")
    prof = load_robot("turtlebot")
    sim = Simulator(world, prof, seed=3, spawn=Pose2D(7.0, 11.0, 0.8))
    return MapMatcher.from_grid(world.to_occupancy_grid(), InitialPoseParams(datum=DATUM)), sim


def test_refinement_recovers_the_pose_from_a_bad_guess(
        office_matcher: tuple[MapMatcher, Simulator]) -> None:
    matcher, sim = office_matcher
    scan = sim.scan(0.0)
    assert scan is not None
    pts = scan_in_base(scan, sim.robot.sensors.lidar.mount.pose2d)
    truth = sim.pose
    for dx, dy, dth in ((1.5, -1.0, math.radians(12.0)), (-2.5, 1.5, math.radians(-19.0))):
        est = matcher.refine(pts, Pose2D(truth.x + dx, truth.y + dy, truth.theta + dth))
        assert est.refined and est.response > 0.9
        assert est.pose.distance_to(truth) < 0.03
        assert abs(est.pose.theta - truth.theta) < math.radians(0.5)
    # 4.5 m off: beyond the first +-3 m window, found by the wider retry
    est = matcher.refine(pts, Pose2D(truth.x - 4.5, truth.y, truth.theta))
    assert est.refined and est.pose.distance_to(truth) < 0.03
    msg = est.message(1.5)
    assert isinstance(msg, PoseWithCovarianceStamped) and msg.header == Header(1.5, "map")
    assert msg.pose.covariance[2, 2] == 1e6


def test_a_scan_that_fits_nowhere_keeps_the_guess(
        office_matcher: tuple[MapMatcher, Simulator]) -> None:
    matcher, _ = office_matcher
    rng = np.random.default_rng(0)
    noise = rng.uniform(-4.0, 4.0, (60, 2))
    guess = Pose2D(10.0, 7.5, 0.0)
    est = matcher.refine(noise, guess)
    assert not est.refined and est.pose == guess
    assert est.reason.startswith("scan match response ")
    assert est.reason.endswith("below min_response 0.5: keeping the GNSS guess")
    few = matcher.refine(noise[:5], guess)
    assert few.reason == "scan has 5 valid points (< 10)"


def test_acceptance_median_error_over_20_trials() -> None:
    """Office, GNSS 2 m (1 sigma per axis), magnetometer off by exactly 15 deg."""
    errors = initial_pose_trials(20, seed=0, world="office")
    assert len(errors) == 20
    assert float(np.median(errors)) <= 0.3
    assert sum(e <= 0.3 for e in errors) >= 18
