"""Robot profile loading: built-ins, validation messages, footprints, overrides."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navstack.core.errors import ConfigError, UnknownNameError
from navstack.sim.kinematics import Ackermann, DiffDrive, Omni
from navstack.sim.robot import RobotParams, list_robots, load_robot, robot_from_mapping


def test_builtin_profiles_load() -> None:
    assert list_robots() == ["diff_drive", "golf_cart", "omni", "rover", "turtlebot",
                             "turtlebot3_waffle_pi"]
    for name in list_robots():
        robot = load_robot(name)
        assert robot.name == name
        assert robot.footprint_model().circumscribed_radius > 0.0


def test_turtlebot_profile_values() -> None:
    tb = load_robot("turtlebot")
    k = tb.kinematics
    assert (k.type, k.max_vel_x, k.min_vx, k.max_vel_theta) == ("diff_drive", 0.26, -0.26, 1.82)
    fp = tb.footprint_model()
    assert fp.radius == pytest.approx(0.23)  # robot_radius 0.22 + padding 0.01
    lidar = tb.sensors.lidar
    assert (lidar.beams, lidar.range_max, lidar.rate_hz, lidar.frame_id) == (
        360, 12.0, 10.0, "base_scan")
    assert (lidar.mount.x, lidar.mount.z) == (-0.064, 0.122)
    assert isinstance(tb.kinematic_model(), DiffDrive)


def test_turtlebot3_waffle_pi_has_the_real_robots_figures() -> None:
    tb = load_robot("turtlebot3_waffle_pi")
    k = tb.kinematics
    assert (k.type, k.max_vel_x, k.max_vel_theta, k.wheel_separation) == (
        "diff_drive", 0.26, 1.82, 0.287)
    body = np.asarray(tb.footprint)
    length, width = np.ptp(body[:, 0]), np.ptp(body[:, 1])
    assert (length, width) == (pytest.approx(0.281), pytest.approx(0.306))
    lidar = tb.sensors.lidar
    assert (lidar.beams, lidar.range_min, lidar.range_max, lidar.rate_hz) == (
        360, 0.12, 3.5, 5.0)
    # LDS-01 precision: +-10 mm below 0.5 m, +-3.5 % beyond, read as 3-sigma bounds
    assert lidar.noise_std + lidar.noise_std_per_m * 3.0 == pytest.approx(0.035)
    cam = tb.sensors.camera
    assert cam.enabled and (cam.width, cam.height) == (640, 480)
    assert cam.horizontal_fov == pytest.approx(math.radians(62.2), abs=1e-3)
    assert cam.mount.x > 0.0  # at the front


def test_rover_profile_values() -> None:
    """The rover's figures (docs/drivers.md): skid steer as diff drive, 1.5 m/s, 0.8 m
    track, 1.2 m x 0.9 m body, 360 degree lidar, GNSS on."""
    rover = load_robot("rover")
    k = rover.kinematics
    assert (k.type, k.max_vel_x, k.min_vx, k.max_vel_theta, k.wheel_separation) == (
        "diff_drive", 1.5, -0.5, 1.0, 0.8)
    assert rover.footprint_model().circumscribed_radius == pytest.approx(
        math.hypot(0.65, 0.5), abs=1e-6)
    s = rover.sensors
    assert (s.lidar.beams, s.lidar.range_max, s.gnss.enabled, s.imu.rate_hz) == (
        720, 30.0, True, 100.0)
    assert isinstance(rover.kinematic_model(), DiffDrive)


def test_golf_cart_and_omni_profiles() -> None:
    cart = load_robot("golf_cart")
    model = cart.kinematic_model()
    assert isinstance(model, Ackermann)
    assert model.min_turning_radius == pytest.approx(2.4 / math.tan(0.74))
    poly = cart.footprint_model().polygon
    span = poly.max(axis=0) - poly.min(axis=0)
    assert span == pytest.approx([2.9 + 0.1, 1.2 + 0.1])  # 0.05 padding on each side
    lidar = cart.sensors.lidar
    assert lidar.angle_max - lidar.angle_min == pytest.approx(1.5 * math.pi)
    assert lidar.range_max == 30.0
    omni = load_robot("omni")
    assert isinstance(omni.kinematic_model(), Omni)
    assert omni.footprint == ((0.3, 0.25), (0.3, -0.25), (-0.3, -0.25), (-0.3, 0.25))


def test_unknown_key_names_full_path_with_suggestion(tmp_path: Path) -> None:
    path = tmp_path / "bot.yaml"
    path.write_text("kinematics:\n  type: diff_drive\n  max_vel_xx: 0.5\n")
    with pytest.raises(ConfigError) as err:
        load_robot(path)
    assert str(err.value) == (f"{path}: robot.kinematics.max_vel_xx: unknown key "
                              "(did you mean 'max_vel_x'?)")
    assert err.value.key_path == "robot.kinematics.max_vel_xx"

    path.write_text("sensors:\n  lidar:\n    rnage_max: 5.0\n")
    with pytest.raises(ConfigError) as err:
        load_robot(str(path))
    assert str(err.value) == (f"{path}: robot.sensors.lidar.rnage_max: unknown key "
                              "(did you mean 'range_max'?)")


def test_bad_values_name_the_key(tmp_path: Path) -> None:
    path = tmp_path / "bot.yaml"
    path.write_text("sensors:\n  imu:\n    rate_hz: -1\n")
    with pytest.raises(ConfigError) as err:
        load_robot(path)
    assert str(err.value) == f"{path}: robot.sensors.imu.rate_hz: Input should be greater " \
                             "than 0 (got -1)"
    path.write_text("kinematics:\n  type: ackermann\n")
    with pytest.raises(ConfigError, match=r"robot.kinematics.wheelbase: Value error, "
                                          r"wheelbase must be > 0 for an ackermann robot"):
        load_robot(path)
    path.write_text("kinematics: {type: tank}\n")
    with pytest.raises(ConfigError, match=r"robot\.kinematics\.type: Input should be "
                                          r"'diff_drive', 'omni' or 'ackermann'"):
        load_robot(path)
    path.write_text("sensors: {lidar: {range_min: 5.0, range_max: 2.0}}\n")
    with pytest.raises(ConfigError, match=r"robot.sensors.lidar.range_max: Value error, "
                                          r"range_max must be > range_min \(5.0\)"):
        load_robot(path)
    path.write_text("kinematics: [1, 2\n")
    with pytest.raises(ConfigError, match="invalid YAML"):
        load_robot(path)
    path.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="robot: a robot profile must be a mapping"):
        load_robot(path)


def test_unknown_robot_name_lists_known() -> None:
    with pytest.raises(UnknownNameError) as err:
        load_robot("turtlebott")
    assert str(err.value) == ("unknown robot 'turtlebott' (did you mean 'turtlebot'?); "
                              "known: diff_drive, golf_cart, omni, rover, turtlebot, "
                              "turtlebot3_waffle_pi")
    assert err.value.known == ["diff_drive", "golf_cart", "omni", "rover", "turtlebot",
                               "turtlebot3_waffle_pi"]
    with pytest.raises(ConfigError, match="robot profile file not found"):
        load_robot("/nonexistent/robot.yaml")


def test_overrides_and_file_name(tmp_path: Path) -> None:
    tb = load_robot("turtlebot", {"sensors": {"lidar": {"noise_std": 0.0}, "imu":
                                              {"enabled": False}}})
    assert tb.sensors.lidar.noise_std == 0.0
    assert tb.sensors.lidar.beams == 360  # untouched siblings survive the deep merge
    assert tb.sensors.imu.enabled is False
    path = tmp_path / "my_rover.yaml"
    path.write_text("kinematics: {type: DiffDrive, max_vel_x: 1.0}\nrobot_radius: 0.3\n")
    rover = load_robot(path)
    assert rover.name == "my_rover"
    assert rover.kinematics.type == "diff_drive"
    assert rover.kinematics.min_vx == -1.0


def test_footprint_forms() -> None:
    text = robot_from_mapping({"footprint": "[[0.5, 0.3], [0.5, -0.3], [-0.5, -0.3], "
                                            "[-0.5, 0.3]]", "footprint_padding": 0.0})
    listed = robot_from_mapping({"footprint": [[0.5, 0.3], [0.5, -0.3], [-0.5, -0.3],
                                               [-0.5, 0.3]], "footprint_padding": 0.0})
    assert text.footprint == listed.footprint
    fp = text.footprint_model()
    assert fp.inscribed_radius == pytest.approx(0.3)
    assert fp.circumscribed_radius == pytest.approx(math.hypot(0.5, 0.3))
    np.testing.assert_allclose(robot_from_mapping({"footprint": [[1, 1], [1, -1], [-1, 0]],
                                                   "footprint_padding": 0.1})
                               .footprint_model().polygon,
                               [[1.1, 1.1], [1.1, -1.1], [-1.1, 0.0]])
    circle = robot_from_mapping({"footprint": "[]", "robot_radius": 0.3})
    assert circle.footprint is None
    assert circle.footprint_model().radius == pytest.approx(0.31)  # Nav2 padding default 0.01
    with pytest.raises(ConfigError, match=r"robot\.footprint: Value error, footprint needs "
                                          r"at least 3"):
        robot_from_mapping({"footprint": [[0, 0], [1, 1]]})


def test_defaults_are_ideal_sensors() -> None:
    r = RobotParams()
    assert r.robot_radius == 0.1 and r.footprint_padding == 0.01  # Nav2 defaults
    assert r.sensors.lidar.noise_std == 0.0 and r.sensors.odometry.slip_prob == 0.0
    assert r.sensors.imu.gyro_bias == (0.0, 0.0, 0.0)
