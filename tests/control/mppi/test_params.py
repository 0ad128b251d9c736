"""MPPI parameters: Nav2 names, defaults, YAML layout and error messages."""

from __future__ import annotations

import pytest
import yaml

from navstack.control.mppi import (
    GOLF_CART_MPPI_YAML,
    MPPIController,
    MPPIParams,
    golf_cart_mppi_params,
)
from navstack.core.errors import ConfigError

NAV2_README_YAML = """
controller_server:
  ros__parameters:
    controller_frequency: 30.0
    FollowPath:
      plugin: "nav2_mppi_controller::MPPIController"
      time_steps: 56
      model_dt: 0.05
      batch_size: 2000
      vx_std: 0.2
      vy_std: 0.2
      wz_std: 0.4
      vx_max: 0.5
      vx_min: -0.35
      vy_max: 0.5
      wz_max: 1.9
      iteration_count: 1
      prune_distance: 1.7
      transform_tolerance: 0.1
      temperature: 0.3
      gamma: 0.015
      motion_model: "DiffDrive"
      visualize: false
      regenerate_noises: true
      TrajectoryVisualizer:
        trajectory_step: 5
        time_step: 3
      AckermannConstraints:
        min_turning_r: 0.2
      critics: ["ConstraintCritic", "CostCritic", "GoalCritic", "GoalAngleCritic",
                "PathAlignCritic", "PathFollowCritic", "PathAngleCritic", "PreferForwardCritic"]
      ConstraintCritic:
        enabled: true
        cost_power: 1
        cost_weight: 4.0
      GoalCritic:
        enabled: true
        cost_power: 1
        cost_weight: 5.0
        threshold_to_consider: 1.4
      GoalAngleCritic:
        enabled: true
        cost_power: 1
        cost_weight: 3.0
        threshold_to_consider: 0.5
      PreferForwardCritic:
        enabled: true
        cost_power: 1
        cost_weight: 5.0
        threshold_to_consider: 0.5
      ObstaclesCritic:
        enabled: true
        cost_power: 1
        repulsion_weight: 1.5
        critical_weight: 20.0
        consider_footprint: false
        collision_cost: 10000.0
        collision_margin_distance: 0.1
        near_goal_distance: 0.5
      CostCritic:
        enabled: true
        cost_power: 1
        cost_weight: 3.81
        critical_cost: 300.0
        consider_footprint: false
        collision_cost: 1000000.0
        near_goal_distance: 1.0
        trajectory_point_step: 2
      PathAlignCritic:
        enabled: true
        cost_power: 1
        cost_weight: 14.0
        max_path_occupancy_ratio: 0.05
        trajectory_point_step: 4
        threshold_to_consider: 0.5
        offset_from_furthest: 20
        use_path_orientations: false
      PathFollowCritic:
        enabled: true
        cost_power: 1
        cost_weight: 5.0
        offset_from_furthest: 5
        threshold_to_consider: 1.4
      PathAngleCritic:
        enabled: true
        cost_power: 1
        cost_weight: 2.0
        offset_from_furthest: 4
        threshold_to_consider: 0.5
        max_angle_to_furthest: 1.0
        mode: 0
      TwirlingCritic:
        enabled: true
        cost_power: 1
        cost_weight: 10.0
"""


def _follow_path(text: str) -> dict[str, object]:
    section = dict(yaml.safe_load(text)["controller_server"]["ros__parameters"]["FollowPath"])
    section.pop("plugin")
    return section


def test_nav2_defaults() -> None:
    p = MPPIParams()
    assert (p.batch_size, p.time_steps, p.model_dt, p.iteration_count) == (1000, 56, 0.05, 1)
    assert (p.vx_std, p.vy_std, p.wz_std) == (0.2, 0.2, 0.4)
    assert (p.vx_max, p.vx_min, p.vy_max, p.wz_max) == (0.5, -0.35, 0.5, 1.9)
    assert (p.ax_max, p.ax_min, p.ay_max, p.ay_min, p.az_max) == (3.0, -3.0, 3.0, -3.0, 3.5)
    assert (p.temperature, p.gamma, p.retry_attempt_limit) == (0.3, 0.015, 1)
    assert (p.prune_distance, p.transform_tolerance, p.enforce_path_inversion) == (1.5, 0.1,
                                                                                   False)
    assert p.motion_model == "DiffDrive" and p.AckermannConstraints.min_turning_r == 0.2
    cost, obstacles = p.critic("CostCritic"), p.critic("ObstaclesCritic")
    assert (cost.cost_weight, cost.critical_cost, cost.collision_cost,
            cost.near_collision_cost, cost.trajectory_point_step) == (
        3.81, 300.0, 1000000.0, 253, 2)
    assert (obstacles.repulsion_weight, obstacles.critical_weight,
            obstacles.collision_cost) == (1.5, 20.0, 100000.0)
    goal, align = p.critic("GoalCritic"), p.critic("PathAlignCritic")
    assert (goal.cost_weight, goal.threshold_to_consider) == (5.0, 1.4)
    assert (align.cost_weight, align.offset_from_furthest,
            align.max_path_occupancy_ratio) == (10.0, 20, 0.07)
    angle = p.critic("PathAngleCritic")
    assert (p.critic("PathFollowCritic").offset_from_furthest, angle.cost_weight,
            angle.max_angle_to_furthest) == (6, 2.2, 0.785398)
    assert p.critic("VelocityDeadbandCritic").cost_weight == 35.0
    assert p.critic("TwirlingCritic").cost_weight == 10.0


def test_nav2_readme_yaml_loads_as_is() -> None:
    p = MPPIParams.from_mapping(_follow_path(NAV2_README_YAML))
    assert p.batch_size == 2000 and p.prune_distance == 1.7 and p.regenerate_noises
    assert p.critics[-1] == "PreferForwardCritic" and len(p.critics) == 8
    assert p.critic("PathAlignCritic").cost_weight == 14.0
    assert p.critic("ObstaclesCritic").collision_cost == 10000.0  # section of an unlisted critic
    assert p.critic("TwirlingCritic").cost_weight == 10.0
    ctrl = MPPIController(_follow_path(NAV2_README_YAML))
    assert [c.name for c in ctrl.optimizer.critics] == list(p.critics)


def test_dotted_keys_and_humble_forward_preference() -> None:
    p = MPPIParams.from_mapping({"GoalCritic.cost_weight": 7.0,
                                 "PathAngleCritic": {"forward_preference": False},
                                 "AckermannConstraints.min_turning_r": 1.5})
    assert p.critic("GoalCritic").cost_weight == 7.0
    assert p.critic("PathAngleCritic").mode == 1
    assert p.AckermannConstraints.min_turning_r == 1.5


def test_golf_cart_yaml_matches_dict() -> None:
    loaded = yaml.safe_load(GOLF_CART_MPPI_YAML)["FollowPath"]
    assert loaded == golf_cart_mppi_params()
    section = golf_cart_mppi_params()
    section.pop("plugin")
    p = MPPIParams.from_mapping(section)
    assert (p.time_steps, p.model_dt, p.batch_size) == (56, 0.1, 2000)
    assert (p.motion_model, p.AckermannConstraints.min_turning_r) == ("Ackermann", 5.0)
    assert (p.vx_max, p.vx_min, p.wz_max) == (2.5, -0.35, 1.9)
    assert (p.critic("ConstraintCritic").cost_weight, p.critic("GoalCritic").cost_weight,
            p.critic("GoalCritic").threshold_to_consider) == (4.0, 5.0, 1.4)
    goal_angle = p.critic("GoalAngleCritic")
    assert (goal_angle.cost_weight, goal_angle.threshold_to_consider) == (3.0, 0.5)
    assert (p.critic("PreferForwardCritic").cost_weight,
            p.critic("PreferForwardCritic").threshold_to_consider) == (5.0, 0.5)
    assert (p.critic("PathAlignCritic").cost_weight, p.critic("PathFollowCritic").cost_weight,
            p.critic("PathAngleCritic").cost_weight) == (14.0, 5.0, 2.0)
    assert p.critic("CostCritic").collision_cost == 1e6


def test_batch_size_zero_names_the_key() -> None:
    with pytest.raises(ConfigError) as err:
        MPPIParams.from_mapping({"batch_size": 0}, file="nav2.yaml",
                                key_path="controller_server.FollowPath")
    assert str(err.value) == ("nav2.yaml: controller_server.FollowPath.batch_size: Input "
                              "should be greater than or equal to 1 (got 0)")
    with pytest.raises(ConfigError, match=r"^batch_size: "):
        MPPIController({"batch_size": 0})


def test_negative_turning_radius_names_the_key() -> None:
    with pytest.raises(ConfigError) as err:
        MPPIParams.from_mapping({"motion_model": "Ackermann",
                                 "AckermannConstraints": {"min_turning_r": -1.0}})
    assert str(err.value) == ("AckermannConstraints.min_turning_r: Input should be greater "
                              "than 0 (got -1.0)")


def test_unknown_names_get_suggestions() -> None:
    with pytest.raises(ConfigError) as err:
        MPPIParams.from_mapping({"critics": ["GoalCritc"]})
    assert "unknown critic 'GoalCritc' (did you mean 'GoalCritic'?)" in str(err.value)
    with pytest.raises(ConfigError) as err:
        MPPIParams.from_mapping({"GoalCritc": {"cost_weight": 1.0}})
    assert str(err.value) == "GoalCritc: unknown key (did you mean 'GoalCritic'?)"
    with pytest.raises(ConfigError) as err:
        MPPIParams.from_mapping({"motion_model": "Diff"})
    assert str(err.value).startswith("motion_model: Input should be 'DiffDrive', 'Omni' or "
                                     "'Ackermann'")


def test_range_checks() -> None:
    with pytest.raises(ConfigError, match=r"vx_min .* must not exceed vx_max"):
        MPPIParams.from_mapping({"vx_min": 1.0, "vx_max": 0.5})
    with pytest.raises(ConfigError, match="longer than model_dt"):
        MPPIParams.from_mapping({"controller_frequency": 10.0, "model_dt": 0.05})
    with pytest.raises(ConfigError, match="critics lists a critic twice"):
        MPPIParams.from_mapping({"critics": ["GoalCritic", "GoalCritic"]})
    with pytest.raises(ConfigError, match=r"^temperature: "):
        MPPIParams.from_mapping({"temperature": 0.0})


def test_nav2_sign_handling_and_shift_rule() -> None:
    p = MPPIParams.from_mapping({"ax_max": -2.0, "ax_min": 1.5, "ay_min": 2.0})
    assert p.accel_limits == (2.0, -1.5, 3.0, -2.0, 3.5)
    assert MPPIParams.from_mapping({"controller_frequency": 20.0}).shifts_control_sequence
    assert not MPPIParams.from_mapping({"controller_frequency": 40.0}).shifts_control_sequence
    assert MPPIParams.from_mapping({"shift_control_sequence": True}).shifts_control_sequence


def test_footprint_required_for_consider_footprint() -> None:
    with pytest.raises(ConfigError) as err:
        MPPIController({"CostCritic": {"consider_footprint": True}})
    assert str(err.value).startswith("CostCritic.consider_footprint: consider_footprint is "
                                     "true but the controller was given no footprint")
