"""Simulated camera: geometry against hand-computed projections, occlusion, markers in the
world file, corners mode, rendering that a real detector reads back."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.sim.camera import CameraModel
from navstack.sim.robot import CameraParams
from navstack.sim.world import World
from navstack.sim.world_io import world_from_mapping


def _world(extra: dict | None = None) -> World:
    doc = {"name": "cam", "size": [10.0, 10.0], "resolution": 0.05, "boundary": False,
           "walls": [{"from": [6.05, 0.0], "to": [6.05, 10.0], "thickness": 0.1}],
           "markers": [{"id": 3, "size": 0.2, "position": [5.999, 5.0], "height": 0.5,
                        "yaw": math.pi}],
           "spawn": {"x": 3.0, "y": 5.0}}
    doc.update(extra or {})
    return world_from_mapping(doc)


def _camera(**kw: object) -> CameraModel:
    return CameraModel(CameraParams(enabled=True, mount={"z": 0.5}, **kw))


def test_intrinsics_follow_the_field_of_view() -> None:
    cam = _camera(width=640, height=480, horizontal_fov=1.047)
    assert cam.fx == pytest.approx(320.0 / math.tan(0.5235), rel=1e-3)
    info = cam.camera_info(1.5)
    assert info.header.frame_id == "camera_link_optical"
    assert info.k[2] == pytest.approx(319.5) and info.k[5] == pytest.approx(239.5)
    assert (info.width, info.height, info.distortion_model) == (640, 480, "plumb_bob")


def test_marker_corners_project_where_the_pinhole_puts_them() -> None:
    world, cam = _world(), _camera()
    # camera 3 m in front of the marker, level with it: a 0.2 m square centred in the image
    seen = cam.visible_markers(world, Pose2D(3.0, 5.0, 0.0))
    assert len(seen) == 1
    c = seen[0].corners
    half = cam.fx * 0.1 / 2.999
    np.testing.assert_allclose(c, [[cam.cx - half, cam.cy - half], [cam.cx + half, cam.cy - half],
                                   [cam.cx + half, cam.cy + half], [cam.cx - half, cam.cy + half]],
                               atol=1e-6)
    truth = cam.marker_in_optical(world.markers[0], Pose2D(3.0, 5.0, 0.0))
    np.testing.assert_allclose(truth[:3, 3], [0.0, 0.0, 2.999], atol=1e-9)
    # marker z axis points back at the camera (optical -z)
    np.testing.assert_allclose(truth[:3, 2], [0.0, 0.0, -1.0], atol=1e-9)


def test_markers_behind_or_facing_away_are_not_seen() -> None:
    world, cam = _world(), _camera()
    assert cam.visible_markers(world, Pose2D(3.0, 5.0, math.pi)) == []  # looking away
    assert cam.visible_markers(world, Pose2D(7.0, 5.0, math.pi)) == []  # behind the wall


def test_rendered_marker_is_detected_at_the_projected_corners() -> None:
    world, cam = _world(), _camera(pixel_noise_std=2.0)
    robot = Pose2D(3.5, 4.8, 0.1)
    img = cam.render(world, robot, np.random.default_rng(0))
    assert img.shape == (480, 640) and img.dtype == np.uint8
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    corners, ids, _ = detector.detectMarkers(img)
    assert ids is not None and ids.ravel().tolist() == [3]
    truth = cam.visible_markers(world, robot)[0].corners
    assert np.abs(corners[0].reshape(4, 2) - truth).max() < 1.0


def test_a_wall_in_front_hides_the_marker_column_by_column() -> None:
    # a pillar between camera and marker hides its left half
    world = _world({"boxes": [{"center": [4.5, 5.15], "size": [0.1, 0.3]}]})
    cam = _camera()
    robot = Pose2D(3.0, 5.0, 0.0)
    rng = np.random.default_rng(0)
    img = cam.render(world, robot, rng)
    clear = cam.render(_world(), robot, rng)
    c = cam.visible_markers(world, robot)[0].corners
    x0, x1 = int(c[:, 0].min()), int(c[:, 0].max())
    y = int(c[:, 1].mean())
    diff = np.abs(img[y, x0:x1 + 1].astype(int) - clear[y, x0:x1 + 1].astype(int)) > 0
    assert diff[:3].all() and not diff[-3:].any()  # left columns hidden, right ones shown
    assert cam.detect_corners(world, robot, rng) == []
    assert [i for i, _ in cam.detect_corners(_world(), robot, rng)] == [3]


def test_corners_mode_limits_and_noise() -> None:
    world = _world()
    robot = Pose2D(3.0, 5.0, 0.0)
    exact = _camera().detect_corners(world, robot, np.random.default_rng(1))
    noisy = _camera(corner_noise_std=0.5).detect_corners(world, robot, np.random.default_rng(1))
    err = noisy[0][1] - exact[0][1]
    assert 0.05 < np.abs(err).mean() < 1.5
    assert _camera(max_range=2.0).detect_corners(world, robot, np.random.default_rng(1)) == []
    tiny = _camera(min_marker_pixels=200.0)
    assert tiny.detect_corners(world, robot, np.random.default_rng(1)) == []


def test_distortion_moves_corners_like_opencv() -> None:
    d = (-0.2, 0.05, 0.001, -0.001, 0.0)
    cam = _camera(distortion=d)
    world = _world()
    robot = Pose2D(3.5, 4.7, 0.2)
    c = cam.visible_markers(world, robot)[0]
    pts3 = world.markers[0].corners()
    t = cam.world_to_optical(cam.pose_in_world(robot))
    opt = pts3 @ t[:3, :3].T + t[:3, 3]
    ref, _ = cv2.projectPoints(opt, np.zeros(3), np.zeros(3), cam.K, np.asarray(d))
    np.testing.assert_allclose(c.corners, ref.reshape(4, 2), atol=1e-6)
    img = cam.render(world, robot, np.random.default_rng(0))
    det = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    corners, ids, _ = det.detectMarkers(img)
    assert ids is not None and np.abs(corners[0].reshape(4, 2) - c.corners).max() < 1.0


def test_packages_render_with_their_marker_and_stay_below_the_lidar() -> None:
    world = _world({"packages": [{"id": 9, "position": [4.0, 5.0], "yaw": math.pi / 2,
                                  "size": [0.1, 0.05, 0.05], "marker_size": 0.05}]})
    assert not world.occupied[world.world_to_cell(4.0, 5.0)]  # not in the grid
    cam = CameraModel(CameraParams(enabled=True, mount={"z": 0.084}))
    robot = Pose2D(3.2, 5.0, 0.0)
    img = cam.render(world, robot, np.random.default_rng(0))
    det = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    _, ids, _ = det.detectMarkers(img)
    assert ids is not None and 9 in ids.ravel().tolist()


def test_world_marker_errors_name_the_key() -> None:
    base = {"name": "w", "size": [4.0, 4.0]}
    with pytest.raises(ConfigError, match=r"markers\[0\].size: marker size must be > 0"):
        world_from_mapping({**base, "markers": [{"id": 1, "size": 0.0, "position": [1, 1]}]})
    with pytest.raises(ConfigError, match=r"unknown ArUco dictionary 'DICT_4X4_5O'.*DICT_4X4_50"):
        world_from_mapping({**base, "marker_dictionary": "DICT_4X4_5O",
                            "markers": [{"id": 1, "size": 0.1, "position": [1, 1]}]})
    with pytest.raises(ConfigError, match=r"markers\[0\].id: marker id 60 is not in DICT_4X4_50"):
        world_from_mapping({**base, "markers": [{"id": 60, "size": 0.1, "position": [1, 1]}]})
    with pytest.raises(ConfigError, match=r"markers\[1\].*already used by markers\[0\]"):
        world_from_mapping({**base, "markers": [{"id": 1, "size": 0.1, "position": [1, 1]},
                                                {"id": 1, "size": 0.1, "position": [2, 1]}]})
    with pytest.raises(ConfigError, match=r"packages\[0\].marker_size: a 0.08 m marker"):
        world_from_mapping({**base, "packages": [{"id": 2, "position": [2, 2],
                                                  "marker_size": 0.08}]})


def test_bgr8_image_message() -> None:
    cam = _camera(encoding="bgr8")
    msg = cam.image(_world(), Pose2D(3.0, 5.0, 0.0), np.random.default_rng(0), 2.0)
    assert (msg.encoding, msg.width, msg.height, msg.step) == ("bgr8", 640, 480, 1920)
    arr = msg.to_array()
    assert arr.shape == (480, 640, 3) and msg.header.stamp == 2.0
