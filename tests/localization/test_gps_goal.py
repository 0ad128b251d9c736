"""GPS goals: the rover's coordinate strings exact to 1e-9 degrees, clear errors naming the
field, and goal placement in odom against the simulator's GNSS truth (an exact local ENU
frame, a world rotated against east-north)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.geo.conversions import GeoError, LocalCartesian, yaw_to_bearing
from navstack.geo.gps_goal import (
    FixGoalFilter,
    LocalOrigin,
    course_over_ground,
    format_dms,
    gps_goal_in_odom,
    odom_axis_course,
    parse_coordinate,
)
from navstack.sim.gnss import world_to_enu
from navstack.sim.robot import GeoReferenceParams


@pytest.mark.parametrize(("text", "kind", "expected"), [
    ("43,39,31", "latitude", 43 + 39 / 60 + 31 / 3600),          # FIELD-ROBOTS example
    ("-79,22,45", "longitude", -(79 + 22 / 60 + 45 / 3600)),      # = -79.379167
    ("-0,30,0", "latitude", -0.5),                                # minus on a zero degree
    ("38,24,23.094", "latitude", 38 + 24 / 60 + 23.094 / 3600),
    (" 110 , 47 , 30.9 ", "longitude", 110 + 47 / 60 + 30.9 / 3600),
    ("+12,0,0", "latitude", 12.0),
    ("43.658611", "latitude", 43.658611),
    ("-110.791924", "longitude", -110.791924),
    ("1e1", "latitude", 10.0),
    (-79.379167, "longitude", -79.379167),
    (0, "latitude", 0.0),
])
def test_rover_coordinates_parse_exactly(text: str | float, kind: str, expected: float) -> None:
    assert abs(parse_coordinate(text, "goal.lat", kind) - expected) <= 1e-9


def test_rover_minus_negates_the_whole_value() -> None:
    assert parse_coordinate("-79,22,45", kind="longitude") == pytest.approx(-79.379167, abs=5e-7)
    assert parse_coordinate("-79,22,45", kind="longitude") != -79 + 22 / 60 + 45 / 3600


@pytest.mark.parametrize(("text", "kind", "message"), [
    ("43;39;31", "latitude", "legs[1].latitude: '43;39;31' is not a latitude; give decimal"),
    ("43,39", "latitude", "legs[1].latitude: '43,39' is not a latitude"),
    ("43,61,0", "latitude", "has minutes or seconds >= 60"),
    ("43,10,60", "latitude", "has minutes or seconds >= 60"),
    ("43.5,10,0", "latitude", "has fractional degrees"),
    ("91,0,0", "latitude", "legs[1].latitude: '91,0,0' is outside the latitude range [-90, 90]"),
    ("-181", "longitude", "outside the longitude range [-180, 180]"),
    ("", "latitude", "'' is not a latitude"),
    ("nan", "latitude", "'nan' is not a latitude"),
    (float("nan"), "latitude", "outside the latitude range"),
    (True, "latitude", "True is not a latitude"),
])
def test_bad_coordinates_name_the_field(text: object, kind: str, message: str) -> None:
    with pytest.raises(GeoError) as err:
        parse_coordinate(text, "legs[1].latitude", kind)  # type: ignore[arg-type]
    assert message in str(err.value)
    assert "legs[1].latitude" in str(err.value)


def test_dms_round_trips() -> None:
    for value in (43.658611, -79.379167, 0.25, -0.0001):
        assert abs(parse_coordinate(format_dms(value)) - value) <= 1e-7


def _world_ll(geo: GeoReferenceParams, x: float, y: float) -> tuple[float, float]:
    """The simulator's GNSS truth: world (x, y) -> lat/lon through its exact local ENU."""
    e, n = world_to_enu(x, y, geo.world_yaw)
    lat, lon, _ = LocalCartesian(geo.latitude, geo.longitude, geo.altitude).reverse(
        e, n, 0.0)
    return lat, lon


@pytest.mark.parametrize("world_yaw", [0.0, 0.35])
@pytest.mark.parametrize(("start", "target"), [
    ((0.0, 0.0, 0.0), (40.0, 0.0)),
    ((-12.0, 7.0, 1.1), (45.0, -38.0)),
    ((30.0, -20.0, -2.6), (-48.0, 44.0)),
    ((5.0, 5.0, math.pi), (5.5, 4.0)),
])
def test_goal_lands_on_the_target_in_odom(world_yaw: float, start: tuple[float, float, float],
                                          target: tuple[float, float]) -> None:
    geo = GeoReferenceParams(world_yaw=world_yaw)
    x0, y0, th0 = start
    lat0, lon0 = _world_ll(geo, x0, y0)
    course = math.degrees(yaw_to_bearing(th0 + world_yaw))  # exact heading calibration
    lat, lon = _world_ll(geo, *target)
    goal = gps_goal_in_odom(LocalOrigin(lat0, lon0, course), lat, lon)
    # odom -> world through the start pose
    gx = x0 + math.cos(th0) * goal.x - math.sin(th0) * goal.y
    gy = y0 + math.sin(th0) * goal.x + math.cos(th0) * goal.y
    assert math.hypot(gx - target[0], gy - target[1]) <= 0.05
    facing = math.atan2(target[1] - y0, target[0] - x0)
    assert abs(math.remainder(goal.yaw + th0 - facing, 2 * math.pi)) <= 1e-3
    assert goal.distance == pytest.approx(math.hypot(target[0] - x0, target[1] - y0), abs=0.05)


def test_goal_faces_the_target_from_the_robot() -> None:
    origin = LocalOrigin(38.4, -110.8, 0.0)  # odom x points north
    lat, lon = LocalCartesian(38.4, -110.8, 0.0).reverse(0.0, 10.0, 0.0)[:2]
    goal = gps_goal_in_odom(origin, lat, lon, robot_xy=(10.0, 10.0))
    assert goal.x == pytest.approx(10.0, abs=1e-6) and goal.y == pytest.approx(0.0, abs=1e-6)
    assert goal.yaw == pytest.approx(-math.pi / 2, abs=1e-6)
    with pytest.raises(GeoError, match=r"origin\.latitude"):
        LocalOrigin(95.0, 0.0, 0.0)


def test_course_over_ground_is_a_circular_mean_of_fast_samples() -> None:
    # 359 and 1 degrees average to 0; the slow start-up samples are left out
    east = [math.sin(math.radians(a)) * 1.5 for a in (359.0, 1.0)] + [0.2]
    north = [math.cos(math.radians(a)) * 1.5 for a in (359.0, 1.0)] + [-0.1]
    assert abs(math.remainder(course_over_ground(east, north, 0.5), 360.0)) < 1e-9
    assert course_over_ground([1.0, 1.0], [0.0, 1e-3]) == pytest.approx(89.97, abs=0.01)
    with pytest.raises(GeoError, match=r"none of 2 GNSS velocity samples reached 0\.5 m/s"):
        course_over_ground([0.1, 0.0], [0.0, 0.2], 0.5)


def test_odom_axis_course_adds_the_odom_yaw() -> None:
    # a rover heading north-east (bearing 45) at odom yaw +0.5 rad: odom x points
    # 45 + 28.65 degrees
    assert odom_axis_course(45.0, 0.5) == pytest.approx(45.0 + math.degrees(0.5))
    assert odom_axis_course(350.0, math.radians(20.0)) == pytest.approx(10.0)


def test_fix_goal_filter_averages_the_per_fix_goal() -> None:
    geo = GeoReferenceParams(world_yaw=0.35)
    goal_ll = _world_ll(geo, 20.0, 10.0)
    course = math.degrees(yaw_to_bearing(0.35))  # odom = world here
    flt = FixGoalFilter(*goal_ll, course, window=10.0)
    rng = np.random.default_rng(1)
    for k in range(50):  # 10 s at 5 Hz, 2 m noise per axis, robot parked at (3, 4)
        nx, ny = rng.normal(0.0, 2.0, 2)
        lat, lon = _world_ll(geo, 3.0 + nx, 4.0 + ny)
        gx, gy = flt.add_fix(0.2 * k, lat, lon, 3.0, 4.0)
    assert flt.fixes == 50
    assert math.hypot(gx - 20.0, gy - 10.0) < 0.7  # 2 m / sqrt(50) = 0.28 m per axis
    flt.add_fix(30.0, *_world_ll(geo, 3.0, 4.0), 3.0, 4.0)  # the window forgets old fixes
    assert flt.fixes == 1
    assert flt.goal() == pytest.approx((20.0, 10.0), abs=0.01)
    with pytest.raises(GeoError, match="no GNSS fix yet"):
        FixGoalFilter(*goal_ll, course).goal()
