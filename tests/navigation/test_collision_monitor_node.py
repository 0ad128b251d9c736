"""CollisionMonitorNode on a bare bus: one-cycle stop, exact slowdown, stale sources,
point cloud and range sources, state for the dashboard."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from navstack.control.collision_monitor import collision_monitor_params
from navstack.core.msgs import (
    CollisionMonitorState,
    Header,
    LaserScan,
    PointCloud,
    Pose2D,
    Range,
    Twist,
)
from navstack.core.polygon import Footprint
from navstack.navigation.collision_monitor_node import CollisionMonitorNode
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime

CYCLE = 0.05  # the controller's 20 Hz
BOX = [[0.6, 0.3], [0.6, -0.3], [0.0, -0.3], [0.0, 0.3]]


def scan_with_obstacle_at(x: float | None, stamp: float) -> LaserScan:
    """A 360-beam scan in base_link: free (inf) except a flat obstacle ahead at ``x``."""
    a = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    r = np.full(360, np.inf, dtype=np.float32)
    if x is not None:
        ahead = np.abs(a) < 0.3
        r[ahead] = (x / np.cos(a[ahead])).astype(np.float32)
    return LaserScan(Header(stamp, "base_link"), float(a[0]), float(a[-1]),
                     float(a[1] - a[0]), 0.0, 0.1, 0.1, 20.0, r)


class Rig:
    def __init__(self, section: dict[str, Any]) -> None:
        self.rt = Runtime()
        self.rt.tf.add_static("odom", "base_link", Pose2D(0.0, 0.0, 0.0))
        params = collision_monitor_params({"cmd_vel_out_topic": "/nav_vel", **section})
        self.node = CollisionMonitorNode(self.rt, Footprint.from_radius(0.2), params)
        self.rt.bring_up()
        self.out: list[tuple[float, float, float]] = []
        self.states: list[tuple[int, str]] = []
        self.rt.bus.subscribe("/nav_vel", Twist, lambda m: self.out.append(
            (self.rt.now, m.linear.x, m.angular.z)), QoS(depth=1))
        self.rt.bus.subscribe("/collision_monitor_state", CollisionMonitorState,
                              lambda m: self.states.append((m.action_type, m.polygon_name)))
        self.cmd = self.rt.bus.publisher("/cmd_vel_smoothed", Twist)

    def drive(self, t0: float, t1: float, vx: float = 0.4, wz: float = 0.2) -> None:
        k = 0
        while t0 + k * CYCLE <= t1 + 1e-9:
            self.rt.scheduler.call_at(t0 + k * CYCLE,
                                      lambda: self.cmd.publish(Twist.planar(vx, 0.0, wz)))
            k += 1

    def sensor(self, topic: str, kind: type, t: float, msg: object) -> None:
        pub = self.rt.bus.publisher(topic, kind)
        self.rt.scheduler.call_at(t, lambda: pub.publish(msg))


SCAN = {"observation_sources": ["scan"], "scan": {"type": "scan", "topic": "/scan"},
        "source_timeout": 0.5}


def test_stop_polygon_gives_zero_within_one_cycle() -> None:
    r = Rig({**SCAN, "polygons": ["PolygonStop"],
             "PolygonStop": {"type": "polygon", "points": BOX, "action_type": "stop"}})
    for k in range(11):  # 10 Hz scans; an obstacle enters the stop box at 0.5 s
        t = 0.1 * k
        r.sensor("/scan", LaserScan, t, scan_with_obstacle_at(None if t < 0.45 else 0.5, t))
    r.drive(0.0, 1.0)
    r.rt.scheduler.run_until(1.0)
    before = [vx for t, vx, _ in r.out if t < 0.5 - 1e-9]
    after = [(t, vx, wz) for t, vx, wz in r.out if t >= 0.5 - 1e-9]
    assert before and all(vx == 0.4 for vx in before)
    assert after[0][0] == pytest.approx(0.5)  # the first command after the scan: zero
    assert all(vx == 0.0 and wz == 0.0 for _, vx, wz in after)
    assert r.states == [(0, ""), (1, "PolygonStop")]
    assert r.node.monitor_state()["action"] == "stop"


def test_slowdown_is_exactly_slowdown_ratio_times_the_command() -> None:
    r = Rig({**SCAN, "polygons": ["PolygonSlow"],
             "PolygonSlow": {"type": "circle", "radius": 1.0, "action_type": "slowdown",
                             "slowdown_ratio": 0.3}})
    r.sensor("/scan", LaserScan, 0.0, scan_with_obstacle_at(0.8, 0.0))
    r.drive(0.0, 0.3, vx=0.45, wz=-0.6)
    r.rt.scheduler.run_until(0.3)
    assert {(vx, wz) for _, vx, wz in r.out} == {(0.45 * 0.3, -0.6 * 0.3)}
    assert r.states[-1] == (2, "PolygonSlow")


def test_stale_scan_stops_within_source_timeout_plus_one_cycle() -> None:
    r = Rig({**SCAN, "polygons": ["PolygonStop"],
             "PolygonStop": {"type": "polygon", "points": BOX, "action_type": "stop"}})
    for k in range(6):  # the lidar dies after its scan at 0.5 s
        r.sensor("/scan", LaserScan, 0.1 * k, scan_with_obstacle_at(None, 0.1 * k))
    r.drive(0.0, 2.0)  # scheduled after the scans: each instant's scan comes first
    r.rt.scheduler.run_until(2.0)
    moving = [t for t, vx, _ in r.out if vx != 0.0]
    stopped = [t for t, vx, _ in r.out if vx == 0.0]
    assert max(moving) <= 0.5 + 0.5 + 1e-9  # fresh until source_timeout after 0.5 s
    assert min(stopped) <= 0.5 + 0.5 + CYCLE + 1e-9
    assert all(t > max(moving) for t in stopped)
    assert r.states[-1] == (1, "scan (stale source)")


def test_no_data_yet_is_stale_and_zero_output_goes_quiet_after_stop_pub_timeout() -> None:
    r = Rig({**SCAN, "polygons": [], "stop_pub_timeout": 0.32})
    r.drive(0.0, 1.0)
    r.rt.scheduler.run_until(1.0)
    assert {vx for _, vx, _ in r.out} == {0.0}
    assert max(t for t, _, _ in r.out) == pytest.approx(0.30)  # zero 0.32 s, then quiet


def test_pointcloud_heights_and_range_arcs_are_sources() -> None:
    r = Rig({"observation_sources": ["cloud", "sonar"], "source_timeout": 0.0,
             "cloud": {"type": "pointcloud", "topic": "/cloud", "min_height": 0.1,
                       "max_height": 0.5},
             "sonar": {"type": "range", "topic": "/sonar",
                       "obstacles_angle": 0.05},
             "polygons": ["PolygonStop"],
             "PolygonStop": {"type": "polygon", "points": BOX, "action_type": "stop",
                             "min_points": 3}})
    low = np.array([[0.3, 0.0, 0.02]] * 5, dtype=np.float32)  # the floor: ignored
    r.sensor("/cloud", PointCloud, 0.0, PointCloud(Header(0.0, "base_link"), low))
    r.drive(0.0, 0.1)
    r.rt.scheduler.run_until(0.12)
    assert all(vx == 0.4 for _, vx, _ in r.out)
    r.sensor("/sonar", Range, 0.15, Range(Header(0.15, "base_link"), 0, 0.2, 0.02, 2.0, 0.4))
    r.drive(0.2, 0.3)
    r.rt.scheduler.run_until(0.3)
    assert all(vx == 0.0 for t, vx, _ in r.out if t >= 0.2)  # 5 arc points at 0.4 m
    r.sensor("/sonar", Range, 0.32, Range(Header(0.32, "base_link"), 0, 0.2, 0.02, 2.0, 2.5))
    r.drive(0.35, 0.4)
    r.rt.scheduler.run_until(0.4)
    assert r.out[-1][1] == 0.4  # beyond max_range: no obstacle


def test_a_source_without_the_map_obstacles_keeps_the_padded_zone_off_the_walls() -> None:
    """The packaged pair of zones: the body against every point, the body + 0.12 m against
    the points the map does not explain.  A wall on the map 0.05 m beside the padded
    zone's reach does not slow the robot; a person the same distance ahead does."""
    from navstack.core.msgs import MapMetaData, OccupancyGrid, Point, Pose

    section = {
        "observation_sources": ["scan", "scan_unmapped"], "source_timeout": 0.0,
        "scan": {"type": "scan", "topic": "/scan"},
        "scan_unmapped": {"type": "scan", "topic": "/scan", "exclude_map_obstacles": 0.15},
        "polygons": ["FootprintApproach", "MovingApproach"],
        "FootprintApproach": {"type": "polygon", "action_type": "approach",
                              "footprint_topic": "/fp", "min_points": 1,
                              "time_before_collision": 1.2, "sources_names": ["scan"]},
        "MovingApproach": {"type": "polygon", "action_type": "approach",
                           "footprint_topic": "/fp", "footprint_padding": 0.12,
                           "min_points": 1, "time_before_collision": 1.2,
                           "sources_names": ["scan_unmapped"]}}
    r = Rig(section)
    r.rt.tf.add_static("map", "odom", Pose2D(1.0, 2.0, 0.0))  # base_link at (1, 2)
    occupied = np.zeros((80, 80), dtype=np.int8)  # 0.05 m cells from (0, 0)
    occupied[:, 27] = 100  # a wall along x = 1.35..1.40: 0.35 m ahead of the robot
    grid = OccupancyGrid(Header(0.0, "map"), MapMetaData(0.0, 0.05, 80, 80, Pose(Point())),
                         occupied)
    r.sensor("/map", OccupancyGrid, 0.0, grid)
    r.sensor("/scan", LaserScan, 0.01, scan_with_obstacle_at(0.36, 0.01))  # the wall's face
    r.drive(0.05, 0.2, wz=0.0)
    r.rt.scheduler.run_until(0.2)
    # the body reaches the wall after 0.4 s at 0.4 m/s: the body zone scales (t = 0.3 s)
    assert [vx for _, vx, _ in r.out] == pytest.approx([0.4 * 0.3 / 1.2] * 4)
    assert r.node.last.polygon == "FootprintApproach"
    r.rt.tf.add_static("map", "odom", Pose2D(0.5, 2.0, 0.0))  # the robot 0.5 m further back
    r.sensor("/scan", LaserScan, 0.25, scan_with_obstacle_at(0.36, 0.25))  # not on the map
    r.drive(0.3, 0.3, wz=0.0)
    r.rt.scheduler.run_until(0.3)
    # a person 0.16 m ahead of the body: inside the padded zone (0.32 m) after 0.1 s
    assert r.out[-1][1] == 0.0 and r.node.last.polygon == "MovingApproach"


def test_unknown_space_explains_a_point_like_a_wall() -> None:
    """A map being built (SLAM) has not published the walls the robot is discovering:
    a point in (or within exclude_map_obstacles of) unknown space, or off the map, is
    not counted as a person; the same point in known free space is."""
    from navstack.core.msgs import MapMetaData, OccupancyGrid, Point, Pose

    section = {
        "observation_sources": ["scan_unmapped"], "source_timeout": 0.0,
        "scan_unmapped": {"type": "scan", "topic": "/scan", "exclude_map_obstacles": 0.15},
        "polygons": ["MovingApproach"],
        "MovingApproach": {"type": "polygon", "action_type": "approach",
                           "footprint_topic": "/fp", "footprint_padding": 0.12,
                           "min_points": 1, "time_before_collision": 1.2,
                           "sources_names": ["scan_unmapped"]}}
    r = Rig(section)
    r.rt.tf.add_static("map", "odom", Pose2D(0.5, 2.0, 0.0))  # base_link at (0.5, 2)
    data = np.zeros((80, 80), dtype=np.int8)  # 0.05 m cells from (0, 0), all free
    data[:, 19:] = -1  # unknown from x = 0.95 on: the point 0.36 m ahead lies there
    meta = MapMetaData(0.0, 0.05, 80, 80, Pose(Point()))
    r.sensor("/map", OccupancyGrid, 0.0, OccupancyGrid(Header(0.0, "map"), meta, data))
    r.sensor("/scan", LaserScan, 0.01, scan_with_obstacle_at(0.36, 0.01))
    r.drive(0.05, 0.2, wz=0.0)
    r.rt.scheduler.run_until(0.2)
    assert [vx for _, vx, _ in r.out] == [0.4] * 4  # explained: not slowed
    r.rt.tf.add_static("map", "odom", Pose2D(-3.0, 2.0, 0.0))  # off the map: explained
    r.sensor("/scan", LaserScan, 0.21, scan_with_obstacle_at(0.36, 0.21))
    r.drive(0.25, 0.3, wz=0.0)
    r.rt.scheduler.run_until(0.3)
    assert r.out[-1][1] == 0.4
    known = np.zeros((80, 80), dtype=np.int8)  # the same space mapped free: a person
    r.sensor("/map", OccupancyGrid, 0.31, OccupancyGrid(Header(0.31, "map"), meta, known))
    r.rt.tf.add_static("map", "odom", Pose2D(0.5, 2.0, 0.0))
    r.sensor("/scan", LaserScan, 0.32, scan_with_obstacle_at(0.36, 0.32))
    r.drive(0.35, 0.4, wz=0.0)
    r.rt.scheduler.run_until(0.4)
    assert r.out[-1][1] == 0.0 and r.node.last.polygon == "MovingApproach"
