"""followGpsWaypoints (issue 20, acceptance 4): five lat/lon points in a world rotated
0.35 rad against east-north, each reached within 3 m of its true position; the YAML form
and the errors that name the waypoint."""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Odometry
from navstack.geo.conversions import GeoError
from navstack.geo.gps_goal import parse_coordinate
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.geo_frame import GeoFrame
from navstack.interfaces.gps_waypoints import (
    gps_waypoints_in_map,
    load_gps_waypoints,
)
from navstack.interfaces.stack import NavStack
from navstack.sim.course import ll_to_world, load_course, world_to_ll
from navstack.sim.robot import GeoReferenceParams, load_robot
from navstack.sim.world_io import world_from_mapping

YAW = 0.35
GEO = GeoReferenceParams(world_yaw=YAW)
# an open 36 m yard with three rocks between the points
TARGETS = [(12.0, 6.0), (20.0, 12.0), (26.0, 20.0), (18.0, 26.0), (10.0, 20.0)]


def _stack() -> NavStack:
    world = world_from_mapping({
        "name": "gps_yard", "resolution": 0.1, "size": [36.0, 36.0],
        "circles": [{"center": [17.0, 6.0], "radius": 0.8},
                    {"center": [24.0, 14.0], "radius": 0.6},
                    {"center": [16.0, 20.0], "radius": 1.0}],
        "spawn": {"x": 5.0, "y": 5.0, "yaw": 0.0}})
    robot = load_robot("rover", {"sensors": {"georeference": GEO.model_dump()}})
    params = str(resources.files("navstack") / "config" / "rover_nav2_params.yaml")
    return NavStack(world, robot, params, seed=3)


def test_five_gps_waypoints_in_a_rotated_world_are_each_reached_within_3_m() -> None:
    stack = _stack()
    nav = Navigator(stack)
    truth: list[tuple[float, float]] = []
    stack.runtime.bus.subscribe("/ground_truth", Odometry, lambda msg: truth.append(
        (msg.pose.pose.position.x, msg.pose.pose.position.y)))
    points = [world_to_ll(GEO, x, y) for x, y in TARGETS]
    assert nav.followGpsWaypoints(points), nav.last_error
    while not nav.isTaskComplete():
        assert stack.now < 240.0, "GPS waypoints not done in 240 s"
    assert nav.getResult() is TaskResult.SUCCEEDED
    assert nav.getFeedback() is not None
    for x, y in TARGETS:
        closest = min(math.hypot(px - x, py - y) for px, py in truth)
        assert closest <= 3.0, f"waypoint ({x}, {y}) passed {closest:.2f} m away"
    assert stack.sim.sim.collisions == 0


def test_the_map_rotation_is_applied_to_points_and_headings() -> None:
    frame = GeoFrame.from_datum(GEO.latitude, GEO.longitude, YAW)
    lat, lon = world_to_ll(GEO, 20.0, 12.0)
    # yaw pi/2 in ENU (north) is pi/2 - 0.35 in the rotated map
    lat2, lon2 = world_to_ll(GEO, 26.0, 20.0)
    poses = gps_waypoints_in_map(frame, [(lat, lon, math.pi / 2), (lat2, lon2)], (0.0, 0.0))
    p = poses[0].to_pose2d()
    assert p.x == pytest.approx(20.0, abs=0.01) and p.y == pytest.approx(12.0, abs=0.01)
    assert p.theta == pytest.approx(math.pi / 2 - YAW, abs=1e-6)
    # dropping the rotation (the Nav2 bug) would put this point 7.9 m away
    unrotated = GeoFrame.from_datum(GEO.latitude, GEO.longitude, 0.0).to_map(lat, lon)
    assert math.hypot(unrotated[0] - 20.0, unrotated[1] - 12.0) > 7.0
    # without a yaw a waypoint faces away from the previous point
    assert poses[1].to_pose2d().theta == pytest.approx(math.atan2(8.0, 6.0), abs=1e-3)


def test_course_gps_waypoints_land_where_the_course_says() -> None:
    course = load_course()
    frame = GeoFrame.from_datum(course.georeference.latitude, course.georeference.longitude,
                                course.georeference.world_yaw)
    poses = gps_waypoints_in_map(frame, course.gps_waypoints)
    expected = [(30.0, 12.0), (45.0, 35.0), (55.0, 50.0), (75.0, 40.0), (85.0, 20.0)]
    for pose, (x, y) in zip(poses, expected, strict=True):
        assert pose.pose.position.x == pytest.approx(x, abs=0.05)  # datum altitude 0 vs 1380 m
        assert pose.pose.position.y == pytest.approx(y, abs=0.05)
    # the legs' coordinates (D,M,S strings and decimals) land on the places the YAML says
    legs = {"gnss_1": (30.0, 15.0), "gnss_2": (38.0, 30.0), "post_1": (60.0, 85.0),
            "post_2": (35.0, 65.0), "gate_a": (52.0, 55.0)}
    for name, (x, y) in legs.items():
        leg = course.leg(name)
        lat = parse_coordinate(leg.latitude, kind="latitude")
        lon = parse_coordinate(leg.longitude, kind="longitude")
        assert ll_to_world(course.georeference, lat, lon) == pytest.approx((x, y), abs=0.01)


def test_yaml_gps_waypoints_and_errors_naming_the_waypoint(tmp_path: Path) -> None:
    good = tmp_path / "gps.yaml"
    good.write_text("waypoints:\n  - {latitude: 38.4066, longitude: -110.7916}\n"
                    "  - {latitude: '38,24,25.2', longitude: '-110,47,29.5', yaw: 1.57}\n")
    points = load_gps_waypoints(good)
    assert points[0].yaw is None and points[1].yaw == 1.57
    assert points[1].latitude == pytest.approx(38 + 24 / 60 + 25.2 / 3600, abs=1e-9)
    assert points[1].longitude == pytest.approx(-(110 + 47 / 60 + 29.5 / 3600), abs=1e-9)
    bad = tmp_path / "bad.yaml"
    bad.write_text("waypoints:\n  - {latitude: 38.4, longitude: -110.8}\n"
                   "  - {latitude: '38;24;25', longitude: -110.8}\n")
    with pytest.raises(ConfigError, match=r"bad\.yaml: waypoints\[1\]\.latitude: '38;24;25' "
                                          r"is not a latitude"):
        load_gps_waypoints(bad)
    empty = tmp_path / "empty.yaml"
    empty.write_text("points: []\n")
    with pytest.raises(ConfigError, match="needs a non-empty 'waypoints' list"):
        load_gps_waypoints(empty)
    frame = GeoFrame.from_datum(GEO.latitude, GEO.longitude, YAW)
    with pytest.raises(GeoError, match=r"waypoints\[0\]\.yaw: 'north' is not a heading"):
        gps_waypoints_in_map(frame, [{"latitude": 38.4, "longitude": -110.8, "yaw": "north"}])


def test_navigator_refuses_a_bad_gps_waypoint_naming_it() -> None:
    nav = Navigator(_stack())
    assert not nav.followGpsWaypoints([(38.4064, -110.7919), (95.0, -110.79)])
    assert "waypoints[1].latitude: 95.0 is outside the latitude range" in nav.last_error
    assert nav.getResult() is TaskResult.UNKNOWN
