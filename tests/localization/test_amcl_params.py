"""AmclParams: Nav2 names and defaults, Nav2 parameter files, typed errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from navstack.core.config_files import load_yaml, ros_parameters
from navstack.core.errors import ConfigError
from navstack.localization.amcl import AmclParams

NAV2_AMCL_YAML = """\
amcl:
  ros__parameters:
    use_sim_time: True
    alpha1: 0.2
    alpha2: 0.2
    alpha3: 0.2
    alpha4: 0.2
    alpha5: 0.2
    base_frame_id: "base_footprint"
    beam_skip_distance: 0.5
    beam_skip_error_threshold: 0.9
    beam_skip_threshold: 0.3
    do_beamskip: false
    global_frame_id: "map"
    lambda_short: 0.1
    laser_likelihood_max_dist: 2.0
    laser_max_range: 100.0
    laser_min_range: -1.0
    laser_model_type: "likelihood_field"
    max_beams: 60
    max_particles: 2000
    min_particles: 500
    odom_frame_id: "odom"
    pf_err: 0.05
    pf_z: 0.99
    recovery_alpha_fast: 0.0
    recovery_alpha_slow: 0.0
    resample_interval: 1
    robot_model_type: "nav2_amcl::OmniMotionModel"
    save_pose_rate: 0.5
    sigma_hit: 0.2
    tf_broadcast: true
    transform_tolerance: 0.5
    update_min_a: 0.2
    update_min_d: 0.25
    z_hit: 0.5
    z_max: 0.05
    z_rand: 0.5
    z_short: 0.05
    scan_topic: scan
    map_topic: map
    set_initial_pose: true
    always_reset_initial_pose: false
    first_map_only: false
    initial_pose:
      x: 1.0
      y: 7.5
      z: 0.0
      yaw: 0.5
"""


def test_defaults_are_nav2s() -> None:
    p = AmclParams()
    assert (p.alpha1, p.alpha5, p.min_particles, p.max_particles) == (0.2, 0.2, 500, 2000)
    assert (p.pf_err, p.pf_z, p.max_beams, p.laser_likelihood_max_dist) == (0.05, 0.99, 60, 2.0)
    assert (p.z_hit, p.z_short, p.z_max, p.z_rand, p.sigma_hit) == (0.5, 0.05, 0.05, 0.5, 0.2)
    assert (p.update_min_d, p.update_min_a, p.transform_tolerance) == (0.25, 0.2, 1.0)
    assert p.robot_model_type == "nav2_amcl::DifferentialMotionModel" and not p.omni
    assert (p.base_frame_id, p.odom_frame_id, p.global_frame_id) == ("base_footprint", "odom",
                                                                     "map")
    assert p.laser_model_type == "likelihood_field" and p.scan_topic == "scan"


def test_nav2_parameter_file_loads(tmp_path: Path) -> None:
    path = tmp_path / "nav2_params.yaml"
    path.write_text(NAV2_AMCL_YAML)
    p = AmclParams.from_mapping(ros_parameters(load_yaml(path), "amcl"), file=str(path))
    assert p.omni and p.transform_tolerance == 0.5 and p.set_initial_pose
    assert (p.initial_pose.x, p.initial_pose.y, p.initial_pose.yaw) == (1.0, 7.5, 0.5)


def test_short_motion_model_names_are_aliases() -> None:
    assert AmclParams(robot_model_type="differential").robot_model_type == \
        "nav2_amcl::DifferentialMotionModel"
    assert AmclParams(robot_model_type="omnidirectional").omni


def test_errors_name_the_key() -> None:
    with pytest.raises(ConfigError) as err:
        AmclParams.from_mapping({"max_particle": 10}, file="nav2.yaml", key_path="amcl")
    assert str(err.value) == ("nav2.yaml: amcl.max_particle: unknown key "
                              "(did you mean 'max_particles'?)")
    with pytest.raises(ConfigError) as err:
        AmclParams.from_mapping({"robot_model_type": "ackermann"})
    assert str(err.value).startswith("robot_model_type: Value error, unknown motion model "
                                     "'ackermann'; use one of 'nav2_amcl::Differential")
    with pytest.raises(ConfigError) as err:
        AmclParams.from_mapping({"min_particles": 3000})
    assert str(err.value) == ("Value error, min_particles (3000) must not exceed max_particles "
                              "(2000) (got {'min_particles': 3000})")
    with pytest.raises(ConfigError) as err:
        AmclParams.from_mapping({"laser_model_type": "ray"})
    assert "laser_model_type" in str(err.value) and "'likelihood_field_prob'" in str(err.value)
