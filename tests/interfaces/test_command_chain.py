"""The command chain's parameters: defaults from the robot, and broken links refused."""

from __future__ import annotations

from typing import Any

import pytest

from navstack.core.errors import ConfigError
from navstack.interfaces.command_chain import command_chain
from navstack.interfaces.stack import default_nav2_params_path
from navstack.runtime.config import load_yaml
from navstack.sim.robot import load_robot


def test_packaged_chain_links_controller_to_base() -> None:
    chain = command_chain(load_yaml(default_nav2_params_path()), "nav2.yaml",
                          load_robot("diff_drive"))
    assert chain.controller_server["cmd_vel_topic"] == "/cmd_vel_nav"
    assert chain.velocity_smoother.cmd_vel_out_topic == chain.collision_monitor.cmd_vel_in_topic
    assert chain.collision_monitor.cmd_vel_out_topic == "/nav_vel"
    assert [e.topic for e in chain.twist_mux.locks] == ["/emergency_stop"]
    # the body zone against every point, the body + 0.12 m against what the map does not
    # explain (docs/command_path.md, "Clearance")
    monitor = chain.collision_monitor
    assert monitor.polygons == ["FootprintApproach", "MovingApproach"]
    assert monitor.polygon_params["MovingApproach"].footprint_padding == 0.12
    assert monitor.polygon_params["MovingApproach"].sources_names == ["scan_unmapped"]
    assert monitor.source_params["scan_unmapped"].exclude_map_obstacles == 0.15


def test_file_without_sections_gets_robot_limits_and_body_approach() -> None:
    chain = command_chain({}, "user.yaml", load_robot("golf_cart"))
    sm = chain.velocity_smoother
    assert sm.max_velocity == (2.5, 0.0, 1.0) and sm.min_velocity == (-0.35, 0.0, -1.0)
    assert sm.max_accel == (1.0, 0.0, 20.0)  # Ackermann: yaw rate not rate limited
    assert chain.behavior_server["cmd_vel_topic"] == "/cmd_vel_nav"
    assert chain.collision_monitor.polygons == ["FootprintApproach"]
    assert chain.twist_mux.topics[0].topic == "/nav_vel"


MONITOR: dict[str, Any] = {
    "polygons": ["Stop"], "Stop": {"type": "circle", "radius": 0.3, "action_type": "stop"},
    "observation_sources": ["scan"], "scan": {"type": "scan", "topic": "scan"}}


def test_a_stock_nav2_monitor_feeds_the_mux() -> None:
    """Nav2's stock file: relative topics, the monitor's output on cmd_vel (Nav2 has no
    mux), Humble's max_points -> remapped to the mux's navigation input, min_points + 1."""
    monitor = {**MONITOR, "cmd_vel_in_topic": "cmd_vel_smoothed",
               "cmd_vel_out_topic": "cmd_vel",
               "Stop": {"type": "circle", "radius": 0.3, "action_type": "stop",
                        "max_points": 3}}
    chain = command_chain({"collision_monitor": {"ros__parameters": monitor}}, "user.yaml",
                          load_robot("diff_drive"))
    assert chain.collision_monitor.cmd_vel_out_topic == "/nav_vel"
    assert chain.collision_monitor.polygon_params["Stop"].min_points == 4


@pytest.mark.parametrize(("nav", "message"), [
    ({"controller_server": {"ros__parameters": {"cmd_vel_topic": "/cmd_vel"}}},
     r"user.yaml: controller_server.ros__parameters.cmd_vel_topic: publishes on '/cmd_vel', "
     r"outside the command chain \(use the velocity smoother's input '/cmd_vel_nav'"),
    ({"velocity_smoother": {"ros__parameters": {"cmd_vel_out_topic": "/smooth"}}},
     r"velocity_smoother.ros__parameters.cmd_vel_out_topic: '/smooth' does not feed "
     r"collision_monitor.ros__parameters.cmd_vel_in_topic \('/cmd_vel_smoothed'\)"),
    ({"collision_monitor": {"ros__parameters": {**MONITOR, "cmd_vel_out_topic": "/nav"}}},
     r"collision_monitor.ros__parameters.cmd_vel_out_topic: '/nav' is not an input of "
     r"the twist_mux \(/nav_vel, /key_vel, /joy_vel\)"),
    ({"collision_monitor": {"ros__parameters": {**MONITOR, "cmd_vel_out_topic": "cmd_vel"}},
      "twist_mux": {"ros__parameters": {"topics": {
          "auto": {"topic": "/auto_vel", "timeout": 0.5, "priority": 10}}}}},
     r"collision_monitor.ros__parameters.cmd_vel_out_topic: publishes on the base's "
     r"/cmd_vel, which the twist_mux owns \(publish on one of the twist_mux inputs "
     r"\(/auto_vel\)\)"),
    ({"collision_monitor": {"ros__parameters": {"base_frame_id": "base_footprint"}}},
     r"collision_monitor.ros__parameters.polygons: collision_monitor needs 'polygons' "
     r"\(Nav2 requires it\)"),
    ({"velocity_smoother": {"ros__parameters": {"max_decel": [1.0, 0.0, -1.0]}}},
     r"velocity_smoother: Value error, max_decel vx must be <= 0"),
])
def test_broken_chains_are_config_errors(nav: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        command_chain(nav, "user.yaml", load_robot("diff_drive"))


def test_a_partial_file_merged_over_the_packaged_one_keeps_the_robot_limits() -> None:
    # the golf cart's Nav2 file has no velocity_smoother section: the packaged one is
    # merged in, and its limits come from the golf cart's profile, not the diff drive's
    from navstack.interfaces.demo import demo_setup
    from navstack.navigation.nav2_params import load_nav2_params

    path = demo_setup("golf_cart").nav2_params
    assert path is not None
    nav = load_nav2_params(path)
    assert "velocity_smoother" in nav.from_defaults
    chain = command_chain(nav.data, nav.file, load_robot("golf_cart"))
    assert chain.velocity_smoother.max_velocity == (2.5, 0.0, 1.0)
    assert chain.velocity_smoother.smoothing_frequency == 20.0  # the packaged section's
