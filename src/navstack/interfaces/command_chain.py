"""The default command chain's parameters, resolved and checked (``docs/command_path.md``).

controller / behavior servers -> ``/cmd_vel_nav`` -> velocity smoother ->
``/cmd_vel_smoothed`` -> collision monitor -> ``/nav_vel`` -> twist_mux -> ``/cmd_vel`` ->
base.  A Nav2 parameter file's ``velocity_smoother``, ``collision_monitor`` and
``twist_mux`` sections configure the stages; a file without them gets:

* velocity smoother: the robot profile's limits (``max_vel_x``, ``min_vel_x``,
  ``max_vel_theta``, ``acc_lim_x``, ``acc_lim_theta``; an Ackermann base's yaw rate
  follows its steering, so its ``wz`` is not rate limited here);
* collision monitor: an ``approach`` zone on the robot body (the stack's monitor before
  issue 18) on ``/scan``;
* twist_mux: navigation (``/nav_vel``, priority 10), keyboard (``/key_vel``, 90), joystick
  (``/joy_vel``, 100), all 0.5 s, and the e-stop lock ``/emergency_stop`` (255, 0.0).

Servers whose ``cmd_vel_topic`` is not set publish into the chain (``/cmd_vel_nav``); the
stages must connect (each output is the next input, the monitor's output one of the mux's
inputs, the mux's output ``/cmd_vel``), else a ``ConfigError`` names the keys.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from navstack.control.collision_monitor import CollisionMonitorParams, collision_monitor_params
from navstack.control.twist_mux import TwistMuxParams, twist_mux_params
from navstack.control.velocity_smoother import VelocitySmootherParams
from navstack.core.config_files import ros_parameters
from navstack.core.errors import ConfigError
from navstack.sim.robot import RobotParams

__all__ = ["BASE_TOPIC", "CommandChain", "command_chain"]

log = logging.getLogger("navstack.config")

BASE_TOPIC = "/cmd_vel"
"""What the base (simulator or driver) listens to."""

DEFAULT_MONITOR: dict[str, Any] = {
    "cmd_vel_in_topic": "/cmd_vel_smoothed", "cmd_vel_out_topic": "/nav_vel",
    "source_timeout": 1.0,
    "polygons": ["FootprintApproach"],
    "FootprintApproach": {"type": "polygon", "action_type": "approach",
                          "footprint_topic": "/local_costmap/published_footprint",
                          "time_before_collision": 1.2, "simulation_time_step": 0.1,
                          "min_points": 1},
    "observation_sources": ["scan"],
    "scan": {"type": "scan", "topic": "/scan"},
}

DEFAULT_MUX: dict[str, Any] = {
    "topics": {"navigation": {"topic": "/nav_vel", "timeout": 0.5, "priority": 10},
               "keyboard": {"topic": "/key_vel", "timeout": 0.5, "priority": 90},
               "joystick": {"topic": "/joy_vel", "timeout": 0.5, "priority": 100}},
    "locks": {"e_stop_lock": {"topic": "/emergency_stop", "timeout": 0.0, "priority": 255}},
}


@dataclass(frozen=True)
class CommandChain:
    """The three stages' parameters and the servers' sections with their output topic."""

    velocity_smoother: VelocitySmootherParams
    collision_monitor: CollisionMonitorParams
    twist_mux: TwistMuxParams
    controller_server: Mapping[str, Any]
    behavior_server: Mapping[str, Any]


def _smoother_defaults(robot: RobotParams) -> dict[str, Any]:
    k = robot.kinematics
    vmin = k.min_vel_x if k.min_vel_x is not None else -k.max_vel_x
    freq = 20.0
    # an Ackermann base's yaw rate follows speed and steering: do not rate limit it
    wz_acc = k.max_vel_theta * freq if k.type == "ackermann" else k.acc_lim_theta
    return {"smoothing_frequency": freq,
            "max_velocity": [k.max_vel_x, k.max_vel_y, k.max_vel_theta],
            "min_velocity": [vmin, -k.max_vel_y, -k.max_vel_theta],
            "max_accel": [k.acc_lim_x, k.acc_lim_y, wz_acc],
            "max_decel": [-k.acc_lim_x, -k.acc_lim_y, -wz_acc]}


def _abs(topic: str) -> str:
    """A topic name as the bus resolves it (Nav2's relative names live in ``/``)."""
    return topic if topic.startswith("/") else "/" + topic


def command_chain(nav: Mapping[str, Any], file: str, robot: RobotParams) -> CommandChain:
    """Resolve and check the chain of a Nav2 parameter file's data ``nav``.

    A stock Nav2 file's collision monitor publishes on ``cmd_vel`` (Nav2 has no mux): the
    twist_mux owns the base's topic, so that output is remapped to the mux's
    ``navigation`` input, as a launch file would remap it, with a note."""
    smoother_raw = ros_parameters(nav, "velocity_smoother", file=file)
    smoother = VelocitySmootherParams.from_mapping(
        {**_smoother_defaults(robot), **smoother_raw}, file=file,
        key_path="velocity_smoother")
    monitor_raw = dict(ros_parameters(nav, "collision_monitor", file=file) or DEFAULT_MONITOR)
    for key in ("polygons", "observation_sources"):
        if key not in monitor_raw:  # Nav2 declares both without a default
            raise ConfigError(f"collision_monitor needs '{key}' (Nav2 requires it)",
                              file=file, key_path=f"collision_monitor.ros__parameters.{key}",
                              suggestion="see the packaged nav2_params.yaml's "
                                         "collision_monitor section")
    mux = twist_mux_params(nav if "twist_mux" in nav else {"twist_mux": {
        "ros__parameters": DEFAULT_MUX}}, file=file)
    out_topic = str(monitor_raw.get("cmd_vel_out_topic", "/cmd_vel"))
    if _abs(out_topic) == BASE_TOPIC:
        nav_input = next((e.topic for e in mux.topics if e.name == "navigation"), None)
        if nav_input is None:
            raise ConfigError(
                f"publishes on the base's {BASE_TOPIC}, which the twist_mux owns",
                file=file, key_path="collision_monitor.ros__parameters.cmd_vel_out_topic",
                suggestion="publish on one of the twist_mux inputs "
                           f"({', '.join(e.topic for e in mux.topics)})")
        log.info("%s: collision_monitor.cmd_vel_out_topic %r remapped to %r, the twist_mux's "
                 "navigation input (the mux owns %s; docs/command_path.md)",
                 file, out_topic, nav_input, BASE_TOPIC)
        monitor_raw["cmd_vel_out_topic"] = nav_input
    monitor = collision_monitor_params(monitor_raw, file=file, key_path="collision_monitor")
    controller = dict(ros_parameters(nav, "controller_server", file=file))
    behavior = dict(ros_parameters(nav, "behavior_server", file=file))
    smoother_in = _abs(smoother.cmd_vel_in_topic)
    for name, section in (("controller_server", controller), ("behavior_server", behavior)):
        section.setdefault("cmd_vel_topic", smoother_in)
        if _abs(section["cmd_vel_topic"]) != smoother_in:
            raise ConfigError(
                f"publishes on {section['cmd_vel_topic']!r}, outside the command chain",
                file=file, key_path=f"{name}.ros__parameters.cmd_vel_topic",
                suggestion=f"use the velocity smoother's input {smoother_in!r}"
                           " (docs/command_path.md)")
    if _abs(smoother.cmd_vel_out_topic) != _abs(monitor.cmd_vel_in_topic):
        raise ConfigError(
            f"{smoother.cmd_vel_out_topic!r} does not feed collision_monitor.ros__parameters."
            f"cmd_vel_in_topic ({monitor.cmd_vel_in_topic!r})", file=file,
            key_path="velocity_smoother.ros__parameters.cmd_vel_out_topic",
            suggestion="make them the same topic")
    inputs = {_abs(e.topic): e.name for e in mux.topics}
    if _abs(monitor.cmd_vel_out_topic) not in inputs:
        raise ConfigError(
            f"{monitor.cmd_vel_out_topic!r} is not an input of the twist_mux "
            f"({', '.join(inputs)})", file=file,
            key_path="collision_monitor.ros__parameters.cmd_vel_out_topic",
            suggestion="add it to twist_mux topics: (the navigation input)")
    if mux.use_stamped:
        raise ConfigError("the servers and the simulated base use geometry_msgs/Twist",
                          file=file, key_path="twist_mux.ros__parameters.use_stamped",
                          suggestion="set it to false in a NavStack")
    if _abs(mux.cmd_vel_out) != BASE_TOPIC:
        raise ConfigError(f"the base listens on {BASE_TOPIC}, not {mux.cmd_vel_out!r}",
                          file=file, key_path="twist_mux.ros__parameters.cmd_vel_out")
    return CommandChain(smoother, monitor, mux, controller, behavior)
