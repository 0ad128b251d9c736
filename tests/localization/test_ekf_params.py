"""robot_localization parameter files load as they are; mistakes name file and key."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.localization.ekf import (
    EkfParams,
    UkfParams,
    configuration_diagnostics,
    load_filter_params,
)
from navstack.localization.ekf.params import DBL_MAX
from navstack.nodes.ekf import EkfNode
from navstack.runtime.node import Runtime

# robot_localization's params/ekf.yaml (ROS 2 branches) with its comments trimmed; the
# 225-value process noise matrix is filled in by _write.
RL_EKF_YAML = """\
ekf_filter_node:
    ros__parameters:
        frequency: 30.0
        sensor_timeout: 0.1
        two_d_mode: false
        transform_time_offset: 0.0
        transform_timeout: 0.0
        print_diagnostics: true
        debug: false
        debug_out_file: /path/to/debug/file.txt
        permit_corrected_publication: false
        publish_acceleration: false
        publish_tf: true
        map_frame: map              # Defaults to "map" if unspecified
        odom_frame: odom            # Defaults to "odom" if unspecified
        base_link_frame: base_link  # Defaults to "base_link" if unspecified
        world_frame: odom           # Defaults to the value of odom_frame if unspecified
        odom0: example/odom
        odom0_config: [true,  true,  false,
                       false, false, false,
                       false, false, false,
                       false, false, true,
                       false, false, false]
        odom0_queue_size: 2
        odom0_nodelay: false
        odom0_differential: false
        odom0_relative: false
        odom0_pose_use_child_frame: false
        odom0_pose_rejection_threshold: 5.0
        odom0_twist_rejection_threshold: 1.0
        odom1: example/odom2
        odom1_config: [false, false, true,
                       false, false, false,
                       false, false, false,
                       false, false, true,
                       false, false, false]
        odom1_differential: false
        odom1_relative: true
        odom1_queue_size: 2
        odom1_pose_rejection_threshold: 2.0
        odom1_twist_rejection_threshold: 0.2
        odom1_nodelay: false
        pose0: example/pose
        pose0_config: [true,  true,  false,
                       false, false, false,
                       false, false, false,
                       false, false, false,
                       false, false, false]
        pose0_differential: true
        pose0_relative: false
        pose0_queue_size: 5
        pose0_rejection_threshold: 2.0  # Note the difference in parameter name
        pose0_nodelay: false
        twist0: example/twist
        twist0_config: [false, false, false,
                        false, false, false,
                        true,  true,  true,
                        false, false, false,
                        false, false, false]
        twist0_queue_size: 3
        twist0_rejection_threshold: 2.0
        twist0_nodelay: false
        imu0: example/imu
        imu0_config: [false, false, false,
                      true,  true,  true,
                      false, false, false,
                      true,  true,  true,
                      true,  true,  true]
        imu0_nodelay: false
        imu0_differential: false
        imu0_relative: true
        imu0_queue_size: 5
        imu0_pose_rejection_threshold: 0.8                 # Note the difference in parameter names
        imu0_twist_rejection_threshold: 0.8                #
        imu0_linear_acceleration_rejection_threshold: 0.8  #
        imu0_remove_gravitational_acceleration: true
        use_control: true
        stamped_control: false
        control_timeout: 0.2
        control_config: [true, false, false, false, false, true]
        acceleration_limits: [1.3, 0.0, 0.0, 0.0, 0.0, 3.4]
        deceleration_limits: [1.3, 0.0, 0.0, 0.0, 0.0, 4.5]
        acceleration_gains: [0.8, 0.0, 0.0, 0.0, 0.0, 0.9]
        deceleration_gains: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
        process_noise_covariance: PROCESS_NOISE
        initial_estimate_covariance: [1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e-9]
"""  # noqa: E501


def _write(tmp_path, text: str, name: str = "ekf.yaml"):
    flat = ", ".join(
        str(0.0 if i != j else (0.05, 0.05, 0.06, 0.03, 0.03, 0.06, 0.025, 0.025, 0.04, 0.01,
                                0.01, 0.02, 0.01, 0.01, 0.015)[i])
        for i in range(15) for j in range(15))
    path = tmp_path / name
    path.write_text(text.replace("PROCESS_NOISE", f"[{flat}]"))
    return path


def test_robot_localization_example_file_loads_as_is(tmp_path) -> None:
    path = _write(tmp_path, RL_EKF_YAML)
    p = load_filter_params(path)
    assert [s.name for s in p.sensors] == ["odom0", "odom1", "pose0", "twist0", "imu0"]
    odom0 = p.sensor("odom0")
    assert odom0.topic == "example/odom" and odom0.queue_size == 2
    assert odom0.config == (True, True) + (False,) * 9 + (True,) + (False,) * 3
    assert (odom0.pose_rejection_threshold, odom0.twist_rejection_threshold) == (5.0, 1.0)
    assert p.sensor("odom1").use_relative
    pose0 = p.sensor("pose0")  # "pose0_rejection_threshold" is the pose threshold
    assert pose0.use_differential and pose0.pose_rejection_threshold == 2.0
    assert p.sensor("twist0").twist_rejection_threshold == 2.0
    imu0 = p.sensor("imu0")
    assert imu0.remove_gravitational_acceleration
    assert imu0.linear_acceleration_rejection_threshold == 0.8
    assert p.timeout == 0.1 and p.world == "odom" and p.use_control
    np.testing.assert_array_equal(np.diag(p.process_noise),
                                  [0.05, 0.05, 0.06, 0.03, 0.03, 0.06, 0.025, 0.025, 0.04,
                                   0.01, 0.01, 0.02, 0.01, 0.01, 0.015])
    assert np.count_nonzero(p.process_noise) == 15
    np.testing.assert_array_equal(p.initial_covariance, np.eye(15) * 1e-9)
    # and a node can be built and brought up from it
    rt = Runtime()
    node = EkfNode(rt, p)
    rt.bring_up()
    for topic in ("/example/odom", "/example/odom2", "/example/pose", "/example/twist",
                  "/example/imu", "/cmd_vel"):
        assert rt.bus.topics[topic].subscriptions, topic
    assert node.diagnostics == []  # every pose variable has exactly one absolute source


def test_configuration_diagnostics_as_robot_localization() -> None:
    x_only = [True] + [False] * 14
    p = EkfParams.from_mapping({"two_d_mode": True, "odom0": "a", "odom0_config": x_only,
                                "pose0": "b", "pose0_config": x_only})
    assert configuration_diagnostics(p) == [
        "2 absolute pose inputs detected for x; this may result in oscillations: make sure "
        "their variances are set appropriately",
        "neither y nor its velocity is measured: its error will grow without bound",
        "neither yaw nor its velocity is measured: its error will grow without bound"]


def test_fourteen_element_config_names_file_and_key(tmp_path) -> None:
    path = tmp_path / "ekf.yaml"
    path.write_text("ekf_filter_node:\n  ros__parameters:\n    odom0: odom\n"
                    "    odom0_config: [false, false, false, false, false, false, true, false,"
                    " false, false, false, true, false, false]\n")
    with pytest.raises(ConfigError) as err:
        load_filter_params(path)
    assert str(err.value) == (
        f"{path}: ekf_filter_node.odom0_config: must list 15 booleans (x, y, z, roll, pitch, "
        "yaw, vx, vy, vz, vroll, vpitch, vyaw, ax, ay, az), got 14")


def test_defaults_are_robot_localizations() -> None:
    p = EkfParams()
    assert p.frequency == 30.0 and p.timeout == pytest.approx(1 / 30)
    assert p.world == "odom" and p.base_link_output == "base_link" and p.publish_tf
    assert not p.two_d_mode and not p.print_diagnostics and not p.predict_to_current_time
    np.testing.assert_array_equal(
        np.diag(p.process_noise), [0.05, 0.05, 0.06, 0.03, 0.03, 0.06, 0.025, 0.025, 0.04,
                                   0.01, 0.01, 0.02, 0.01, 0.01, 0.015])
    np.testing.assert_array_equal(p.initial_covariance, np.eye(15) * 1e-9)
    u = UkfParams()
    assert (u.alpha, u.kappa, u.beta) == (0.001, 0.0, 2.0)
    s = EkfParams.from_mapping({"twist0": "t"}).sensor("twist0")
    assert s.queue_size == 10 and s.twist_rejection_threshold == DBL_MAX
    prefixed = EkfParams.from_mapping({"tf_prefix": "/robot1", "world_frame": "map"})
    assert (prefixed.world, prefixed.odom_frame, prefixed.base_link_output) == (
        "robot1/map", "robot1/odom", "robot1/base_link")


def test_sensor_mistakes_are_named() -> None:
    with pytest.raises(ConfigError) as err:
        EkfParams.from_mapping({"odom0": "odom", "odom0_diferential": True},
                               file="f.yaml", key_path="ekf_filter_node")
    assert str(err.value) == ("f.yaml: ekf_filter_node.odom0_diferential: unknown key for "
                              "odom input 'odom0' (did you mean 'odom0_differential'?)")
    with pytest.raises(ConfigError) as err:
        EkfParams.from_mapping({"imu0": "imu", "imu1_config": [True] * 15},
                               key_path="ekf_filter_node")
    assert "ekf_filter_node.imu1: options for 'imu1' are set but its topic is not" in str(
        err.value)
    with pytest.raises(ConfigError) as err:
        EkfParams.from_mapping({"pose1": "p"}, key_path="ekf_filter_node")
    assert "'pose1' is set but 'pose0' is not" in str(err.value)
    with pytest.raises(ConfigError) as err:
        EkfParams.from_mapping({"process_noise_covariance": [0.1] * 14}, key_path="n")
    assert str(err.value) == ("n.process_noise_covariance: must list 225 values (row-major "
                              "15 x 15) or 15 (the diagonal), got 14")
    with pytest.raises(ConfigError) as err:
        EkfParams.from_mapping({"odom0": "odom", "odom0_queue_size": 0}, key_path="n")
    assert str(err.value).startswith("n.odom0_queue_size: Input should be greater than")
    with pytest.raises(ConfigError) as err:
        EkfParams.from_mapping({"world_frame": "earth"})
    assert "world_frame must be map_frame ('map') or odom_frame ('odom')" in str(err.value)
