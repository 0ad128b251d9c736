"""pointcloud_to_laserscan on a simulated 16-ring cloud of a known scene: where the
planar lidar and the flattened cloud see the same obstacle they agree within 1 cm, and
heights outside [min_height, max_height] are ignored (acceptance 6)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Header, LaserScan, PointCloud2, Pose2D
from navstack.nodes.pointcloud_to_laserscan import PointCloudToLaserScanNode
from navstack.perception.pointcloud_to_laserscan import (
    PointCloudToLaserScanParams,
    pointcloud_to_laserscan,
)
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.world import World

RES = 0.05
INC = 2 * math.pi / 360


def _scene() -> tuple[World, np.ndarray]:
    """20 m x 20 m, robot at the centre (10, 10): a 2.5 m wall 5 m east, a 0.3 m low box
    3 m west, the 2.5 m boundary walls."""
    n = int(20 / RES)
    occ = np.zeros((n, n), dtype=bool)
    heights = np.full((n, n), 2.5)
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = True

    def box(x0: float, y0: float, x1: float, y1: float, h: float) -> None:
        r0, r1, c0, c1 = int(y0 / RES), int(y1 / RES), int(x0 / RES), int(x1 / RES)
        occ[r0:r1, c0:c1] = True
        heights[r0:r1, c0:c1] = h

    box(15.0, 7.0, 15.5, 13.0, 2.5)  # tall wall, east
    box(6.5, 8.5, 7.0, 11.5, 0.3)  # low box, west
    return World(occ, RES, 0.0, 0.0, name="p2l", spawn=Pose2D(10.0, 10.0, 0.0)), heights


def _simulator() -> Simulator:
    world, heights = _scene()
    robot = load_robot("golf_cart", {"sensors": {
        "lidar": {"angle_min": -math.pi, "angle_max": math.pi, "beams": 360,
                  "mount": {"x": 0.0, "y": 0.0, "z": 0.6, "yaw": 0.0}, "noise_std": 0.0,
                  "dropout_prob": 0.0, "range_max": 30.0},
        "lidar3d": {"enabled": True, "azimuths": 360, "rings": 16, "noise_std": 0.0,
                    "mount": {"x": 0.0, "y": 0.0, "z": 0.6, "yaw": 0.0}}}})
    sim = Simulator(world, robot, seed=0, spawn=Pose2D(10.0, 10.0, 0.0))
    sim.heights = heights
    return sim


def _flatten(cloud: PointCloud2, min_height: float, max_height: float) -> LaserScan:
    params = PointCloudToLaserScanParams(min_height=min_height, max_height=max_height,
                                         angle_min=-math.pi - INC / 2,
                                         angle_max=math.pi - INC / 2, angle_increment=INC,
                                         range_max=30.0)
    xyz = cloud.xyz() + np.array([0.0, 0.0, 0.6])  # the lidar frame into base_link
    return pointcloud_to_laserscan(xyz, params, Header(cloud.header.stamp, "base_link"))


def _beams(scan: LaserScan, bearing: float, half_width: float) -> np.ndarray:
    a = scan.angle_min + INC / 2 + INC * np.arange(len(scan.ranges))
    return np.flatnonzero(np.abs((a - bearing + math.pi) % (2 * math.pi) - math.pi)
                          < half_width)


def test_cloud_is_organised_16_rings() -> None:
    cloud = _simulator().point_cloud(1.0)
    assert cloud is not None
    assert (cloud.height, cloud.width) == (16, 360)
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "intensity", "ring"]
    ring = cloud.field("ring")
    assert ring[0] == 0 and ring[-1] == 15
    xyz = cloud.xyz()
    ground = xyz[np.isfinite(xyz[:, 2]) & (np.abs(xyz[:, 2] + 0.6) < 1e-4)]
    # the lowest ring (-15 deg) meets the ground 0.6 / tan(15 deg) = 2.24 m away
    assert np.hypot(ground[:, 0], ground[:, 1]).min() == pytest.approx(
        0.6 / math.tan(math.radians(15)), abs=1e-3)


def test_flattened_cloud_matches_the_planar_lidar_and_ignores_low_obstacles() -> None:
    sim = _simulator()
    planar = sim.scan(1.0)
    cloud = sim.point_cloud(1.0)
    assert planar is not None and cloud is not None
    scan = _flatten(cloud, min_height=0.4, max_height=2.0)
    assert len(scan.ranges) == len(planar.ranges) == 360
    p, s = np.asarray(planar.ranges, float), np.asarray(scan.ranges, float)
    # the tall wall east: both see it, 5 m ahead, within 1 cm
    east = _beams(scan, 0.0, math.radians(25))
    assert np.all(np.abs(p[east] - s[east]) < 0.01)
    assert p[east].min() == pytest.approx(5.0, abs=0.01)
    # every beam where both see the same surface agrees within 1 cm
    same = np.isfinite(p) & np.isfinite(s) & (np.abs(p - s) < 0.5)
    assert same.sum() > 250 and np.abs(p[same] - s[same]).max() < 0.01
    # the low box west (0.3 m < min_height): the planar lidar sees it 3 m away, the
    # flattened scan looks over it to the boundary wall 9.9 m away
    west = _beams(scan, math.pi, math.radians(10))
    assert np.all(np.abs(p[west] - 3.0) < 0.05)
    assert np.all(s[west] > 9.0)
    # with the band lowered to include it, the box is back, within 1 cm
    low = _flatten(cloud, min_height=0.05, max_height=2.0)
    lw = np.asarray(low.ranges, float)[west]
    assert np.all(np.abs(lw - p[west]) < 0.01)
    # a band above the walls (2.6..3 m) sees nothing: every beam inf (use_inf)
    empty = _flatten(cloud, min_height=2.6, max_height=3.0)
    assert np.all(np.isinf(empty.ranges))


def test_parameters_follow_the_ros_package() -> None:
    pts = np.array([[1.0, 0.0, 0.5], [2.0, 0.0, 0.5], [0.0, 3.0, 5.0], [0.0, -1.0, 0.5],
                    [np.nan, 0.0, 0.5], [0.1, 0.0, 0.5], [-4.0, 0.0, 0.5]])
    p = PointCloudToLaserScanParams(angle_min=-math.pi / 2, angle_max=math.pi / 2,
                                    angle_increment=math.pi / 2, min_height=0.0,
                                    max_height=1.0, range_min=0.5, range_max=3.5,
                                    use_inf=False, inf_epsilon=2.0)
    scan = pointcloud_to_laserscan(pts, p, Header(0.0, "base_link"))
    # beams: [-pi/2, 0), [0, pi/2); the nearest point of each; empty -> range_max + eps
    assert scan.ranges.tolist() == [1.0, 1.0]
    p2 = p.updated(range_min=1.5)
    assert pointcloud_to_laserscan(pts, p2, Header()).ranges.tolist() == [5.5, 2.0]
    assert PointCloudToLaserScanParams().beams == 360
    with pytest.raises(ConfigError, match="angle_max"):
        PointCloudToLaserScanParams.from_mapping({"angle_min": 1.0, "angle_max": 0.5})
    with pytest.raises(ConfigError, match="max_height"):
        PointCloudToLaserScanParams.from_mapping({"min_height": 1.0, "max_height": 0.5})


def test_node_flattens_the_simulated_velodyne_in_base_link() -> None:
    sim = _simulator()
    rt = Runtime()
    SimulatorNode(rt, sim)
    node = PointCloudToLaserScanNode(
        rt, PointCloudToLaserScanParams(target_frame="base_link", min_height=0.4,
                                        max_height=2.0, angle_min=-math.pi - INC / 2,
                                        angle_max=math.pi - INC / 2, angle_increment=INC,
                                        range_max=30.0),
        cloud_topic="/velodyne_points", scan_topic="/scan_from_cloud")
    got: list[LaserScan] = []
    planar: list[LaserScan] = []
    rt.bus.subscribe("/scan_from_cloud", LaserScan, got.append)
    rt.bus.subscribe("/scan", LaserScan, planar.append)
    rt.bring_up()
    rt.scheduler.run_for(0.35)
    assert node.scans >= 3 and node.dropped_tf == 0
    s, p = np.asarray(got[-1].ranges, float), np.asarray(planar[-1].ranges, float)
    assert got[-1].header.frame_id == "base_link"
    east = _beams(got[-1], 0.0, math.radians(25))
    assert np.all(np.abs(s[east] - p[east]) < 0.01)
