"""Message helpers: Pose2D algebra, Path arrays and length, LaserScan points, grid cells."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.msgs import (
    Header,
    LaserScan,
    MapMetaData,
    OccupancyGrid,
    Path,
    Point,
    Pose,
    Pose2D,
    PoseStamped,
    Quaternion,
    Transform,
)


def test_pose2d_compose_and_inverse() -> None:
    a = Pose2D(1.0, 2.0, math.pi / 2)
    b = Pose2D(1.0, 0.5, math.pi / 2)
    c = a.compose(b)
    assert (c.x, c.y, c.theta) == pytest.approx((0.5, 3.0, math.pi))
    assert a @ b == c
    inv = a.inverse()
    assert (inv.x, inv.y, inv.theta) == pytest.approx((-2.0, 1.0, -math.pi / 2))
    ident = a @ inv
    assert (ident.x, ident.y, ident.theta) == pytest.approx((0.0, 0.0, 0.0), abs=1e-15)
    assert Pose2D.from_array([0.0, 0.0, 3.0 * math.pi]).theta == pytest.approx(math.pi)
    assert a.distance_to(b) == pytest.approx(1.5)
    pts = a.transform_points(np.array([[1.0, 0.0], [0.0, 1.0]]))
    assert np.allclose(pts, [[1.0, 3.0], [0.0, 2.0]])


def test_pose_round_trips() -> None:
    p = Pose2D(1.5, -2.0, 0.7)
    back = PoseStamped.from_pose2d(p, "odom", 3.0)
    assert back.header == Header(3.0, "odom")
    q = back.to_pose2d()
    assert (q.x, q.y, q.theta) == pytest.approx((1.5, -2.0, 0.7))
    t = Transform.from_pose2d(p).to_pose2d()
    assert (t.x, t.y, t.theta) == pytest.approx((1.5, -2.0, 0.7))
    assert Quaternion.from_yaw(0.7).yaw == pytest.approx(0.7)


def test_path_from_array_as_array_and_length() -> None:
    xyt = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.5], [3.0, 10.0, -2.0], [0.0, 10.0, math.pi]])
    path = Path.from_array(xyt, frame_id="map", stamp=2.0)
    assert len(path.poses) == 4
    assert path.header == Header(2.0, "map")
    assert path.poses[1].header.frame_id == "map"
    assert np.allclose(path.as_array(), xyt, atol=1e-12)
    assert path.length() == pytest.approx(5.0 + 6.0 + 3.0)
    assert Path().length() == 0.0
    assert Path().as_array().shape == (0, 3)
    assert Path.from_array(xyt[:1]).length() == 0.0


def test_path_num_poses_does_not_build_the_poses_of_an_array_path() -> None:
    lazy = Path.from_array(np.zeros((5, 3)), frame_id="map")
    assert lazy.num_poses == 5
    assert lazy._poses is None  # still only the array
    assert len(lazy.poses) == 5 and lazy.num_poses == 5
    assert Path().num_poses == 0 and Path.from_array(np.zeros((0, 3))).num_poses == 0
    assert Path(poses=lazy.poses).num_poses == 5


def test_laserscan_points_drop_invalid_ranges() -> None:
    scan = LaserScan(angle_min=-math.pi / 2, angle_max=math.pi / 2,
                     angle_increment=math.pi / 2, range_min=0.1, range_max=10.0,
                     ranges=np.array([1.0, np.inf, 2.0], dtype=np.float32))
    assert np.allclose(scan.angles(), [-math.pi / 2, 0.0, math.pi / 2])
    assert np.allclose(scan.points(), [[0.0, -1.0], [0.0, 2.0]], atol=1e-12)
    out_of_range = LaserScan(angle_increment=0.1, range_min=0.5, range_max=3.0,
                             ranges=np.array([0.2, 3.5, np.nan, 1.0], dtype=np.float32))
    pts = out_of_range.points()
    assert pts.shape == (1, 2)
    assert np.allclose(pts[0], [math.cos(0.3), math.sin(0.3)])


def test_occupancy_grid_world_to_cell() -> None:
    info = MapMetaData(resolution=0.05, width=100, height=80,
                       origin=Pose(Point(-2.0, -1.0, 0.0)))
    grid = OccupancyGrid(info=info, data=np.zeros((80, 100), np.int8))
    assert grid.world_to_cell(-2.0, -1.0) == (0, 0)
    assert grid.world_to_cell(0.0, 0.0) == (20, 40)
    assert grid.world_to_cell(0.026, -0.974) == (0, 40)
    assert grid.world_to_cell(-2.01, -1.0) == (0, -1)  # out of bounds is reported, not clamped
    rotated = OccupancyGrid(info=MapMetaData(resolution=0.5, origin=Pose(
        Point(1.0, 1.0, 0.0), Quaternion.from_yaw(math.pi / 2))))
    # grid x points along world +y, grid y along world -x: (0.2, 2.3) is at (1.3, 0.8) m
    assert rotated.world_to_cell(0.2, 2.3) == (1, 2)
