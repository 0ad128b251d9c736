"""navsat_transform semantics: datum, heading, antenna offset, covariance, rejections."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import ConfigError, TransformError
from navstack.core.msgs import Header, NavSatFix, NavSatStatus
from navstack.geo.conversions import geodetic_to_utm
from navstack.localization.navsat import NavsatTransform, NavsatTransformParams
from tests.localization.navsat_helpers import (
    ALT0,
    COV,
    ENU,
    LAT0,
    LON0,
    fix_at,
    local_params,
    odom_at,
)


def test_datum_from_first_fix_heading_and_odometry() -> None:
    core = NavsatTransform(local_params())
    assert core.add_fix(fix_at(0.0, 0.0))
    core.add_heading(1.0)
    assert not core.compute_transform()  # no odometry yet
    core.add_odometry(odom_at(10.0, 5.0, 0.3))
    assert core.compute_transform()
    assert core.transform is not None
    assert core.transform.yaw == pytest.approx(0.3 - 1.0, abs=1e-12)
    core.add_fix(fix_at(3.0, 4.0, t=1.0))
    core.add_odometry(odom_at(0.0, 0.0, 0.0, t=1.0))
    out = core.gps_odometry()
    assert out is not None
    c, s = math.cos(-0.7), math.sin(-0.7)
    p = out.pose.pose.position
    assert (p.x, p.y) == pytest.approx((10.0 + 3 * c - 4 * s, 5.0 + 3 * s + 4 * c), abs=1e-6)
    assert out.header == Header(1.0, "map") and out.child_frame_id == "base_link"
    assert core.gps_odometry() is None  # each fix is reported once


def test_declination_yaw_offset_and_covariance_rotation() -> None:
    core = NavsatTransform(local_params(magnetic_declination_radians=0.2, yaw_offset=0.3))
    core.add_fix(fix_at(0.0, 0.0))
    core.add_heading(math.pi / 2 - 0.5)  # corrected heading: pi/2
    core.add_odometry(odom_at(0.0, 0.0, math.pi))
    assert core.compute_transform()
    assert core.transform is not None
    assert core.transform.yaw == pytest.approx(math.pi / 2, abs=1e-12)
    core.add_fix(fix_at(10.0, 0.0))  # 10 m east -> world +y
    out = core.gps_odometry()
    assert out is not None
    assert (out.pose.pose.position.x, out.pose.pose.position.y) == \
        pytest.approx((0.0, 10.0), abs=1e-6)
    cov = out.pose.covariance
    assert np.allclose(cov[:3, :3], np.diag([1.0, 4.0, 9.0]), atol=1e-12)
    assert cov[5, 5] == 1e6


def test_antenna_offset_is_removed() -> None:
    core = NavsatTransform(local_params())
    # robot at the world origin facing ENU north; antenna 1 m ahead of base_link
    core.add_fix(fix_at(0.0, 1.0), antenna=(1.0, 0.0, 0.5))
    core.add_heading(math.pi / 2)
    core.add_odometry(odom_at(0.0, 0.0, 0.0))
    core.compute_transform()
    # drive 5 m north; the antenna is then at ENU (0, 6)
    core.add_fix(fix_at(0.0, 6.0), antenna=(1.0, 0.0, 0.5))
    core.add_odometry(odom_at(5.0, 0.0, 0.0))
    out = core.gps_odometry()
    assert out is not None
    assert (out.pose.pose.position.x, out.pose.pose.position.y) == \
        pytest.approx((5.0, 0.0), abs=1e-6)


def test_utm_mode_adds_meridian_convergence_and_keeps_the_zone() -> None:
    core = NavsatTransform(NavsatTransformParams())
    core.add_fix(fix_at(0.0, 0.0, u=0.0))
    core.add_heading(math.pi / 2)  # facing true north
    core.add_odometry(odom_at(0.0, 0.0, 0.0))
    core.compute_transform()
    gamma = geodetic_to_utm(LAT0, LON0).convergence
    assert core.convergence == pytest.approx(gamma, abs=1e-15) and gamma != 0.0
    core.add_fix(fix_at(0.0, 100.0, u=0.0))  # 100 m true north = straight ahead
    out = core.gps_odometry()
    assert out is not None
    p = out.pose.pose.position
    assert math.atan2(p.y, p.x) == pytest.approx(0.0, abs=2e-6)
    scale = geodetic_to_utm(LAT0, LON0).scale
    assert math.hypot(p.x, p.y) == pytest.approx(100.0 * scale, abs=1e-3)


def test_manual_datum_places_the_world_origin() -> None:
    lat, lon, _ = ENU.reverse(0.0, 0.0, 0.0)
    core = NavsatTransform(local_params(wait_for_datum=True, datum=(lat, lon, math.pi / 2)))
    assert core.transform_good
    core.add_fix(fix_at(10.0, 0.0))
    core.add_odometry(odom_at(0.0, 0.0, 0.0))
    out = core.gps_odometry()
    assert out is not None
    # world x points north, so 10 m east is world -y
    assert (out.pose.pose.position.x, out.pose.pose.position.y) == \
        pytest.approx((0.0, -10.0), abs=1e-6)


def test_wait_for_datum_needs_a_datum() -> None:
    with pytest.raises(ConfigError, match=r"Value error, wait_for_datum is true but datum is "
                                          r"not set; give datum: \[latitude_deg, "
                                          r"longitude_deg, yaw_rad\]"):
        NavsatTransformParams.from_mapping({"wait_for_datum": True})


def test_filtered_gps_round_trips_and_zero_altitude() -> None:
    core = NavsatTransform(local_params(zero_altitude=True))
    core.add_fix(fix_at(0.0, 0.0))
    core.add_heading(0.4)
    core.add_odometry(odom_at(2.0, 3.0, 1.1))
    core.compute_transform()
    target = fix_at(7.0, -2.0)
    x, y, _ = core.world_from_ll(target.latitude, target.longitude, target.altitude)
    cov = np.diag([0.25, 1.0, 4.0, 0.0, 0.0, 0.0])
    core.add_odometry(odom_at(x, y, 0.0, t=2.0, cov=cov))
    out = core.filtered_gps()
    assert out is not None
    assert out.latitude == pytest.approx(target.latitude, abs=1e-10)
    assert out.longitude == pytest.approx(target.longitude, abs=1e-10)
    yaw = core.transform.yaw if core.transform else 0.0
    c, s = math.cos(-yaw), math.sin(-yaw)
    r = np.array([[c, -s], [s, c]])
    assert np.allclose(out.position_covariance[:2, :2], r @ np.diag([0.25, 1.0]) @ r.T)
    assert out.status.status == 2 and out.position_covariance_type == 3
    core.add_fix(fix_at(0.0, 0.0, u=ALT0 + 50.0))
    assert core.gps_odometry() is None  # needs odometry newer than the last /gps/filtered
    core.add_odometry(odom_at(x, y, 0.0, t=3.0))
    gps = core.gps_odometry()
    assert gps is not None and gps.pose.pose.position.z == 0.0


def test_unusable_fixes_are_rejected_and_counted() -> None:
    core = NavsatTransform(local_params())
    assert not core.add_fix(fix_at(0.0, 0.0, t=1.5, status=NavSatStatus.STATUS_NO_FIX))
    nan = NavSatFix(Header(2.0, "gps"), NavSatStatus(0, 1), math.nan, 1.0, 0.0, COV, 2)
    assert not core.add_fix(nan)
    assert not core.add_fix(fix_at(0.0, 0.0, t=3.0, cov_type=0))
    assert not core.add_fix(fix_at(0.0, 0.0, t=4.0, cov_type=0))
    assert core.rejections == {"no_fix": 1, "non_finite": 1, "unknown_covariance": 2}
    assert core.last_rejection == ("rejected fix at t=4.000 s: position_covariance_type is "
                                   "COVARIANCE_TYPE_UNKNOWN; configure the receiver driver to "
                                   "report its covariance")
    assert core.latest_cart is None
    with pytest.raises(TransformError, match="navsat transform not computed yet"):
        core.world_from_ll(LAT0, LON0, 0.0)
