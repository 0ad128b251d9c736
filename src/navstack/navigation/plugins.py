"""Nav2 plugin strings -> navstack classes for the servers (imported lazily).

Each entry names ``module:Class``; the class is built with ``Class(params_dict,
footprint=...)`` for controllers and ``Class.from_mapping(params_dict, ...)``-style
factories below for the others.  Both ``pkg::Class`` and ``pkg/Class`` spellings work.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from navstack.core.errors import ConfigError, did_you_mean
from navstack.core.registry import PluginRegistry

CONTROLLERS: PluginRegistry[str] = PluginRegistry("controller")
CONTROLLERS.register("DWB", "navstack.control.dwb.dwb_controller:DWBLocalPlanner",
                     aliases=("dwb_core::DWBLocalPlanner", "dwb_core/DWBLocalPlanner"))
CONTROLLERS.register("MPPI", "navstack.control.mppi.controller:MPPIController",
                     aliases=("nav2_mppi_controller::MPPIController",
                              "nav2_mppi_controller/MPPIController"))
CONTROLLERS.register("RegulatedPurePursuit",
                     "navstack.control.rpp.controller:RegulatedPurePursuitController",
                     aliases=("nav2_regulated_pure_pursuit_controller::"
                              "RegulatedPurePursuitController",
                              "nav2_regulated_pure_pursuit_controller/"
                              "RegulatedPurePursuitController"))

PLANNERS: PluginRegistry[str] = PluginRegistry("planner")
PLANNERS.register("Navfn", "navstack.planning.navfn:NavfnPlanner",
                  aliases=("nav2_navfn_planner/NavfnPlanner", "nav2_navfn_planner::NavfnPlanner"))
PLANNERS.register("CostAwareAStar", "navstack.planning.astar:CostAwareAStar",
                  aliases=("nav2_smac_planner/SmacPlanner2D",
                           "nav2_smac_planner::SmacPlanner2D"))
PLANNERS.register("SmacPlannerHybrid", "navstack.planning.hybrid_astar.planner:HybridAStar",
                  aliases=("nav2_smac_planner::SmacPlannerHybrid",
                           "nav2_smac_planner/SmacPlannerHybrid"))
PLANNERS.register("ThetaStarPlanner", "navstack.planning.theta_star:ThetaStarPlanner",
                  aliases=("nav2_theta_star_planner/ThetaStarPlanner",
                           "nav2_theta_star_planner::ThetaStarPlanner"))

GOAL_CHECKERS: PluginRegistry[str] = PluginRegistry("goal checker")
GOAL_CHECKERS.register("SimpleGoalChecker", "navstack.control.goal_checker:SimpleGoalChecker",
                       aliases=("nav2_controller::SimpleGoalChecker",
                                "nav2_controller/SimpleGoalChecker"))
GOAL_CHECKERS.register("StoppedGoalChecker", "navstack.control.goal_checker:StoppedGoalChecker",
                       aliases=("nav2_controller::StoppedGoalChecker",
                                "nav2_controller/StoppedGoalChecker"))

PROGRESS_CHECKERS: PluginRegistry[str] = PluginRegistry("progress checker")
PROGRESS_CHECKERS.register("SimpleProgressChecker",
                           "navstack.control.progress_checker:SimpleProgressChecker",
                           aliases=("nav2_controller::SimpleProgressChecker",
                                    "nav2_controller/SimpleProgressChecker"))
PROGRESS_CHECKERS.register("PoseProgressChecker",
                           "navstack.control.progress_checker:PoseProgressChecker",
                           aliases=("nav2_controller::PoseProgressChecker",
                                    "nav2_controller/PoseProgressChecker"))


def load_class(registry: PluginRegistry[str], plugin: str, *, file: str = "",
               key_path: str = "") -> Any:
    """The class registered for a Nav2 plugin string; ConfigError naming the key if unknown."""
    if plugin not in registry:
        known = registry.names()
        hint = did_you_mean(plugin, registry.all_names()).strip(" ()")
        raise ConfigError(f"unknown {registry.kind} plugin '{plugin}'", file=file,
                          key_path=f"{key_path}.plugin" if key_path else "plugin",
                          suggestion=hint or f"known: {', '.join(known)}")
    module, _, attr = registry.get(plugin).partition(":")
    return getattr(importlib.import_module(module), attr)


def plugin_section(server_params: Mapping[str, Any], name: str, default_plugin: str, *,
                   file: str = "", key_path: str = "") -> tuple[str, dict[str, Any]]:
    """``(plugin string, params without 'plugin')`` of a named plugin section."""
    raw = server_params.get(name) or {}
    if not isinstance(raw, Mapping):
        raise ConfigError(f"must be a mapping, got {type(raw).__name__}", file=file,
                          key_path=f"{key_path}.{name}")
    section = dict(raw)
    plugin = str(section.pop("plugin", default_plugin))
    return plugin, section


def build_plugin(cls: Any, section: Mapping[str, Any], *, file: str = "", key_path: str = "",
                 **kwargs: Any) -> Any:
    """Instantiate a plugin whose first argument is its ``Params`` model.

    The Params class is read off a default instance (``cls(**kwargs).params``) so the
    section is validated with errors naming ``file`` and ``key_path``.
    """
    params_type = type(cls(**kwargs).params)
    return cls(params_type.from_mapping(dict(section), file=file, key_path=key_path), **kwargs)
