"""WGS84 conversions against documented values and exact identities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.geo.conversions import (
    UTM_K0,
    WGS84_A,
    WGS84_F,
    GeoError,
    LocalCartesian,
    bearing_to_yaw,
    ecef_to_geodetic,
    geodesic_direct,
    geodesic_inverse,
    geodetic_to_ecef,
    geodetic_to_enu,
    geodetic_to_utm,
    utm_forward,
    utm_to_geodetic,
    utm_zone,
    yaw_to_bearing,
)


def test_utm_matches_the_geoconvert_manual_example() -> None:
    # GeographicLib GeoConvert(1): "33.3 44.4" is "38n 444140.54 3684706.36"
    u = geodetic_to_utm(33.3, 44.4)
    assert (u.zone, u.northp) == (38, True)
    assert u.easting == pytest.approx(444140.54, abs=0.006)
    assert u.northing == pytest.approx(3684706.36, abs=0.006)


def test_utm_on_the_central_meridian_at_the_equator_is_the_false_origin() -> None:
    u = geodetic_to_utm(0.0, 45.0)
    assert (u.zone, u.easting, u.northing, u.convergence) == (38, 500000.0, 0.0, 0.0)
    assert u.scale == pytest.approx(UTM_K0, abs=1e-15)


def test_southern_hemisphere_mirrors_with_the_false_northing() -> None:
    n, s = geodetic_to_utm(33.9, 18.4), geodetic_to_utm(-33.9, 18.4)
    assert not s.northp and s.zone == n.zone == 34
    assert s.easting == pytest.approx(n.easting, abs=1e-6)
    assert s.northing == pytest.approx(10_000_000.0 - n.northing, abs=1e-6)
    assert s.convergence == pytest.approx(-n.convergence, abs=1e-15)


def test_zone_selection_including_norway_and_svalbard() -> None:
    assert utm_zone(0.0, -180.0) == 1
    assert utm_zone(0.0, 179.99) == 60
    assert utm_zone(47.37, 8.54) == 32
    assert utm_zone(60.0, 5.0) == 32          # Norway exception (would be 31)
    assert utm_zone(78.0, 8.0) == 31          # Svalbard
    assert utm_zone(78.0, 10.0) == 33
    assert utm_zone(78.0, 25.0) == 35
    assert utm_zone(78.0, 40.0) == 37
    with pytest.raises(GeoError, match=r"latitude 85.0 is outside the UTM band \[-80, 84\]; "
                                       "use UPS or a LocalCartesian"):
        utm_zone(85.0, 0.0)


def test_utm_round_trip_to_a_nanodegree() -> None:
    rng = np.random.default_rng(0)
    lat = rng.uniform(-79.9, 83.9, 2000)
    zone = rng.integers(1, 61, 2000)
    lon = (6.0 * zone - 183.0) + rng.uniform(-3.0, 3.0, 2000)
    for z in np.unique(zone)[:20]:
        m = zone == z
        for northp in (True, False):
            mm = m & ((lat >= 0) == northp)
            if not mm.any():
                continue
            e, n, _, _ = utm_forward(lat[mm], lon[mm], int(z), northp)
            lat2, lon2 = utm_to_geodetic(e, n, int(z), northp)
            assert np.max(np.abs(lat2 - lat[mm])) < 1e-9
            assert np.max(np.abs((lon2 - lon[mm] + 180.0) % 360.0 - 180.0)) < 1e-9


def test_convergence_and_scale_agree_with_finite_differences() -> None:
    lat, lon, d = 47.3, 10.7, 1e-6
    u = geodetic_to_utm(lat, lon)
    north = geodetic_to_utm(lat + d, lon, zone=u.zone)
    # true north seen from the grid is at bearing -gamma
    assert -math.atan2(north.easting - u.easting, north.northing - u.northing) == \
        pytest.approx(u.convergence, abs=1e-9)
    east = geodetic_to_utm(lat, lon + d, zone=u.zone)
    grid_len = math.hypot(east.easting - u.easting, east.northing - u.northing)
    assert grid_len / geodesic_inverse(lat, lon, lat, lon + d).distance == \
        pytest.approx(u.scale, abs=1e-8)


def test_ecef_axes_and_round_trip() -> None:
    assert geodetic_to_ecef(0.0, 0.0, 0.0) == (WGS84_A, 0.0, 0.0)
    x, y, z = geodetic_to_ecef(90.0, 0.0, 0.0)
    assert abs(x) < 1e-9 and y == 0.0 and z == pytest.approx(WGS84_A * (1 - WGS84_F), abs=1e-9)
    rng = np.random.default_rng(1)
    lat = rng.uniform(-89.99, 89.99, 5000)
    lon = rng.uniform(-180.0, 180.0, 5000)
    alt = rng.uniform(-500.0, 2.0e7, 5000)
    lat2, lon2, alt2 = ecef_to_geodetic(*geodetic_to_ecef(lat, lon, alt))
    assert np.max(np.abs(lat2 - lat)) < 1e-9
    assert np.max(np.abs(lon2 - lon)) < 1e-9
    assert np.max(np.abs(alt2 - alt)) < 1e-6


def test_local_cartesian_matches_the_cartconvert_manual_example() -> None:
    # GeographicLib CartConvert(1): "33.3 44.4 6000" with -l 33 44 20
    e, n, u = LocalCartesian(33.0, 44.0, 20.0).forward(33.3, 44.4, 6000.0)
    assert (e, n, u) == pytest.approx((37288.97, 33374.29, 5783.64), abs=0.01)


def test_enu_agrees_with_the_geodesic_and_round_trips() -> None:
    lat0, lon0 = 38.406415, -110.791924
    lat, lon, _ = geodesic_direct(lat0, lon0, 0.0, 100.0)  # 100 m due north on the ellipsoid
    e, n, u = geodetic_to_enu(lat, lon, 0.0, lat0, lon0, 0.0)
    assert abs(e) < 1e-9 and n == pytest.approx(100.0, abs=1e-6)
    assert u == pytest.approx(-100.0 ** 2 / (2 * 6.37e6), rel=0.01)  # Earth curvature drop
    lc = LocalCartesian(lat0, lon0, 1380.0)
    rng = np.random.default_rng(2)
    pts = rng.uniform(-5000.0, 5000.0, (1000, 3))
    back = lc.forward(*lc.reverse(pts[:, 0], pts[:, 1], pts[:, 2]))
    assert np.max(np.abs(np.column_stack(back) - pts)) < 1e-6
    assert lc.forward(lat0, lon0, 1380.0) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)


def test_geodesic_matches_the_geographiclib_example() -> None:
    # Wellington, NZ to Salamanca, Spain (geographiclib documentation)
    g = geodesic_inverse(-41.32, 174.81, 40.96, -5.50)
    assert g.distance == pytest.approx(19959679.267353, abs=1e-5)
    assert g.azimuth1 == pytest.approx(161.067669986160, abs=1e-9)
    assert g.azimuth2 == pytest.approx(18.825195123247, abs=1e-9)


def test_bearing_yaw_conversions() -> None:
    assert bearing_to_yaw(0.0) == pytest.approx(math.pi / 2)
    assert bearing_to_yaw(math.pi / 2) == pytest.approx(0.0)
    assert bearing_to_yaw(math.pi) == pytest.approx(-math.pi / 2)
    assert yaw_to_bearing(0.0) == pytest.approx(math.pi / 2)
    assert yaw_to_bearing(-math.pi / 2) == pytest.approx(math.pi)
    b = np.array([0.1, 2.0, 4.0, 6.0])
    assert np.allclose(yaw_to_bearing(bearing_to_yaw(b)), b)


def test_out_of_range_latitude_is_named() -> None:
    with pytest.raises(GeoError, match=r"latitude must be within \[-90, 90\] degrees, got "
                                       r"91.0; check that latitude and longitude are not "
                                       "swapped"):
        geodetic_to_ecef(91.0, 0.0, 0.0)
