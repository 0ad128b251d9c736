"""Nav2 parameter files as navstack reads them: which sections, which keys, what merges.

A Nav2 parameter file (``controller_server: ros__parameters: ...``) is checked before any
server is built, so every mistake is one :class:`~navstack.core.errors.ConfigError`
naming the file, the key path and the closest known name:

* **Top-level sections.**  The servers navstack runs (:data:`RUN_SECTIONS`, with the
  command chain's ``velocity_smoother``, ``collision_monitor`` and ``twist_mux``) are read.
  Sections of the other Nav2 / ROS nodes a real Nav2 file carries (:data:`OTHER_NODES`:
  ``map_saver``, ``smoother_server``, ``docking_server``,
  ``robot_state_publisher``, lifecycle managers, ...) are accepted and ignored with a
  note, so real Nav2 files load as they are.  The sections navstack's missions read
  (:data:`MISSION_SECTIONS`: explore_lite's ``explore_node``, the coverage search's
  ``coverage``) and SLAM's ``slam_toolbox`` (read by navstack's SLAM node) are accepted
  without a note; the missions and the SLAM node check them.  Any other name is
  an error with a "did you mean" (``controler_server``); so is a file without any section
  navstack runs, or an empty file.
* **Server keys.**  Each run server's own keys are its params model's fields, the Nav2
  keys navstack accepts but does not use (:data:`NAV2_ONLY_KEYS`, ignored with a note),
  the ROS node keys every node has (``use_sim_time``, ``introspection_mode``, ...), and the
  plugin sections its ``*_plugins`` lists name.  ``controller_frequncy`` is an error
  (did you mean ``controller_frequency``?).  A mapping no plugin list names is a typo of
  a listed plugin when one is close (error), else unused (Nav2 ignores it too).
  Plugin and layer sections are checked by the plugins themselves.
* **Command chain values.**  The ``velocity_smoother``, ``collision_monitor`` and
  ``twist_mux`` sections are checked whole, as their stages read them: value types and
  ranges, every polygon and observation source the lists name (a missing section, a
  ``slowdown_ration``), the mux's topic and lock entries (``priorty``, a priority above
  255, duplicate topics).
* **Partial files.**  A file that configures only some servers is merged over the
  packaged defaults (``navstack/config/nav2_params.yaml``) section by section: a server
  the file names takes the file's section as a whole (as a Nav2 node reads only its own
  section), the others come from the defaults; the note lists which came from where.
* ``/**`` (wildcard) keys apply to every run server that has them.

:func:`load_nav2_params` returns the checked data with its notes; they are logged on
``navstack.config`` (INFO for the merge, WARNING for what is ignored).
"""

from __future__ import annotations

import copy
import difflib
import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from navstack.core.config_files import ROS_PARAMETERS, load_yaml
from navstack.core.errors import ConfigError, ConfigErrors, did_you_mean
from navstack.navigation.costmap_filter_servers import (
    is_info_server_section,
    is_mask_server_section,
)

if TYPE_CHECKING:
    from navstack.runtime.config import StackConfig

log = logging.getLogger("navstack.config")

WILDCARD = "/**"
NESTED = ("global_costmap", "local_costmap")
"""Sections Nav2 writes twice (``global_costmap: global_costmap: ros__parameters:``)."""

RUN_SECTIONS: tuple[str, ...] = (
    "bt_navigator", "controller_server", "planner_server", "behavior_server",
    "waypoint_follower", "global_costmap", "local_costmap", "amcl",
    "velocity_smoother", "collision_monitor", "twist_mux")
"""Sections of the servers :class:`~navstack.interfaces.stack.NavStack` builds from the
file (``amcl`` when it localizes with AMCL; the command chain's velocity_smoother,
collision_monitor and twist_mux, docs/command_path.md).  Costmap filter info and mask
servers (``[<prefix>_]costmap_filter_info_server``, ``[<prefix>_]filter_mask_server``) are
run too; their sections pass through unchanged and are checked when the stack builds them
(:mod:`navstack.navigation.costmap_filter_servers`)."""

OTHER_NODES: frozenset[str] = frozenset({
    # Nav2 nodes navstack does not run, or runs without reading the file
    "map_server", "map_saver", "smoother_server", "collision_detector", "docking_server",
    "route_server", "loopback_simulator", "recoveries_server", "opennav_docking",
    "graceful_controller", "assisted_teleop", "nav2_container", "nav2_map_server",
    # helper nodes Nav2 launch files start (older distributions list them too)
    "bt_navigator_rclcpp_node", "bt_navigator_navigate_to_pose_rclcpp_node",
    "bt_navigator_navigate_through_poses_rclcpp_node", "controller_server_rclcpp_node",
    "planner_server_rclcpp_node", "global_costmap_client", "local_costmap_client",
    "global_costmap_rclcpp_node", "local_costmap_rclcpp_node",
    "lifecycle_manager", "lifecycle_manager_navigation", "lifecycle_manager_localization",
    "lifecycle_manager_slam", "lifecycle_manager_keepout_zone",
    "lifecycle_manager_speed_zone", "lifecycle_manager_costmap_filters",
    # other ROS nodes often kept in the same file
    "robot_state_publisher", "joint_state_publisher", "ekf_filter_node",
    "ekf_local_filter_node", "ekf_global_filter_node", "ukf_filter_node",
    "navsat_transform", "navsat_transform_node", "teleop_twist_joy_node",
    "joy_node", "explore_node", "pointcloud_to_laserscan", "laser_filter",
    "scan_to_scan_filter_chain",
})
"""Nav2 and companion node names that are recognised and ignored (with a note)."""

MISSION_SECTIONS: frozenset[str] = frozenset({"explore_node", "coverage"})
SLAM_SECTION = "slam_toolbox"
"""Read by navstack's SLAM node (``SlamNode``) when SLAM runs; accepted without a note."""
"""Sections read by the missions (``navstack.interfaces.mission_catalog``), not by the
servers: explore_lite's node (``explore_node``, its ROS 2 parameter file's name) and the
coverage search.  The stack passes over them; each mission checks its own section."""

ROS_NODE_KEYS: frozenset[str] = frozenset({
    "use_sim_time", "introspection_mode", "service_introspection_mode",
    "bond_heartbeat_period", "autostart_node", "qos_overrides", "strict_param_loading",
    "warn_on_missing_params", "allow_parameter_qos_overrides", "start_type_description_service",
    "enable_stamped_cmd_vel", "action_server_result_timeout"})
"""Keys any ROS 2 / Nav2 node accepts; navstack (one process, scheduler time) needs none."""

NAV2_ONLY_KEYS: dict[str, frozenset[str]] = {
    # declared by the Nav2 servers (Humble .. Rolling) but without use in navstack
    "controller_server": frozenset({
        "publish_zero_velocity", "costmap_update_timeout", "odom_duration",
        "path_handler_plugins", "search_window", "use_realtime_priority"}),
    "planner_server": frozenset({"costmap_update_timeout", "allow_partial_planning"}),
    "behavior_server": frozenset({
        "costmap_topic", "footprint_topic", "local_costmap_topic", "global_costmap_topic",
        "local_footprint_topic", "global_footprint_topic",
        "projection_time", "simulation_time_step", "cmd_vel_teleop"}),
    "bt_navigator": frozenset({
        "plugin_lib_names", "odom_topic", "transform_tolerance", "always_reload_bt_xml",
        "wait_for_service_timeout", "default_cancel_timeout", "error_code_names",
        "error_code_name_prefixes", "filter_duration", "bt_search_directories",
        "enable_groot_monitoring", "groot_zmq_publisher_port", "groot_zmq_server_port",
        "groot_server_port", "waypoint_statuses_blackboard_id", "default_bt_xml_filename",
        "navigate_to_pose", "navigate_through_poses"}),
    "waypoint_follower": frozenset({"loop_rate", "waypoint_task_executor_plugin",
                                    "global_frame_id"}),
    "global_costmap": frozenset(),
    "local_costmap": frozenset(),
    "amcl": frozenset(),
    "velocity_smoother": frozenset(),
    # Nav2 Kilted's real-time thread option (no threads here)
    "collision_monitor": frozenset({"use_realtime_priority"}),
    "twist_mux": frozenset(),
}
"""Nav2 server keys navstack accepts so Nav2 files load, and ignores with a note."""

_PLUGIN_LISTS: dict[str, dict[str, tuple[str, ...]]] = {
    # list key -> names used when the key is absent (the servers' defaults)
    "controller_server": {"controller_plugins": ("FollowPath",),
                          "goal_checker_plugins": ("general_goal_checker",),
                          "progress_checker_plugins": ("progress_checker",),
                          "goal_checker_plugin": (), "progress_checker_plugin": ()},
    "planner_server": {"planner_plugins": ("GridBased",)},
    "behavior_server": {"behavior_plugins": ("spin", "backup", "drive_on_heading", "wait")},
    "global_costmap": {"plugins": ("static_layer", "obstacle_layer", "inflation_layer"),
                       "filters": ()},
    "local_costmap": {"plugins": ("static_layer", "obstacle_layer", "inflation_layer"),
                      "filters": ()},
    "collision_monitor": {"polygons": (), "observation_sources": ()},
}
"""Lists whose named sections a run server reads (plugins, layers, checkers)."""

CHAIN_SECTIONS: frozenset[str] = frozenset({"velocity_smoother", "collision_monitor",
                                            "twist_mux"})
"""The command chain's stages (docs/command_path.md): their values are checked here too,
as the stage reads them (the other servers' values are checked when they are built)."""

_NO_SPARE_SECTIONS: frozenset[str] = frozenset({"velocity_smoother", "twist_mux"})
"""Servers without plugin lists: a mapping among their keys is an unknown parameter (a
``topic:`` for ``topics:``), not a spare plugin section."""

_IGNORED_LISTS: dict[str, tuple[str, ...]] = {
    # lists whose named sections belong to Nav2 features navstack does not load
    "controller_server": ("path_handler_plugins",),
    "waypoint_follower": ("waypoint_task_executor_plugin",),
    "bt_navigator": ("navigators",),
}
_UNBUILT_BEHAVIORS = ("assisted_teleop",)
"""Nav2 behaviors navstack has no plugin for: dropped from ``behavior_plugins`` with a note
(Nav2 Humble's stock file lists ``assisted_teleop``)."""
_IGNORED_DEFAULTS: dict[str, tuple[str, ...]] = {
    "behavior_server": _UNBUILT_BEHAVIORS,
    "waypoint_follower": ("wait_at_waypoint",),
    "bt_navigator": ("navigate_to_pose", "navigate_through_poses"),
}


def packaged_nav2_params_path() -> Path:
    """``navstack/config/nav2_params.yaml``: the defaults a partial file merges over."""
    return Path(str(resources.files("navstack") / "config" / "nav2_params.yaml"))


@lru_cache(maxsize=1)
def _server_fields() -> dict[str, frozenset[str]]:
    """Keys each run server reads (its params model's fields), imported lazily."""
    from navstack.control.collision_monitor import CollisionMonitorParams
    from navstack.control.twist_mux import TwistMuxParams
    from navstack.control.velocity_smoother import VelocitySmootherParams
    from navstack.costmap.layered_costmap import Costmap2DParams
    from navstack.localization.amcl.params import AmclParams
    from navstack.navigation.behavior_server import BehaviorServerParams
    from navstack.navigation.bt_navigator import BtNavigatorParams
    from navstack.navigation.controller_server import ControllerServerParams
    from navstack.navigation.planner_server import PlannerServerParams
    from navstack.navigation.waypoint_follower import WaypointFollowerParams

    costmap = frozenset(Costmap2DParams.model_fields)
    return {
        "controller_server": frozenset(ControllerServerParams.model_fields),
        "planner_server": frozenset(PlannerServerParams.model_fields),
        "behavior_server": frozenset(BehaviorServerParams.model_fields),
        "bt_navigator": frozenset(BtNavigatorParams.model_fields) | {"tree"},
        "waypoint_follower": frozenset(WaypointFollowerParams.model_fields),
        "global_costmap": costmap, "local_costmap": costmap,
        "amcl": frozenset(AmclParams.model_fields),
        "velocity_smoother": frozenset(VelocitySmootherParams.model_fields),
        # the polygon and source sections are named by the lists, not given as fields
        "collision_monitor": frozenset(CollisionMonitorParams.model_fields)
        - {"polygon_params", "source_params"},
        "twist_mux": frozenset(TwistMuxParams.model_fields),
    }


@dataclass
class Nav2Params:
    """A checked Nav2 parameter set: ``data`` in Nav2's layout (wildcard folded in,
    ignored sections and keys removed), the ``file`` named in errors, and notes."""

    data: dict[str, Any]
    file: str
    from_file: tuple[str, ...] = ()
    from_defaults: tuple[str, ...] = ()
    notes: list[str] = field(default_factory=list)


def _names(value: Any) -> list[str]:
    if isinstance(value, str):
        return [value] if value else []
    if isinstance(value, list | tuple):
        return [str(v) for v in value]
    return []


def _section(data: Mapping[str, Any], name: str, file: str) -> tuple[dict[str, Any], str]:
    """``(ros__parameters dict, its key path)`` of top-level section ``name``."""
    node = data[name]
    path = name
    if not isinstance(node, Mapping):
        raise ConfigError(f"must be a mapping with '{ROS_PARAMETERS}:', got "
                          f"{type(node).__name__}", file=file, key_path=name)
    if ROS_PARAMETERS not in node and name in NESTED and isinstance(node.get(name), Mapping):
        node, path = node[name], f"{name}.{name}"
    params = node.get(ROS_PARAMETERS)
    if params is None:
        other = [str(k) for k in node if k != ROS_PARAMETERS]
        hint = did_you_mean(other[0], [ROS_PARAMETERS]).strip(" ()") if other else ""
        raise ConfigError(f"missing '{ROS_PARAMETERS}'", file=file, key_path=path,
                          suggestion=hint or f"nest the values under '{ROS_PARAMETERS}:'")
    if not isinstance(params, Mapping):
        raise ConfigError(f"must be a mapping, got {type(params).__name__}", file=file,
                          key_path=f"{path}.{ROS_PARAMETERS}")
    return dict(params), f"{path}.{ROS_PARAMETERS}"


def _check_server(name: str, params: dict[str, Any], path: str, file: str,
                  ignored: list[str]) -> tuple[dict[str, Any], list[ConfigError]]:
    """Check one run server's keys; returns the params navstack reads and the errors."""
    fields = _server_fields()[name]
    nav2_only = NAV2_ONLY_KEYS[name]
    listed: set[str] = set()
    for key, default in _PLUGIN_LISTS.get(name, {}).items():
        listed.update(_names(params.get(key, list(default))))
    ignored_sections: set[str] = set(_IGNORED_DEFAULTS.get(name, ()))
    for key in _IGNORED_LISTS.get(name, ()):
        ignored_sections.update(_names(params.get(key)))
    if name == "behavior_server" and isinstance(params.get("behavior_plugins"), list):
        unbuilt = [b for b in params["behavior_plugins"] if b in _UNBUILT_BEHAVIORS]
        params = {**params, "behavior_plugins": [
            b for b in params["behavior_plugins"] if b not in _UNBUILT_BEHAVIORS]}
        ignored.extend(f"{name}.behavior_plugins[{b}]" for b in unbuilt)
        listed.difference_update(unbuilt)
    known = fields | nav2_only | listed
    errors: list[ConfigError] = []
    kept: dict[str, Any] = {}
    for key, value in params.items():
        key = str(key)
        if key in fields or key in listed:
            kept[key] = value
        elif key in nav2_only or key in ignored_sections:
            ignored.append(f"{name}.{key}")
        elif key in ROS_NODE_KEYS:
            continue
        elif isinstance(value, Mapping) and name not in _NO_SPARE_SECTIONS:
            missing = [n for n in listed if n not in params]
            hint = did_you_mean(key, missing).strip(" ()")
            if hint:
                errors.append(ConfigError(
                    "plugin section not named in any plugin list", file=file,
                    key_path=f"{path}.{key}", suggestion=hint))
            else:  # Nav2 ignores sections no list names (e.g. a spare goal checker)
                ignored.append(f"{name}.{key}")
        else:
            errors.append(ConfigError(
                f"unknown {name} parameter", file=file, key_path=f"{path}.{key}",
                suggestion=did_you_mean(key, known).strip(" ()")))
    return kept, errors


def _check_chain_values(name: str, kept: dict[str, Any], path: str,
                        file: str) -> list[ConfigError]:
    """Check the values of a command-chain section as its stage will read them (types,
    ranges, polygon and source sections, mux entries); every error names ``path``."""
    from navstack.control.collision_monitor import collision_monitor_params
    from navstack.control.twist_mux import twist_mux_params
    from navstack.control.velocity_smoother import VelocitySmootherParams

    try:
        if name == "velocity_smoother":
            VelocitySmootherParams.from_mapping(kept, file=file, key_path=path)
        elif name == "collision_monitor":
            missing = [k for k in ("polygons", "observation_sources") if k not in kept]
            if missing:  # Nav2 declares both without a default
                return [ConfigError(f"collision_monitor needs '{k}' (Nav2 requires it)",
                                    file=file, key_path=f"{path}.{k}",
                                    suggestion=f"list the {k} section names; see the "
                                               "packaged nav2_params.yaml's collision_monitor")
                    for k in missing]
            collision_monitor_params(kept, file=file, key_path=path)
        elif name == "twist_mux":
            twist_mux_params({"twist_mux": {ROS_PARAMETERS: kept}}, file=file)
    except ConfigErrors as exc:
        return list(exc.errors)
    except ConfigError as exc:
        return [exc]
    return []


def check_nav2_data(data: Mapping[str, Any], file: str) -> Nav2Params:
    """Check a Nav2 parameter mapping (module docstring); no merge with the defaults."""
    if not data:
        raise ConfigError("empty Nav2 parameter file", file=file, suggestion=(
            f"give at least one server section, e.g. 'controller_server: {ROS_PARAMETERS}: "
            f"...'; known: {', '.join(RUN_SECTIONS)}"))
    errors: list[ConfigError] = []
    ignored_nodes: list[str] = []
    ignored_keys: list[str] = []
    wildcard: dict[str, Any] = {}
    run: list[str] = []
    filters: list[str] = []
    for name in data:
        key = str(name)
        if key == WILDCARD:
            try:
                wildcard, _ = _section(data, key, file)
            except ConfigError as exc:
                errors.append(exc)
        elif key in RUN_SECTIONS:
            run.append(key)
        elif is_info_server_section(key) or is_mask_server_section(key):
            filters.append(key)
        elif key in MISSION_SECTIONS or key == SLAM_SECTION:
            continue
        elif key in OTHER_NODES:
            ignored_nodes.append(key)
        else:
            errors.append(ConfigError("unknown section", file=file, key_path=key,
                                      suggestion=_section_hint(key)))
    out: dict[str, Any] = {}
    for name in run:
        try:
            params, path = _section(data, name, file)
        except ConfigError as exc:
            errors.append(exc)
            continue
        kept, server_errors = _check_server(name, {**_wildcard_for(name, wildcard), **params},
                                            path, file, ignored_keys)
        errors.extend(server_errors)
        if name in CHAIN_SECTIONS and not server_errors:
            errors.extend(_check_chain_values(name, kept, path, file))
        out[name] = ({name: {ROS_PARAMETERS: kept}} if name in NESTED
                     else {ROS_PARAMETERS: kept})
    for name in filters:
        try:
            params, _ = _section(data, name, file)
        except ConfigError as exc:
            errors.append(exc)
            continue
        out[name] = {ROS_PARAMETERS: params}
    wild_unknown = [k for k in wildcard
                    if k not in ROS_NODE_KEYS and not any(
                        k in _server_fields()[s] or k in NAV2_ONLY_KEYS[s] for s in RUN_SECTIONS)]
    errors.extend(ConfigError("unknown to every server navstack runs", file=file,
                              key_path=f"{WILDCARD}.{ROS_PARAMETERS}.{k}") for k in wild_unknown)
    if errors:
        raise errors[0] if len(errors) == 1 else ConfigErrors(errors)
    if not run:
        raise ConfigError(
            "no section for a server navstack runs", file=file, suggestion=(
                f"the file only has {', '.join(map(str, data))}; add one of "
                f"{', '.join(RUN_SECTIONS)} (as 'controller_server: {ROS_PARAMETERS}: ...')"))
    notes = []
    if ignored_nodes:
        notes.append(f"{file}: sections of nodes navstack does not run, ignored: "
                     f"{', '.join(ignored_nodes)}")
    if ignored_keys:
        notes.append(f"{file}: Nav2 parameters navstack does not use, ignored: "
                     f"{', '.join(ignored_keys)}")
    return Nav2Params(out, file, (*run, *filters), (), notes)


def _section_hint(key: str) -> str:
    close = did_you_mean(key, RUN_SECTIONS).strip(" ()")
    if not close:
        near = difflib.get_close_matches(key, sorted(OTHER_NODES), n=1, cutoff=0.85)
        close = f"did you mean '{near[0]}'?" if near else ""
    return close or (f"not a Nav2 node navstack knows; it reads {', '.join(RUN_SECTIONS)} "
                     f"and ignores the other Nav2 nodes: remove it or keep it in another file")


def _wildcard_for(server: str, wildcard: Mapping[str, Any]) -> dict[str, Any]:
    """The wildcard keys this server reads (the others are meant for other nodes)."""
    fields = _server_fields()[server]
    return {k: v for k, v in wildcard.items() if k in fields}


@lru_cache(maxsize=1)
def _packaged() -> Nav2Params:
    path = packaged_nav2_params_path()
    return check_nav2_data(load_yaml(path), str(path))


def load_nav2_params(source: str | Path | Mapping[str, Any] | Nav2Params | None = None, *,
                     file: str | None = None, merge_defaults: bool = True) -> Nav2Params:
    """Read, check and (for a partial file) complete Nav2 parameters.

    ``source``: a file path, a mapping in Nav2's layout (``file`` names it in errors,
    default ``"nav2_params argument"``), an already checked :class:`Nav2Params`, or
    ``None`` for the packaged defaults.  Raises :class:`ConfigError` (module docstring).
    """
    if isinstance(source, Nav2Params):
        return source
    if source is None:
        packaged = _packaged()
        return Nav2Params(copy.deepcopy(packaged.data), packaged.file, (),
                          tuple(packaged.data), list(packaged.notes))
    if isinstance(source, str | Path):
        label = file or str(source)
        checked = check_nav2_data(load_yaml(source), label)
    else:
        checked = check_nav2_data(source, file or "nav2_params argument")
    checked.data = copy.deepcopy(checked.data)
    if merge_defaults:
        _merge(checked)
    for note in checked.notes:
        log.log(logging.INFO if "packaged defaults" in note else logging.WARNING, note)
    return checked


def _merge(checked: Nav2Params) -> None:
    packaged = _packaged()
    missing = [s for s in packaged.data if s not in checked.data]
    if not missing:
        return
    for name in missing:
        checked.data[name] = copy.deepcopy(packaged.data[name])
    checked.from_defaults = tuple(missing)
    checked.notes.insert(0, (
        f"{checked.file}: sections from the file: {', '.join(checked.from_file)}; from the "
        f"packaged defaults ({Path(packaged.file).name}): {', '.join(missing)}"))


def stack_navigation(cfg: StackConfig) -> Nav2Params | None:
    """The checked ``navigation`` of a stack file: its Nav2 file (named in errors by its
    own path) or inline Nav2 layout (named as the stack file's ``navigation`` section);
    ``None`` when empty (the packaged defaults)."""
    if isinstance(cfg.navigation, str):
        return load_nav2_params(cfg.navigation_file())
    if not cfg.navigation:
        return None
    label = f"{cfg.source_file} (navigation)" if cfg.source_file else "stack navigation"
    return load_nav2_params(dict(cfg.navigation), file=label)
