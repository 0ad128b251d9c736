"""Collision monitor zones (Nav2 nav2_collision_monitor): stop, slowdown, limit, approach."""

import numpy as np
import pytest

from navstack.control.collision_monitor import (
    ActionType,
    CollisionMonitor,
    PolygonParams,
    ZonePolygon,
    collision_monitor_params,
)
from navstack.core.errors import ConfigError
from navstack.core.msgs import Twist2D
from navstack.core.polygon import Footprint

BODY = Footprint.from_radius(0.2).polygon
BOX = [[0.5, 0.3], [0.5, -0.3], [0.0, -0.3], [0.0, 0.3]]


def approach(tbc: float = 1.2, min_points: int = 1) -> ZonePolygon:
    return ZonePolygon("FootprintApproach", PolygonParams(
        type="polygon", action_type="approach", footprint_topic="/footprint",
        time_before_collision=tbc, simulation_time_step=0.1, min_points=min_points), BODY)


def monitor(**sections: dict[str, object]) -> CollisionMonitor:
    params = collision_monitor_params({"polygons": list(sections), **sections})
    return CollisionMonitor(params, BODY)


def cluster(x: float, y: float, n: int = 5) -> np.ndarray:
    return np.column_stack((np.full(n, x), np.linspace(y - 0.02, y + 0.02, n)))


def test_clear_path_keeps_the_command() -> None:
    zone = approach()
    pts = np.array([[0.0, 1.0], [-1.0, 0.0]])  # beside and behind
    assert zone.safe_velocity(Twist2D(0.5, 0.0, 0.0), pts) is None


def test_approach_scales_by_time_to_contact() -> None:
    zone = approach()
    pts = np.array([[0.6, 0.0]])  # contact after driving ~0.4 m: in the step ending 0.8 s
    assert zone.collision_time(Twist2D(0.5, 0.0, 0.0), pts) == pytest.approx(0.7)
    out = zone.safe_velocity(Twist2D(0.5, 0.0, 0.0), pts)
    assert out is not None and out.vx == pytest.approx(0.5 * 0.7 / 1.2)  # one step short


def test_touching_obstacle_stops_and_moving_away_is_allowed() -> None:
    zone = approach()
    pts = np.array([[0.21, 0.0]])  # inside the body after the first 0.1 s step
    out = zone.safe_velocity(Twist2D(0.3, 0.0, 0.0), pts)
    assert out == Twist2D()
    assert zone.safe_velocity(Twist2D(-0.2, 0.0, 0.0), pts) is None


def test_a_point_already_inside_stops_only_motion_that_takes_it_deeper() -> None:
    # a zone padded to 0.35 m around the body; a door frame 0.3 m to the left is inside
    zone = ZonePolygon("Approach", PolygonParams(
        type="circle", radius=0.35, action_type="approach", time_before_collision=1.2,
        simulation_time_step=0.1, min_points=1))
    beside = np.array([[0.0, 0.3]])
    assert zone.safe_velocity(Twist2D(0.3, 0.0, 0.0), beside) is None  # along it
    assert zone.safe_velocity(Twist2D(0.3, 0.0, 0.8), beside) is None  # arcs around it
    ahead_left = np.array([[0.15, 0.26]])  # 0.3 m away, 60 degrees left
    assert zone.safe_velocity(Twist2D(0.0, 0.0, 0.8), ahead_left) is None  # turning: same
    assert zone.safe_velocity(Twist2D(0.3, 0.0, 0.0), ahead_left) == Twist2D()  # closer
    assert zone.safe_velocity(Twist2D(-0.2, 0.0, 0.0), ahead_left) is None  # away
    # a wall ahead, already inside: driving at it stops, backing away does not
    ahead = cluster(0.3, 0.0)
    assert zone.safe_velocity(Twist2D(0.2, 0.0, 0.0), ahead) == Twist2D()
    assert zone.safe_velocity(Twist2D(-0.2, 0.0, 0.0), ahead) is None
    # a polygon zone measures depth to its outline
    square = ZonePolygon("Square", PolygonParams(
        type="polygon", points=[[0.4, 0.4], [0.4, -0.4], [-0.4, -0.4], [-0.4, 0.4]],
        action_type="approach", time_before_collision=1.0, min_points=1))
    np.testing.assert_allclose(square.depth(np.array([[0.3, 0.0], [0.0, 0.1], [0.5, 0.0]])),
                               [0.1, 0.3, 0.0])
    side = np.array([[0.0, 0.35]])  # 0.05 m deep on the left
    assert square.safe_velocity(Twist2D(0.3, 0.0, 0.0), side) is None  # along it


def test_arc_motion_is_simulated_exactly() -> None:
    zone = approach(tbc=2.0)
    # (1, 1) lies on the 1 m radius left arc: reached at a quarter turn, t = pi/2,
    # less the body's ~0.2 m (0.2 rad of arc at 1 rad/s)
    pts = np.array([[1.0, 1.0]])
    assert zone.collision_time(Twist2D(0.5, 0.0, 0.0), pts) is None
    assert zone.collision_time(Twist2D(1.0, 0.0, 1.0), pts) == pytest.approx(1.3)


def test_stop_polygon_gives_zero_with_min_points() -> None:
    mon = monitor(PolygonStop={"type": "polygon", "points": BOX, "action_type": "stop",
                               "min_points": 4})
    cmd = Twist2D(0.4, 0.0, 0.3)
    assert mon.process(cmd, cluster(0.4, 0.0, 3)).action is ActionType.DO_NOTHING
    res = mon.process(cmd, cluster(0.4, 0.0, 4))
    assert (res.cmd, res.action, res.polygon) == (Twist2D(), ActionType.STOP, "PolygonStop")


def test_slowdown_is_exactly_the_ratio_times_the_command() -> None:
    mon = monitor(PolygonSlow={"type": "circle", "radius": 0.8, "action_type": "slowdown",
                               "slowdown_ratio": 0.3})
    cmd = Twist2D(0.45, 0.05, -0.7)
    res = mon.process(cmd, cluster(0.0, 0.7))
    assert res.action is ActionType.SLOWDOWN
    assert res.cmd == Twist2D(0.45 * 0.3, 0.05 * 0.3, -0.7 * 0.3)
    assert mon.process(cmd, cluster(0.0, 0.9)).cmd == cmd  # outside the circle


def test_limit_caps_linear_and_angular_speed() -> None:
    mon = monitor(PolygonLimit={"type": "polygon", "points": BOX, "action_type": "limit",
                                "linear_limit": 0.2, "angular_limit": 0.4})
    res = mon.process(Twist2D(0.3, 0.4, 1.0), cluster(0.3, 0.0))
    assert res.action is ActionType.LIMIT
    assert res.cmd.vx == pytest.approx(0.12) and res.cmd.vy == pytest.approx(0.16)
    assert res.cmd.wz == 0.4
    assert mon.process(Twist2D(0.1, 0.0, -0.2), cluster(0.3, 0.0)).cmd == Twist2D(0.1, 0, -0.2)


def test_most_restrictive_zone_wins_and_stop_ends_evaluation() -> None:
    mon = monitor(
        PolygonSlow={"type": "circle", "radius": 1.0, "action_type": "slowdown",
                     "slowdown_ratio": 0.5},
        PolygonLimit={"type": "circle", "radius": 1.0, "action_type": "limit",
                      "linear_limit": 0.1, "angular_limit": 1.0},
        PolygonStop={"type": "polygon", "points": BOX, "action_type": "stop"},
        Disabled={"type": "circle", "radius": 2.0, "action_type": "stop", "enabled": False})
    res = mon.process(Twist2D(0.5, 0.0, 0.0), cluster(0.8, 0.0))
    assert (res.action, res.polygon) == (ActionType.LIMIT, "PolygonLimit")
    assert res.cmd.vx == pytest.approx(0.1)
    res = mon.process(Twist2D(0.5, 0.0, 0.0), cluster(0.3, 0.0))
    assert (res.action, res.polygon, res.cmd) == (ActionType.STOP, "PolygonStop", Twist2D())
    stale = mon.process(Twist2D(0.5, 0.0, 0.0), np.zeros((0, 2)), "scan (stale source)")
    assert (stale.action, stale.polygon, stale.cmd) == (ActionType.STOP,
                                                        "scan (stale source)", Twist2D())


@pytest.mark.parametrize(("section", "message"), [
    ({"polygons": ["P"]}, r"collision_monitor.P: polygon 'P' has no section"),
    ({"polygons": ["P"], "P": {"type": "circle", "action_type": "stop"}},
     r"collision_monitor.P: Value error, a circle needs 'radius'"),
    ({"polygons": ["P"], "P": {"type": "polygon", "action_type": "stop",
                               "points": [[0, 0], [1, 0]]}},
     r"a polygon needs at least 3 points, got 2"),
    ({"polygons": ["P"], "P": {"type": "circle", "radius": 1.0, "action_type": "halt"}},
     r"collision_monitor.P.action_type: Input should be 'stop', 'slowdown', 'limit' or "
     r"'approach'"),
    ({"observation_sources": ["scan"], "scan": {"type": "lidar", "topic": "/scan"}},
     r"collision_monitor.scan.type: Input should be 'scan', 'pointcloud' or 'range'"),
    ({"polygons": "P"}, r"collision_monitor.polygons: must be a list of section names"),
    ({"stop_pub_timout": 1.0}, r"stop_pub_timout: unknown key \(did you mean "
                               r"'stop_pub_timeout'\?\)"),
])
def test_bad_sections_name_the_key(section: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        collision_monitor_params(section, file="nav2.yaml")


def test_offset_polygon_moves_every_edge_out_by_the_padding() -> None:
    from navstack.control.collision_monitor import offset_polygon

    square = np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]])  # CCW
    assert np.allclose(offset_polygon(square, 0.1), square * 1.5)
    assert np.allclose(offset_polygon(square[::-1], 0.1), square[::-1] * 1.5)  # CW
    disc = offset_polygon(BODY, 0.12)  # the round body's polygon: edges 0.12 m further
    mid = (disc + np.roll(disc, -1, axis=0)) / 2.0
    body_mid = (BODY + np.roll(BODY, -1, axis=0)) / 2.0
    assert np.allclose(np.hypot(*mid.T) - np.hypot(*body_mid.T), 0.12)


def test_padded_footprint_zone_sees_only_its_sources() -> None:
    mon = CollisionMonitor(collision_monitor_params({
        "polygons": ["Body", "Moving"],
        "Body": {"type": "polygon", "action_type": "approach", "footprint_topic": "/fp",
                 "min_points": 1, "sources_names": ["walls"]},
        "Moving": {"type": "polygon", "action_type": "approach", "footprint_topic": "/fp",
                   "footprint_padding": 0.12, "min_points": 1, "sources_names": ["people"]},
        "observation_sources": ["walls", "people"],
        "walls": {"type": "scan", "topic": "/scan"},
        "people": {"type": "scan", "topic": "/scan", "exclude_map_obstacles": 0.15}}), BODY)
    cmd = Twist2D(0.3, 0.0, 0.0)
    near = np.array([[0.30, 0.0]])  # 0.10 m ahead of the 0.2 m body
    # a wall point 0.1 m ahead: only the body zone checks it -- reached after 0.33 s
    res = mon.process(cmd, {"walls": near, "people": np.zeros((0, 2))})
    assert res.action is ActionType.APPROACH and res.polygon == "Body"
    assert res.cmd.vx == pytest.approx(0.3 * 0.3 / 2.0)  # Jazzy default: 2 s
    # the same point as a person: already inside the padded zone, so driving on stops
    res = mon.process(cmd, {"walls": np.zeros((0, 2)), "people": near})
    assert res == type(res)(Twist2D(), ActionType.APPROACH, "Moving")
    # one array: every zone sees every point
    assert mon.process(cmd, near).polygon == "Moving"


def test_sources_names_and_padding_are_checked() -> None:
    with pytest.raises(ConfigError, match=r"Stop\.sources_names: unknown source 'lidar' "
                                          r"\(name sources listed in observation_sources: "
                                          r"\['scan'\]\)"):
        collision_monitor_params({"polygons": ["Stop"], "observation_sources": ["scan"],
                                  "Stop": {"type": "circle", "radius": 0.3,
                                           "action_type": "stop", "sources_names": ["lidar"]},
                                  "scan": {"type": "scan", "topic": "/scan"}})
    with pytest.raises(ConfigError, match="footprint_padding pads the robot's footprint"):
        PolygonParams.from_mapping({"type": "polygon", "action_type": "stop", "points": BOX,
                                    "footprint_padding": 0.1})
