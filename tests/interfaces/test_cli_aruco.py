"""``navstack aruco detect`` on image and video files, against the simulator's truth."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import yaml
from typer.testing import CliRunner

from navstack.app import app
from navstack.core.msgs import Pose2D
from navstack.sim.camera import CameraModel
from navstack.sim.robot import CameraParams
from navstack.sim.world_io import world_from_mapping

RUNNER = CliRunner()
WORLD = world_from_mapping({
    "name": "cli", "size": [10.0, 10.0], "boundary": False,
    "walls": [{"from": [8.05, 1.0], "to": [8.05, 9.0], "thickness": 0.1}],
    "marker_dictionary": "DICT_ARUCO_ORIGINAL",
    "markers": [{"id": 101, "size": 0.12, "position": [7.999, 5.0], "height": 0.4,
                 "yaw": math.pi}],
    "spawn": {"x": 5.0, "y": 5.0}})
CAM = CameraModel(CameraParams(enabled=True, mount={"z": 0.3}, pixel_noise_std=2.0))
ROBOT = Pose2D(6.4, 5.3, -0.2)


def _calibration(path: Path, fx: float | None = None) -> Path:
    info = CAM.camera_info()
    k = list(info.k)
    if fx is not None:
        k[0] = k[4] = fx
    path.write_text(yaml.safe_dump({
        "image_width": info.width, "image_height": info.height, "camera_name": "sim",
        "camera_matrix": {"rows": 3, "cols": 3, "data": k},
        "distortion_model": "plumb_bob",
        "distortion_coefficients": {"rows": 1, "cols": 5, "data": list(info.d)}}))
    return path


def test_detect_in_an_image_matches_the_truth(tmp_path: Path) -> None:
    img = CAM.render(WORLD, ROBOT, np.random.default_rng(0))
    png = tmp_path / "frame.png"
    cv2.imwrite(str(png), cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
    out = tmp_path / "poses.json"
    res = RUNNER.invoke(app, ["aruco", "detect", str(png), "--camera-info",
                              str(_calibration(tmp_path / "cam.yaml")), "--dictionary",
                              "DICT_ARUCO_ORIGINAL", "--marker-size", "0.12", "--json", str(out)])
    assert res.exit_code == 0, res.output
    assert "image: 1 frame(s), 0 without markers, 1 marker pose(s); ids 101" in res.output
    pose = json.loads(out.read_text())["poses"][0]
    truth = CAM.marker_in_optical(WORLD.markers[0], ROBOT)[:3, 3]
    assert np.linalg.norm(np.array([pose["x"], pose["y"], pose["z"]]) - truth) < 0.01


def test_detect_in_a_video_counts_frames_without_markers(tmp_path: Path) -> None:
    video = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (640, 480),
                             False)
    rng = np.random.default_rng(1)
    for pose in (ROBOT, Pose2D(6.4, 5.3, math.pi), Pose2D(6.2, 4.9, 0.1)):
        writer.write(CAM.render(WORLD, pose, rng))
    writer.release()
    out = tmp_path / "video.json"
    res = RUNNER.invoke(app, ["aruco", "detect", str(video), "--camera-info",
                              str(_calibration(tmp_path / "cam.yaml")), "--dictionary",
                              "ARUCO_ORIGINAL", "--marker-size", "0.12", "--json", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert (doc["kind"], doc["frames"], doc["frames_without_markers"]) == ("video", 3, 1)
    assert [p["frame"] for p in doc["poses"]] == [0, 2]


def test_detect_errors_are_one_line(tmp_path: Path) -> None:
    img = CAM.render(WORLD, ROBOT, np.random.default_rng(0))
    png = tmp_path / "frame.png"
    cv2.imwrite(str(png), img)
    cal = _calibration(tmp_path / "cam.yaml")
    zero = _calibration(tmp_path / "zero.yaml", fx=0.0)
    deep = tmp_path / "depth.png"
    cv2.imwrite(str(deep), (img.astype(np.uint16) * 256))
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), img[:240, :320])
    cases = [
        (["--camera-info", str(zero)], "focal lengths must be > 0 px"),
        (["--camera-info", str(cal), "--marker-size", "0"], "option --marker-size: marker size "
                                                            "must be > 0 m"),
        (["--camera-info", str(cal), "--dictionary", "DICT_9X9_50"],
         "option --dictionary: unknown ArUco dictionary 'DICT_9X9_50'"),
    ]
    for args, message in cases:
        res = RUNNER.invoke(app, ["aruco", "detect", str(png), *args])
        assert res.exit_code == 2 and message in res.output, res.output
    res = RUNNER.invoke(app, ["aruco", "detect", str(deep), "--camera-info", str(cal)])
    assert res.exit_code == 2 and "uint16 pixels; ArUco detection needs an 8-bit" in res.output
    res = RUNNER.invoke(app, ["aruco", "detect", str(small), "--camera-info", str(cal)])
    assert res.exit_code == 2 and "is 320 x 240 but" in res.output


def test_generate_writes_a_detectable_marker(tmp_path: Path) -> None:
    out = tmp_path / "m.png"
    res = RUNNER.invoke(app, ["aruco", "generate", "23", "--out", str(out)])
    assert res.exit_code == 0, res.output
    img = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    det = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50))
    _, ids, _ = det.detectMarkers(img)
    assert ids is not None and ids.ravel().tolist() == [23]
    res = RUNNER.invoke(app, ["aruco", "generate", "60", "--out", str(out)])
    assert res.exit_code == 2 and "marker id 60 is not in DICT_4X4_50" in res.output
