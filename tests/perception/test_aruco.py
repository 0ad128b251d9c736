"""ArUco detection and pose: accuracy against the simulator's truth, covariance, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navstack.core.errors import ConfigError, InvalidMessage
from navstack.core.msgs import Header, Pose2D
from navstack.core.msgs.camera_msgs import CameraInfo, Image
from navstack.core.rotations import rotation_angle
from navstack.perception.aruco import (
    ArucoDetector,
    ArucoParams,
    ImageEncodingError,
    PinholeCamera,
    load_camera_info,
)
from navstack.sim.camera import CameraModel
from navstack.sim.robot import CameraParams
from navstack.sim.world import World
from navstack.sim.world_io import world_from_mapping


def _world(size: float = 0.1, dictionary: str = "DICT_4X4_50", marker_id: int = 7) -> World:
    return world_from_mapping({
        "name": "a", "size": [12.0, 12.0], "boundary": False, "marker_dictionary": dictionary,
        "walls": [{"from": [10.05, 1.0], "to": [10.05, 11.0], "thickness": 0.1}],
        "markers": [{"id": marker_id, "size": size, "position": [9.999, 6.0], "height": 0.3,
                     "yaw": math.pi}],
        "spawn": {"x": 5.0, "y": 6.0}})


CAM = CameraModel(CameraParams(enabled=True, mount={"z": 0.3}, pixel_noise_std=2.0))
PINHOLE = PinholeCamera.from_camera_info(CAM.camera_info())


def _view(world: World, distance: float, angle: float) -> Pose2D:
    m = world.markers[0]
    x = m.x + distance * math.cos(m.yaw + angle)
    y = m.y + distance * math.sin(m.yaw + angle)
    return Pose2D(x, y, math.atan2(m.y - y, m.x - x))


@pytest.mark.parametrize(("distance", "angle", "tol"), [(1.0, 0.0, 0.01), (1.0, 0.6, 0.01),
                                                       (2.0, -0.5, 0.03), (3.0, 0.3, 0.12)])
def test_pose_matches_the_truth(distance: float, angle: float, tol: float) -> None:
    world = _world()
    robot = _view(world, distance, angle)
    img = CAM.render(world, robot, np.random.default_rng(4))
    poses = ArucoDetector(ArucoParams(marker_size=0.1)).process(img, PINHOLE)
    assert [p.id for p in poses] == [7]
    truth = CAM.marker_in_optical(world.markers[0], robot)
    assert np.linalg.norm(poses[0].translation - truth[:3, 3]) < tol
    if distance <= 1.0:
        assert math.degrees(rotation_angle(poses[0].rotation, truth[:3, :3])) < 5.0


def test_covariance_is_positive_and_grows_with_distance() -> None:
    world = _world()
    det = ArucoDetector(ArucoParams(marker_size=0.1))
    variances = []
    for d in (1.0, 2.0, 3.0):
        img = CAM.render(world, _view(world, d, 0.2), np.random.default_rng(0))
        pose = det.process(img, PINHOLE)[0]
        assert np.all(np.linalg.eigvalsh(pose.covariance) > 0.0)
        variances.append(pose.covariance[2, 2])  # depth (optical z)
    # depth sigma ~ z^2: variance grows roughly with z^4
    assert variances[1] > 8.0 * variances[0] and variances[2] > 3.0 * variances[1]


def test_original_aruco_dictionary() -> None:
    world = _world(dictionary="DICT_ARUCO_ORIGINAL", marker_id=612)
    img = CAM.render(world, _view(world, 1.5, 0.3), np.random.default_rng(0))
    poses = ArucoDetector(ArucoParams(dictionary="ARUCO_ORIGINAL")).process(img, PINHOLE)
    assert [p.id for p in poses] == [612]


def test_small_marker_pass_reads_what_opencv_rejects() -> None:
    # a 5 cm marker 2.3 m away, 40 degrees off its normal: about 14 x 10 px
    world = _world(size=0.05)
    img = CAM.render(world, _view(world, 2.3, 0.7), np.random.default_rng(2))
    plain = ArucoDetector(ArucoParams(marker_size=0.05, small_marker_pass=False))
    full = ArucoDetector(ArucoParams(marker_size=0.05))
    assert [d.id for d in full.detect(img)] == [7]
    assert plain.detect(img) == []


def test_frames_without_markers_are_counted_not_errors() -> None:
    world = _world()
    det = ArucoDetector()
    img = CAM.render(world, Pose2D(5.0, 6.0, math.pi), np.random.default_rng(0))  # looks away
    assert det.process(img, PINHOLE) == []
    det.process(CAM.render(world, _view(world, 1.0, 0.0), np.random.default_rng(0)), PINHOLE)
    assert (det.stats.frames, det.stats.frames_without_markers, det.stats.markers) == (2, 1, 1)


def test_bad_parameters_are_clear_errors() -> None:
    with pytest.raises(ConfigError, match=r"dictionary: .*unknown ArUco dictionary 'DICT_5X5_5'"):
        ArucoParams.from_mapping({"dictionary": "DICT_5X5_5"})
    with pytest.raises(ConfigError, match=r"marker_size: .*marker size must be > 0 m.*got 0"):
        ArucoParams.from_mapping({"marker_size": 0.0})
    with pytest.raises(ConfigError, match=r"marker_size: .*got -0.1"):
        ArucoParams.from_mapping({"marker_size": -0.1})
    with pytest.raises(ConfigError, match=r"ids .*60.* not in DICT_4X4_50"):
        ArucoDetector(ArucoParams(ids=[3, 60]))


def test_camera_info_with_zero_focal_length() -> None:
    info = CameraInfo(Header(0.0, "cam"), 480, 640, "plumb_bob", (0.0,) * 5, (0.0,) * 9)
    with pytest.raises(ConfigError, match=r"focal lengths must be > 0 px.*not calibrated"):
        PinholeCamera.from_camera_info(info)


def test_wrong_image_encodings() -> None:
    det = ArucoDetector()
    depth = Image.from_array(np.ones((48, 64), np.float32), "32FC1", Header(0.0, "cam"))
    with pytest.raises(ImageEncodingError, match=r"encoding .32FC1.*8-bit image: mono8"):
        det.detect(depth)
    with pytest.raises(ImageEncodingError, match="dtype uint16"):
        det.detect(np.zeros((48, 64), np.uint16))
    with pytest.raises(ImageEncodingError, match=r"shape \(48, 64, 2\)"):
        det.detect(np.zeros((48, 64, 2), np.uint8))
    with pytest.raises(InvalidMessage, match="needs 3072 bytes"):
        Image(Header(), 48, 64, "mono8", False, 64, np.zeros(10, np.uint8)).to_array()


def test_colour_images_are_converted() -> None:
    world = _world()
    grey = CAM.render(world, _view(world, 1.0, 0.0), np.random.default_rng(0))
    rgb = Image.from_array(np.repeat(grey[:, :, None], 3, axis=2), "rgb8")
    assert [p.id for p in ArucoDetector().process(rgb, PINHOLE)] == [7]


def test_image_rows_with_padding_round_trip() -> None:
    arr = np.arange(12, dtype=np.uint8).reshape(3, 4)
    padded = np.zeros((3, 6), np.uint8)
    padded[:, :4] = arr
    msg = Image(Header(), 3, 4, "mono8", False, 6, padded.reshape(-1))
    np.testing.assert_array_equal(msg.to_array(), arr)
    np.testing.assert_array_equal(Image.from_array(arr, "mono8").to_array(), arr)


def test_calibration_yaml(tmp_path: Path) -> None:
    good = tmp_path / "cam.yaml"
    good.write_text("image_width: 640\nimage_height: 480\ncamera_name: pi\n"
                    "camera_matrix: {rows: 3, cols: 3, data: [500, 0, 320, 0, 500, 240, 0, 0, 1]}\n"
                    "distortion_model: plumb_bob\n"
                    "distortion_coefficients: {rows: 1, cols: 5, data: [0.1, -0.2, 0, 0, 0]}\n")
    cam = load_camera_info(good)
    assert (cam.fx, cam.width, cam.frame_id) == (500.0, 640, "pi")
    assert cam.D.tolist() == [0.1, -0.2, 0.0, 0.0, 0.0]
    zero = tmp_path / "zero.yaml"
    zero.write_text("width: 640\nheight: 480\nk: [0, 0, 320, 0, 0, 240, 0, 0, 1]\n")
    with pytest.raises(ConfigError, match=r"zero.yaml: k: focal lengths must be > 0"):
        load_camera_info(zero)
    with pytest.raises(ConfigError, match="camera info file not found"):
        load_camera_info(tmp_path / "missing.yaml")
    fisheye = tmp_path / "fish.yaml"
    fisheye.write_text("width: 640\nheight: 480\nk: [500, 0, 320, 0, 500, 240, 0, 0, 1]\n"
                       "distortion_model: equidistant\nd: [0.1, 0.0, 0.0, 0.0]\n")
    with pytest.raises(ConfigError, match="distortion model 'equidistant' is not supported"):
        load_camera_info(fisheye)
