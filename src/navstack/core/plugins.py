"""The server plugin registries and their decorators.

A plugin is one class with one decorator giving its navstack name and its Nav2 type
(either spelling; both ``pkg::Class`` and ``pkg/Class`` are registered)::

    @register_planner("Navfn", nav2="nav2_navfn_planner::NavfnPlanner")
    class NavfnPlanner(GlobalPlanner):
        params_model = NavfnParams
        ...

A Nav2 YAML then selects it with ``plugin: "nav2_navfn_planner/NavfnPlanner"`` (or
``"Navfn"``).  Names are unique per registry; a second registration of a name or alias
is a :class:`~navstack.core.errors.DuplicatePluginError`.

Built-in plugins load lazily: the tables below say which module registers each name,
and the module is imported on the first lookup of one of its names.  A user's plugin is
found when its module was imported before the stack is built, when the YAML names it
``"package.module:ClassName"``, or through a ``navstack.plugins`` entry point of an
installed distribution (:mod:`navstack.core.registry`; ``docs/extending.md``).
"""

from __future__ import annotations

from typing import Any

from navstack.core.interfaces import (
    Behavior,
    Controller,
    GlobalPlanner,
    GoalChecker,
    ProgressChecker,
    Smoother,
)
from navstack.core.registry import ClassRegistry, builtin_table

PLANNERS: ClassRegistry[GlobalPlanner] = ClassRegistry(
    "planner", GlobalPlanner, builtin_table({
        "navstack.planning.navfn": ("Navfn", "nav2_navfn_planner::NavfnPlanner"),
        "navstack.planning.astar": ("CostAwareAStar", "nav2_smac_planner::SmacPlanner2D"),
        "navstack.planning.hybrid_astar.planner": (
            "SmacPlannerHybrid", "nav2_smac_planner::SmacPlannerHybrid"),
        "navstack.planning.theta_star": (
            "ThetaStarPlanner", "nav2_theta_star_planner::ThetaStarPlanner"),
    }))
"""Global planners (``planner_server``'s ``planner_plugins``)."""

CONTROLLERS: ClassRegistry[Controller] = ClassRegistry(
    "controller", Controller, builtin_table({
        "navstack.control.dwb.dwb_controller": ("DWB", "dwb_core::DWBLocalPlanner"),
        "navstack.control.mppi.controller": ("MPPI", "nav2_mppi_controller::MPPIController"),
        "navstack.control.rpp.controller": (
            "RegulatedPurePursuit",
            "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"),
        "navstack.control.rotation_shim": (
            "RotationShimController", "nav2_rotation_shim_controller::RotationShimController"),
    }))
"""Local controllers (``controller_server``'s ``controller_plugins``)."""

SMOOTHERS: ClassRegistry[Smoother] = ClassRegistry(
    "smoother", Smoother, builtin_table({
        "navstack.planning.smoothers.simple": ("SimpleSmoother",
                                               "nav2_smoother::SimpleSmoother"),
        "navstack.planning.smoothers.savitzky_golay": (
            "SavitzkyGolaySmoother", "nav2_smoother::SavitzkyGolaySmoother"),
    }))
"""Path smoothers (Nav2 ``smoother_server``'s ``smoother_plugins``)."""

GOAL_CHECKERS: ClassRegistry[GoalChecker] = ClassRegistry(
    "goal checker", GoalChecker, builtin_table({
        "navstack.control.goal_checker": (
            "SimpleGoalChecker", "nav2_controller::SimpleGoalChecker",
            "dwb_plugins::SimpleGoalChecker", "StoppedGoalChecker",
            "nav2_controller::StoppedGoalChecker", "dwb_plugins::StoppedGoalChecker"),
    }))
"""Goal checkers (``controller_server``'s ``goal_checker_plugins``)."""

PROGRESS_CHECKERS: ClassRegistry[ProgressChecker] = ClassRegistry(
    "progress checker", ProgressChecker, builtin_table({
        "navstack.control.progress_checker": (
            "SimpleProgressChecker", "nav2_controller::SimpleProgressChecker",
            "PoseProgressChecker", "nav2_controller::PoseProgressChecker",
            "GoalProgressChecker", "navstack::GoalProgressChecker"),
    }))
"""Progress checkers (``controller_server``'s ``progress_checker_plugins``)."""

BEHAVIORS: ClassRegistry[Behavior[Any]] = ClassRegistry(
    "behavior", Behavior, builtin_table({
        "navstack.navigation.behaviors": (
            "Spin", "nav2_behaviors::Spin", "BackUp", "nav2_behaviors::BackUp",
            "DriveOnHeading", "nav2_behaviors::DriveOnHeading", "Wait",
            "nav2_behaviors::Wait"),
    }))
"""Recovery behaviors (``behavior_server``'s ``behavior_plugins``)."""

register_planner = PLANNERS.plugin
register_controller = CONTROLLERS.plugin
register_smoother = SMOOTHERS.plugin
register_goal_checker = GOAL_CHECKERS.plugin
register_progress_checker = PROGRESS_CHECKERS.plugin
register_behavior = BEHAVIORS.plugin

REGISTRIES: tuple[ClassRegistry[Any], ...] = (PLANNERS, CONTROLLERS, SMOOTHERS, GOAL_CHECKERS,
                                             PROGRESS_CHECKERS, BEHAVIORS)
"""Every server registry (for listings and the consistency test)."""
