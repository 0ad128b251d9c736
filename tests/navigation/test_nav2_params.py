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
  ros__parameters:
    smoothing_frequency: 20.0
    max_velocity: [0.5, 0.0, 2.0]
    min_velocity: [-0.5, 0.0, -2.0]
    odom_topic: "odom"
collision_monitor:
  ros__parameters:
    base_frame_id: "base_footprint"
    odom_frame_id: "odom"
    cmd_vel_in_topic: "cmd_vel_smoothed"
    cmd_vel_out_topic: "cmd_vel"
    state_topic: "collision_monitor_state"
    polygons: ["FootprintApproach"]
    FootprintApproach:
      type: "polygon"
      action_type: "approach"
      footprint_topic: "/local_costmap/published_footprint"
      time_before_collision: 1.2
      simulation_time_step: 0.1
      min_points: 6
    observation_sources: ["scan"]
    scan: {type: "scan", topic: "scan", min_height: 0.15, max_height: 2.0}
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
                             "behavior_server", "waypoint_follower", "velocity_smoother",
                             "collision_monitor")
    assert set(nav.from_defaults) == {"planner_server", "global_costmap", "amcl",
                                      "twist_mux"}
    assert nav.notes == [
        f"{path}: sections from the file: bt_navigator, controller_server, local_costmap, "
        "behavior_server, waypoint_follower, velocity_smoother, collision_monitor; from the "
        "packaged defaults (nav2_params.yaml): " + ", ".join(nav.from_defaults),
        f"{path}: sections of nodes navstack does not run, ignored: map_saver, "
        "docking_server, robot_state_publisher, lifecycle_manager_navigation",
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
    # the file's command chain runs: its smoother limits, its monitor (Nav2's relative
    # topics, base_footprint) in front of the packaged twist_mux
    assert stack.velocity_smoother.params.max_velocity == (0.5, 0.0, 2.0)
    monitor = stack.collision_monitor.params
    assert monitor.cmd_vel_out_topic == "/nav_vel"  # Nav2's "cmd_vel", remapped to the mux
    assert monitor.polygon_params["FootprintApproach"].min_points == 6
    stack.run_for(1.0)
    assert stack.collision_monitor.monitor_state()["action"] == "do_nothing"


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


def test_command_chain_sections_are_checked_whole() -> None:
    """velocity_smoother, collision_monitor and twist_mux are read, not ignored: their
    values, polygon/source sections and mux entries are checked with the file's keys."""
    square = [[0.3, 0.3], [0.3, -0.3], [-0.3, -0.3], [-0.3, 0.3]]
    with pytest.raises(ConfigErrors) as info:
        check_nav2_data({
            "velocity_smoother": {"ros__parameters": {"smoothing_frequency": -1.0,
                                                      "feedback": "OPEN"}},
            "collision_monitor": {"ros__parameters": {
                "polygons": ["Stop", "Slow"], "observation_sources": ["scan"],
                "Stop": {"type": "polygon", "action_type": "stop", "points": square,
                         "slowdown_ration": 0.3},
                "scan": {"type": "scan", "topic": "scan"}}},
            "twist_mux": {"ros__parameters": {
                "topics": {"navigation": {"topic": "nav_vel", "timeout": 0.5,
                                          "priorty": 10}},
                "locks": {"e_stop": {"topic": "e_stop", "timeout": 0.0, "priority": 300}}}},
        }, "f.yaml")
    assert str(info.value).splitlines() == [
        "f.yaml: velocity_smoother.ros__parameters.smoothing_frequency: Input should be "
        "greater than 0 (got -1.0)",
        "f.yaml: velocity_smoother.ros__parameters.feedback: Input should be 'OPEN_LOOP' or "
        "'CLOSED_LOOP' (got 'OPEN')",
        "f.yaml: collision_monitor.ros__parameters.Slow: polygon 'Slow' has no section "
        "(add 'Slow: {type: ...}' beside the list)",
        "f.yaml: twist_mux.ros__parameters.topics.navigation.priority: required key is "
        "missing",
        "f.yaml: twist_mux.ros__parameters.topics.navigation.priorty: unknown key",
        "f.yaml: twist_mux.ros__parameters.locks.e_stop.priority: Input should be less than "
        "or equal to 255 (got 300)"]
    with pytest.raises(ConfigError, match=r"^f\.yaml: collision_monitor\.ros__parameters\."
                                          r"Stop\.slowdown_ration: unknown key \(did you "
                                          r"mean 'slowdown_ratio'\?\)$"):
        check_nav2_data({"collision_monitor": {"ros__parameters": {
            "polygons": ["Stop"], "observation_sources": [],
            "Stop": {"type": "polygon", "action_type": "stop", "points": square,
                     "slowdown_ration": 0.3}}}}, "f.yaml")
    with pytest.raises(ConfigError, match=r"^f\.yaml: twist_mux\.ros__parameters\.topic: "
                                          r"unknown twist_mux parameter \(did you mean "
                                          r"'topics'\?\)$"):
        check_nav2_data({"twist_mux": {"ros__parameters": {"topic": {}}}}, "f.yaml")
    with pytest.raises(ConfigErrors, match=r"collision_monitor\.ros__parameters\."
                                           r"observation_sources: collision_monitor needs "
                                           r"'observation_sources' \(Nav2 requires it\)"):
        check_nav2_data({"collision_monitor": {"ros__parameters": {"stop_pub_timeout": 1.0}}},
                        "f.yaml")
    # a valid section in the ROS 2 layout passes and is kept as it is
    nav = check_nav2_data({"twist_mux": {"ros__parameters": {
        "topics": {"navigation": {"topic": "cmd_vel_nav", "timeout": 0.5, "priority": 50}},
        "locks": {"e_stop_lock": {"topic": "e_stop", "timeout": 0.0, "priority": 255}}}}},
        "f.yaml")
    assert nav.data["twist_mux"]["ros__parameters"]["locks"] == {
        "e_stop_lock": {"topic": "e_stop", "timeout": 0.0, "priority": 255}}


def test_mission_sections_load_without_a_note() -> None:
    """The TurtleBot3 file's ``explore_node`` (explore_lite's node) and a ``coverage``
    section are the missions' (navigation.nav2_params.MISSION_SECTIONS), ``slam_toolbox``
    the SLAM node's: accepted, not noted as ignored (the SLAM node reads its section: the
    note "sections of nodes navstack does not run" misled), not passed to any server; an
    unknown section is still an error."""
    data = {"controller_server": {"ros__parameters": {"controller_frequency": 20.0}},
            "explore_node": {"ros__parameters": {"potential_scale": 1e-3}},
            "coverage": {"ros__parameters": {"cell_size": 0.8}},
            "slam_toolbox": {"ros__parameters": {"resolution": 0.05}}}
    nav = check_nav2_data(data, "f.yaml")
    assert nav.notes == []
    assert not {"explore_node", "coverage", "slam_toolbox"} & set(nav.data)
    with pytest.raises(ConfigError, match="unknown section"):
        check_nav2_data({**data, "explore": {"ros__parameters": {}}}, "f.yaml")
