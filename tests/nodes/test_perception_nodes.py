"""Perception on a running stack: marker frames on the map, the package cloud in the
costmap, the simulated gripper, bad camera input."""

from __future__ import annotations

import math

import numpy as np

from navstack.core.msgs import Header, Pose2D, String, Twist2D
from navstack.core.msgs.camera_msgs import CameraInfo, Image
from navstack.core.msgs.fiducial_msgs import ArucoMarkerArray
from navstack.core.msgs.gripper_msgs import GRIPPER_SERVICE, GRIPPER_STATUS_TOPIC, ServoCommand
from navstack.core.rotations import rotation_angle, transform_to_matrix
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.interfaces.perception import (
    PerceptionOptions,
    attach_perception,
    with_package_cloud,
)
from navstack.interfaces.stack import NavStack, default_nav2_params_path
from navstack.runtime.config import load_yaml
from navstack.sim.robot import load_robot
from navstack.sim.world_io import world_from_mapping


def test_office_marker_becomes_a_static_frame_on_the_map() -> None:
    stack = NavStack("office", "diff_drive", spawn=Pose2D(2.2, 5.0, math.pi), seed=3)
    per = attach_perception(stack, PerceptionOptions(detector={"marker_size": 0.15}))
    got: list[ArucoMarkerArray] = []
    stack.runtime.bus.subscribe("/aruco/marker_map", ArucoMarkerArray, got.append)
    stack.run_for(1.0)
    truth = stack.world.markers[0]
    tf = transform_to_matrix(stack.runtime.tf.lookup("map", "aruco_marker_12").transform)
    assert np.linalg.norm(tf[:3, 3] - [truth.x, truth.y, truth.z]) < 0.02
    assert math.degrees(rotation_angle(tf[:3, :3], truth.rotation())) < 2.0
    assert got and got[-1].markers[0].id == 12 and got[-1].header.frame_id == "map"
    # the live detection is a frame of the camera too
    assert stack.runtime.tf.can_transform("camera_link_optical", "marker_12")
    assert per.detector.detector.stats.frames_without_markers == 0
    assert per.camera.frames >= 29


def test_corners_mode_gives_the_same_frame() -> None:
    stack = NavStack("office", "diff_drive", spawn=Pose2D(2.0, 4.7, math.pi - 0.2), seed=3)
    attach_perception(stack, PerceptionOptions(camera_mode="corners", camera_rate_hz=10.0,
                                               detector={"marker_size": 0.15}))
    stack.run_for(1.0)
    t = stack.runtime.tf.lookup("map", "aruco_marker_12").transform.translation
    assert math.hypot(t.x - 0.801, t.y - 5.0) < 0.03


def test_bad_camera_info_and_encoding_are_counted_not_fatal() -> None:
    stack = NavStack("office", "diff_drive", spawn=Pose2D(2.2, 5.0, math.pi), seed=3)
    per = attach_perception(stack, PerceptionOptions(detector={"marker_size": 0.15}))
    bus = stack.runtime.bus
    node = per.detector
    bus.publisher("/camera/camera_info", CameraInfo).publish(
        CameraInfo(Header(0.0, "cam"), 480, 640, "plumb_bob", (0.0,) * 5, (0.0,) * 9))
    stack.run_for(0.0)
    assert node.bad_camera_info == 1 and "focal lengths must be > 0" in node.last_error
    stack.run_for(0.2)  # the simulator's valid info replaces it
    bus.publisher("/camera/image_raw", Image).publish(
        Image.from_array(np.zeros((480, 640), np.uint16), "16UC1", Header(stack.now, "cam")))
    stack.run_for(0.1)
    assert node.bad_images == 1 and "encoding '16UC1'" in node.last_error
    assert node.detector.stats.markers > 0  # and it kept detecting


ARENA = {"name": "pkg", "size": [4.0, 4.0], "resolution": 0.05,
         "packages": [{"id": 3, "position": [2.6, 1.0], "yaw": 1.5708},
                      {"id": 4, "position": [1.0, 3.0]}],
         "spawn": {"x": 0.7, "y": 1.0, "yaw": 0.0}}


def _package_stack(spawn: Pose2D) -> NavStack:
    nav2 = with_package_cloud(load_yaml(default_nav2_params_path()))
    return NavStack(world_from_mapping(ARENA), load_robot("turtlebot3_waffle_pi"), nav2,
                    spawn=spawn, seed=2)


def test_package_ring_is_in_the_costmap_soon_after_detection() -> None:
    stack = _package_stack(Pose2D(0.7, 1.0, 0.0))
    per = attach_perception(stack, PerceptionOptions(detector={"marker_size": 0.05},
                                                     marker_map={"package_ids": [3, 4]}))
    cm = stack.global_costmap.costmap
    hit = None
    for _ in range(60):
        stack.run_for(0.02)
        ring = per.marker_map.cloud_rings.get(3)  # the ring points last published
        if ring is None:
            continue
        assert ring.shape == (25, 3)
        cells = [cm.world_to_map(float(x), float(y)) for x, y, _ in ring]
        if all(c is not None and cm.data[c[1], c[0]] >= LETHAL_OBSTACLE for c in cells):
            hit = stack.now
            break
    # the lidar does not see the package: only the camera's ring marks it, within 0.4 s
    assert hit is not None and hit - per.marker_map.package_first_seen[3] <= 0.4
    cx, cy = per.marker_map.package_centres()[3]
    assert math.hypot(cx - 2.6, cy - 1.0) < 0.05


def test_gripper_lifts_the_package_in_reach_and_carries_it() -> None:
    # the Waffle Pi's front edge is 0.076 m ahead of base_link: package 0.12 m ahead
    stack = _package_stack(Pose2D(2.6 - 0.076 - 0.05 - 0.025 - 0.02, 1.0, 0.0))
    per = attach_perception(stack)
    assert per.gripper is not None
    status: list[str] = []
    bus = stack.runtime.bus
    bus.subscribe(GRIPPER_STATUS_TOPIC, String, lambda m: status.append(m.data))
    assert bus.call(GRIPPER_SERVICE, ServoCommand(20, 7.0)) == "OK"
    stack.run_for(1.0)
    assert stack.sim.sim.packages.carried is None  # still closing (2 s ramp)
    stack.run_for(1.2)
    pkgs = stack.sim.sim.packages
    assert pkgs.carried == 0 and status[-1] == "holding package_3"
    before = pkgs.poses[0]
    stack.sim.sim.teleport(Pose2D(1.0, 1.0, math.pi / 2))
    stack.run_for(0.1)
    after = pkgs.poses[0]
    assert math.hypot(after.x - 1.0, after.y - 1.0) < 0.2 and after != before
    assert bus.call(GRIPPER_SERVICE, ServoCommand(20, 2.0)) == "OK"
    stack.run_for(0.0)
    assert pkgs.carried is None and status[-1] == "open"


def test_driving_into_a_package_is_a_collision() -> None:
    stack = _package_stack(Pose2D(2.3, 1.0, 0.0))
    stack.start()
    sim = stack.sim.sim
    for _ in range(60):
        sim.set_command(Twist2D(0.2, 0.0, 0.0), sim.time)
        sim.step(0.05)
    assert sim.packages.collisions[0] == 1 and sim.collisions == 1
    assert 2.45 < sim.pose.x < 2.6 - 0.025 - 0.076  # stopped at the package
