"""Default navigation trees, built in Python (Nav2 ``behavior_trees/*.xml`` equivalents).

:func:`build_navigate_to_pose_tree` is Nav2's
``navigate_to_pose_w_replanning_and_recovery.xml``::

    RecoveryNode(number_of_retries=6) "NavigateRecovery"
    ├── PipelineSequence "NavigateWithReplanning"
    │   ├── RateController(hz=1.0)
    │   │   └── RecoveryNode(1) "ComputePathToPose"
    │   │       ├── Fallback: ReactiveSequence[Inverter(GlobalUpdatedGoal), IsPathValid]
    │   │       │             or ComputePathToPose        (replan only when needed)
    │   │       └── ClearEntireCostmap "ClearGlobalCostmap-Context"
    │   └── RecoveryNode(1) "FollowPath"
    │       ├── ProgressGuard(progress_epsilon, progress_dwell_time)[FollowPath]
    │       └── ClearEntireCostmap "ClearLocalCostmap-Context"
    └── Sequence "RecoveryBranch"
        ├── CountRecovery
        └── ReactiveFallback "RecoveryFallback"
            ├── GoalUpdated                               (a new goal ends the recovery)
            └── RoundRobin "RecoveryActions"
                ├── Sequence[ClearLocalCostmap, ClearGlobalCostmap]
                ├── Spin(spin_dist=1.57)
                ├── Wait(wait_duration=5.0)
                └── BackUp(backup_dist=0.30, backup_speed=0.15)

The replanning branch plans when there is no path yet, when ``IsPathValid`` says the
path is blocked, or when the goal changed; otherwise it succeeds at once, so the planner
is called at most ``replanning_hz`` times per second and only while needed.
``ProgressGuard`` is the navstack progress trigger: FollowPath fails over to recovery
when the distance remaining along the path has not fallen by ``progress_epsilon`` in
``progress_dwell_time``.

:func:`build_navigate_through_poses_tree` is the same shape with
``Sequence[RemovePassedGoals(radius), <replan-if-needed via ComputePathThroughPoses>]``
in the replanning branch: the path runs through every remaining pose (planned leg by
leg), and poses the robot passes within ``passed_goal_radius`` are dropped.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Literal

from py_trees.behaviour import Behaviour
from py_trees.common import Status
from py_trees.composites import Selector, Sequence
from py_trees.decorators import Inverter
from pydantic import Field, field_validator

from navstack.core.params import Params
from navstack.navigation import messages as m
from navstack.navigation.bt_composites import (
    PipelineSequence,
    ProgressGuard,
    RateController,
    RecoveryNode,
    RoundRobin,
)
from navstack.navigation.bt_conditions import (
    ClearEntireCostmap,
    CountRecovery,
    GlobalUpdatedGoal,
    GoalUpdated,
    IsPathValid,
    RemovePassedGoals,
)
from navstack.navigation.bt_nodes import (
    BackUp,
    ComputePathThroughPoses,
    ComputePathToPose,
    FollowPath,
    Spin,
    TreeContext,
    Wait,
)

RecoveryName = Literal["clear_costmaps", "spin", "wait", "backup"]
RECOVERY_NAMES: tuple[RecoveryName, ...] = ("clear_costmaps", "spin", "wait", "backup")
"""Nav2's RecoveryActions RoundRobin, in its order."""


class NavigateTreeParams(Params):
    """Knobs of the default trees; defaults are the values in Nav2's XML files.

    ``progress_epsilon`` / ``progress_dwell_time`` configure the navstack progress
    trigger; ``passed_goal_radius`` is ``RemovePassedGoals`` ``radius`` (Nav2 default 0.5).
    ``recovery_behaviors`` lists the RoundRobin's actions in order (Nav2: edit the XML);
    a car-like robot cannot turn in place and drops ``spin``, as Nav2's Ackermann
    examples remove the Spin node.  In a stack's parameter file these knobs go under
    ``bt_navigator: ros__parameters: tree:``.
    """

    number_of_retries: int = Field(6, ge=0)
    replanning_hz: float = Field(1.0, gt=0.0)
    spin_dist: float = 1.57
    wait_duration: float = Field(5.0, ge=0.0)
    backup_dist: float = Field(0.30, gt=0.0)
    backup_speed: float = Field(0.15, gt=0.0)
    behavior_time_allowance: float = Field(10.0, ge=0.0)
    progress_epsilon: float = Field(0.05, gt=0.0)
    progress_dwell_time: float = Field(10.0, gt=0.0)
    passed_goal_radius: float = Field(0.5, ge=0.0)
    continue_from_goal_radius: float = Field(0.0, ge=0.0)
    """navstack: > 0 plans a NavigateToPose goal's first path from the goal just reached
    when the robot is within this distance of it (:mod:`.bt_navigator`); 0 (default):
    from the robot, as Nav2."""
    planner_id: str = "GridBased"
    controller_id: str = "FollowPath"
    goal_checker_id: str = ""
    recovery_behaviors: tuple[RecoveryName, ...] = Field(RECOVERY_NAMES, min_length=1)

    @field_validator("recovery_behaviors")
    @classmethod
    def _distinct(cls, v: tuple[RecoveryName, ...]) -> tuple[RecoveryName, ...]:
        if len(set(v)) != len(v):
            raise ValueError(f"lists a behavior twice: {list(v)}")
        return v


TreeBuilder = Callable[[TreeContext, NavigateTreeParams], Behaviour]


def _replan_if_needed(ctx: TreeContext, planner: Behaviour) -> Behaviour:
    """Fallback[ReactiveSequence[Inverter(GlobalUpdatedGoal), IsPathValid], planner]."""
    path_still_good = Sequence("PathStillGood", memory=False, children=[
        Inverter("GoalUnchanged", GlobalUpdatedGoal(ctx)),
        IsPathValid(ctx),
    ])
    return Selector("ReplanIfNeeded", memory=True, children=[path_still_good, planner])


def _recovery_branch(ctx: TreeContext, p: NavigateTreeParams) -> Behaviour:
    """Count the entry, then the next recovery in round-robin order unless the goal changes."""
    make: dict[RecoveryName, Callable[[], Behaviour]] = {
        "clear_costmaps": lambda: Sequence("ClearingActions", memory=True, children=[
            ClearEntireCostmap("ClearLocalCostmap-Subtree", ctx, m.CLEAR_LOCAL_COSTMAP),
            ClearEntireCostmap("ClearGlobalCostmap-Subtree", ctx, m.CLEAR_GLOBAL_COSTMAP),
        ]),
        "spin": lambda: Spin(ctx, p.spin_dist, p.behavior_time_allowance),
        "wait": lambda: Wait(ctx, p.wait_duration),
        "backup": lambda: BackUp(ctx, p.backup_dist, p.backup_speed,
                                 p.behavior_time_allowance),
    }
    actions = RoundRobin("RecoveryActions",
                         children=[make[name]() for name in p.recovery_behaviors])
    fallback = Selector("RecoveryFallback", memory=False, children=[GoalUpdated(ctx), actions])
    return Sequence("RecoveryBranch", memory=True, children=[CountRecovery(ctx), fallback])


def _navigate_tree(ctx: TreeContext, p: NavigateTreeParams, planning: Behaviour) -> Behaviour:
    """The shared shape: replanning pipeline with FollowPath, wrapped in recoveries."""
    compute = RecoveryNode("ComputePath", [
        planning,
        ClearEntireCostmap("ClearGlobalCostmap-Context", ctx, m.CLEAR_GLOBAL_COSTMAP),
    ], number_of_retries=1)
    follow = RecoveryNode("FollowPathRecovery", [
        ProgressGuard(FollowPath(ctx, p.controller_id, p.goal_checker_id), ctx,
                      p.progress_epsilon, p.progress_dwell_time),
        ClearEntireCostmap("ClearLocalCostmap-Context", ctx, m.CLEAR_LOCAL_COSTMAP),
    ], number_of_retries=1)
    pipeline = PipelineSequence("NavigateWithReplanning", [
        RateController("RateController", compute, p.replanning_hz, ctx.clock),
        follow,
    ])
    return RecoveryNode("NavigateRecovery", [pipeline, _recovery_branch(ctx, p)],
                        number_of_retries=p.number_of_retries)


def build_navigate_to_pose_tree(ctx: TreeContext, params: NavigateTreeParams) -> Behaviour:
    """Nav2 ``navigate_to_pose_w_replanning_and_recovery.xml`` (see module docstring)."""
    return _navigate_tree(ctx, params, _replan_if_needed(
        ctx, ComputePathToPose(ctx, params.planner_id)))


def build_navigate_through_poses_tree(ctx: TreeContext, params: NavigateTreeParams
                                      ) -> Behaviour:
    """Nav2 ``navigate_through_poses_w_replanning_and_recovery.xml`` (see module docstring)."""
    planning = Sequence("PlanThroughPoses", memory=True, children=[
        RemovePassedGoals(ctx, params.passed_goal_radius),
        _replan_if_needed(ctx, ComputePathThroughPoses(ctx, params.planner_id)),
    ])
    return _navigate_tree(ctx, params, planning)


NAVIGATE_TO_POSE_TREE = "navigate_to_pose_w_replanning_and_recovery"
NAVIGATE_THROUGH_POSES_TREE = "navigate_through_poses_w_replanning_and_recovery"

DEFAULT_TREES: Mapping[str, TreeBuilder] = MappingProxyType({
    NAVIGATE_TO_POSE_TREE: build_navigate_to_pose_tree,
    NAVIGATE_THROUGH_POSES_TREE: build_navigate_through_poses_tree,
})
"""Tree builders by name; a goal's ``behavior_tree`` field picks one (empty: default)."""


def release_tree(root: Behaviour) -> None:
    """Stop a tree (cancelling running actions) and unregister its blackboard clients."""
    if root.status != Status.INVALID:
        root.stop(Status.INVALID)
    for node in root.iterate():
        for client in node.blackboards:
            client.unregister(clear=True)
        node.blackboards.clear()
