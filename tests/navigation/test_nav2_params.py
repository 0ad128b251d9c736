"""Nav2 parameter files: a file laid out like nav2_bringup's loads (other nodes and
Nav2-only keys noted), partial files merge over the defaults, mistakes are named."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
import yaml

from navstack.core.errors import ConfigError, ConfigErrors
from navstack.navigation.nav2_params import (
    check_nav2_data,
    load_nav2_params,
    packaged_nav2_params_path,
)

# the layout of a Humble/Jazzy nav2_bringup file: nodes navstack does not run, Nav2 keys
# it does not use, ROS node keys, plugin sections (behaviors, navigators, task executor)
BRINGUP_STYLE = """
/**:
  ros__parameters:
    use_sim_time: true
bt_navigator:
  ros__parameters:
    global_frame: map
    odom_topic: /odom
    bt_loop_duration: 0.01
    default_server_timeout: 20.0
    plugin_lib_names: [nav2_compute_path_to_pose_action_bt_node]
    navigators: [navigate_to_pose, navigate_through_poses]
    navigate_to_pose: {plugin: nav2_bt_navigator::NavigateToPoseNavigator}
    navigate_through_poses: {plugin: nav2_bt_navigator::NavigateThroughPosesNavigator}
    error_code_names: [compute_path_error_code]
controller_server:
  ros__parameters:
    controller_frequency: 20.0
    costmap_update_timeout: 0.3
    progress_checker_plugins: [progress_checker]
    goal_checker_plugins: [general_goal_checker]
    controller_plugins: [FollowPath]
    progress_checker: {plugin: nav2_controller::SimpleProgressChecker}
    general_goal_checker: {plugin: nav2_controller::SimpleGoalChecker}
    precise_goal_checker: {plugin: nav2_controller::SimpleGoalChecker}
    FollowPath: {plugin: dwb_core::DWBLocalPlanner}
local_costmap:
  local_costmap:
    ros__parameters:
      global_frame: odom
      rolling_window: true
      introspection_mode: disabled
behavior_server:
  ros__parameters:
    local_costmap_topic: local_costmap/costmap_raw
    behavior_plugins: [spin, backup, wait]
    spin: {plugin: nav2_behaviors::Spin}
    backup: {plugin: nav2_behaviors::BackUp}
    wait: {plugin: nav2_behaviors::Wait}
    cycle_frequency: 10.0
waypoint_follower:
  ros__parameters:
    loop_rate: 20
    waypoint_task_executor_plugin: wait_at_waypoint
    wait_at_waypoint: {plugin: nav2_waypoint_follower::WaitAtWaypoint}
map_saver:
  ros__parameters: {save_map_timeout: 5.0}
velocity_smoother:
  ros__parameters: {smoothing_frequency: 20.0}
collision_monitor:
  ros__parameters: {base_frame_id: base_footprint}
docking_server:
  ros__parameters: {controller_frequency: 50.0}
robot_state_publisher:
  ros__parameters: {use_sim_time: true}
lifecycle_manager_navigation:
  ros__parameters: {autostart: true}
"""


def test_a_bringup_style_file_loads_with_notes(tmp_path: Path,
                                               caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "nav2.yaml"
    path.write_text(BRINGUP_STYLE)
    with caplog.at_level(logging.INFO, logger="navstack.config"):
        nav = load_nav2_params(path)
    assert nav.file == str(path)
    assert nav.from_file == ("bt_navigator", "controller_server", "local_costmap",
                             "behavior_server", "waypoint_follower")
    assert set(nav.from_defaults) == {"planner_server", "global_costmap", "amcl"}
    assert nav.notes == [
        f"{path}: sections from the file: bt_navigator, controller_server, local_costmap, "
        "behavior_server, waypoint_follower; from the packaged defaults (nav2_params.yaml): "
        + ", ".join(nav.from_defaults),
        f"{path}: sections of nodes navstack does not run, ignored: map_saver, "
        "velocity_smoother, collision_monitor, docking_server, robot_state_publisher, "
        "lifecycle_manager_navigation",
        f"{path}: Nav2 parameters navstack does not use, ignored: bt_navigator.odom_topic, "
        "bt_navigator.plugin_lib_names, "
        "bt_navigator.navigate_to_pose, bt_navigator.navigate_through_poses, "
        "bt_navigator.error_code_names, controller_server.costmap_update_timeout, "
        "controller_server.precise_goal_checker, behavior_server.local_costmap_topic, "
        "waypoint_follower.loop_rate, "
        "waypoint_follower.waypoint_task_executor_plugin, waypoint_follower.wait_at_waypoint"]
    assert [r.levelname for r in caplog.records] == ["INFO", "WARNING", "WARNING"]
    # what the servers get: their own keys and plugin sections, nothing else
    bt = nav.data["bt_navigator"]["ros__parameters"]
    assert bt == {"global_frame": "map", "bt_loop_duration": 0.01,
                  "default_server_timeout": 20.0,
                  "navigators": ["navigate_to_pose", "navigate_through_poses"]}
    behaviors = nav.data["behavior_server"]["ros__parameters"]
    assert behaviors == {"cycle_frequency": 10.0, "behavior_plugins": ["spin", "backup", "wait"],
                         "spin": {"plugin": "nav2_behaviors::Spin"},
                         "backup": {"plugin": "nav2_behaviors::BackUp"},
                         "wait": {"plugin": "nav2_behaviors::Wait"}}
    local = nav.data["local_costmap"]["local_costmap"]["ros__parameters"]
    # the costmap model declares use_sim_time and introspection_mode (from the wildcard)
    assert local == {"use_sim_time": True, "global_frame": "odom", "rolling_window": True,
                     "introspection_mode": "disabled"}
    assert "/**" not in nav.data and "map_saver" not in nav.data


def test_the_stack_runs_on_a_bringup_style_file(tmp_path: Path) -> None:
    from navstack.interfaces.stack import NavStack

    path = tmp_path / "nav2.yaml"
    path.write_text(BRINGUP_STYLE)
    stack = NavStack("office", nav2_params=path).start()
    assert stack.controller.params.controller_frequency == 20.0
    assert stack.behaviors.params.cycle_frequency == 10.0


def test_the_packaged_file_needs_no_notes() -> None:
    nav = load_nav2_params()
    assert nav.notes == [] and nav.from_file == ()
    assert nav.file == str(packaged_nav2_params_path())
    packaged = yaml.safe_load(packaged_nav2_params_path().read_text())
    assert set(nav.data) == set(packaged)


def test_wildcard_keys_reach_the_servers_that_have_them() -> None:
    nav = check_nav2_data({"/**": {"ros__parameters": {"robot_base_frame": "base_footprint"}},
                           "bt_navigator": {"ros__parameters": {}},
                           "behavior_server": {"ros__parameters": {"robot_base_frame": "b"}}},
                          "f.yaml")
    assert nav.data["bt_navigator"]["ros__parameters"] == {"robot_base_frame": "base_footprint"}
    assert nav.data["behavior_server"]["ros__parameters"] == {"robot_base_frame": "b"}


def test_every_mistake_of_a_file_is_reported_at_once() -> None:
    with pytest.raises(ConfigErrors) as info:
        check_nav2_data({"controller_server": {"ros__parameters": {"controller_frequncy": 1,
                                                                   "failure_tolerance": 1}},
                         "planer_server": {"ros__parameters": {}},
                         "bt_navigator": {"ros__parameter": {}}}, "f.yaml")
    assert str(info.value).splitlines() == [
        "f.yaml: planer_server: unknown section (did you mean 'planner_server'?)",
        "f.yaml: controller_server.ros__parameters.controller_frequncy: unknown "
        "controller_server parameter (did you mean 'controller_frequency'?)",
        "f.yaml: bt_navigator: missing 'ros__parameters' (did you mean 'ros__parameters'?)"]
    with pytest.raises(ConfigError, match=r"f\.yaml: global_costmap: must be a mapping"):
        check_nav2_data({"global_costmap": 3}, "f.yaml")
