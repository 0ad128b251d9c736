"""``PlannerServer``: the ComputePathToPose action and IsPathValid service (nav2_planner).

Plans synchronously on the global costmap (the numba planners answer in milliseconds on
office-size maps): start = the goal's ``start`` or the robot's pose in the costmap
frame from TF, goal transformed into that frame.  Planner exceptions map to Nav2's
ComputePathToPose error codes with the planner's own sentence as the reason.  Each
result is also published on ``/plan``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import Field

from navstack.core.errors import (
    GoalOccupied,
    GoalOutsideMap,
    NoValidPath,
    PlannerCancelled,
    PlannerError,
    PlannerTimeout,
    StartOccupied,
    StartOutsideMap,
    TransformError,
)
from navstack.core.interfaces import GlobalPlanner
from navstack.core.msgs import Path, Pose2D, PoseStamped
from navstack.core.params import Params
from navstack.core.plugins import PLANNERS
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION
from navstack.navigation.costmap_node import CostmapNode
from navstack.navigation.messages import (
    COMPUTE_PATH_TO_POSE,
    IS_PATH_VALID,
    ComputePathToPoseGoal,
    PlannerErrorCode,
)
from navstack.navigation.plugins import load_plugin, plugin_section
from navstack.runtime.actions import ActionServer, GoalHandle
from navstack.runtime.bus import LATCHED
from navstack.runtime.node import Node, Runtime

ERROR_CODES: dict[type[PlannerError], PlannerErrorCode] = {
    StartOutsideMap: PlannerErrorCode.START_OUTSIDE_MAP,
    GoalOutsideMap: PlannerErrorCode.GOAL_OUTSIDE_MAP,
    StartOccupied: PlannerErrorCode.START_OCCUPIED,
    GoalOccupied: PlannerErrorCode.GOAL_OCCUPIED,
    PlannerTimeout: PlannerErrorCode.TIMEOUT,
    NoValidPath: PlannerErrorCode.NO_VALID_PATH,
    PlannerCancelled: PlannerErrorCode.CANCELLED,
}


class PlannerServerParams(Params):
    """nav2_planner parameters (names and Humble defaults)."""

    expected_planner_frequency: float = Field(20.0, ge=0.0)
    planner_plugins: list[str] = Field(default_factory=lambda: ["GridBased"])
    use_sim_time: bool = True
    plan_topic: str = "/plan"
    # navstack: check the oriented footprint along each path and replan around the points
    # where the body does not fit (planning/footprint_path.py; off = Nav2's behaviour)
    footprint_check: bool = False
    """navstack: check each path with the oriented, ``footprint_check_margin``-grown
    footprint; replan around gaps the body does not fit and off obstacles it hugs (for
    bodies whose axle is not centred)."""
    footprint_check_margin: float = Field(0.05, ge=0.0)
    """navstack: tracking margin added to the (padded) footprint for the check [m]."""
    footprint_check_replans: int = Field(8, ge=0)
    """navstack: replans (with discs marked lethal in a copy of the costmap) before the
    best path so far is kept."""
    footprint_check_block_radius: float = Field(0.1, gt=0.0)
    """navstack: radius [m] of the discs marked lethal to close a gap or push a path."""
    footprint_check_shift: float = Field(0.15, ge=0.0)
    """navstack: largest sideways shift [m] tried: a misfit that no shift fits is a gap,
    else a hug."""


_KNOWN = set(PlannerServerParams.model_fields)


class PlannerServer(Node):
    """ComputePathToPose on the global costmap with the configured planner plugins."""

    def __init__(self, runtime: Runtime, params: Mapping[str, Any], global_costmap: CostmapNode,
                 file: str = "", name: str = "planner_server",
                 footprint: Footprint | None = None) -> None:
        """Each of ``planner_plugins`` is looked up in :data:`navstack.core.plugins.PLANNERS`
        by its section's ``plugin`` string, built from its ``params_model`` and configured
        with the global costmap and ``footprint`` (default: the costmap's), which planners
        that check the robot's body use (Smac Hybrid-A*, as Nav2's planners do)."""
        super().__init__(name, runtime)
        server = {k: v for k, v in params.items() if k in _KNOWN}
        self.params = PlannerServerParams.from_mapping(server, file=file, key_path=name)
        self.global_costmap = global_costmap
        body = footprint if footprint is not None else global_costmap.layered.footprint
        self.footprint = body
        self.planners: dict[str, GlobalPlanner] = {}
        for pname in self.params.planner_plugins:
            key = f"{name}.{pname}"
            plugin, section = plugin_section(params, pname, "nav2_navfn_planner/NavfnPlanner",
                                             file=file, key_path=name)
            cls = load_plugin(PLANNERS, plugin, file=file, key_path=key)
            planner = cls(cls.params_model.from_mapping(section, file=file, key_path=key))
            planner.configure(global_costmap.layered, body)
            # stepped simulated time: wall-clock planning budgets become expansion
            # budgets, so a seed plans the same on any machine (planning/budget.py)
            planner.use_simulated_time(runtime.scheduler.mode == "sim")
            self.planners[pname] = planner
        self.plans_computed = 0
        self.footprint_replans = 0
        """Paths replaced because the footprint did not fit (``footprint_check``)."""
        self.last_path: Path | None = None

    def on_configure(self) -> None:
        self.pub_plan = self.create_publisher(self.params.plan_topic, Path, LATCHED)
        self.server: ActionServer[ComputePathToPoseGoal] = ActionServer(
            self.bus, COMPUTE_PATH_TO_POSE, self._on_goal)
        self.bus.advertise_service(IS_PATH_VALID, self.is_path_valid)

    def on_cleanup(self) -> None:
        self.server.close()
        self.bus.remove_service(IS_PATH_VALID)

    # --- planning -----------------------------------------------------------------------
    def _on_goal(self, handle: GoalHandle[ComputePathToPoseGoal]) -> bool | str:
        goal = handle.goal
        pid = goal.planner_id or next(iter(self.planners))
        if pid not in self.planners:
            return f"unknown planner_id '{pid}'; known: {', '.join(self.planners)}"
        handle.execute()
        try:
            path = self.compute_path(goal.goal, goal.start, pid)
        except TransformError as exc:
            handle.fail(int(PlannerErrorCode.TF_ERROR), f"cannot transform the request: {exc}")
        except PlannerError as exc:
            code = ERROR_CODES.get(type(exc), PlannerErrorCode.UNKNOWN)
            handle.fail(int(code), str(exc))
        else:
            handle.succeed(path)
        return True

    def compute_path(self, goal: PoseStamped, start: PoseStamped | None = None,
                     planner_id: str = "") -> Path:
        """Plan from ``start`` (default: the robot) to ``goal`` in the costmap frame."""
        node = self.global_costmap
        frame = node.costmap.frame_id
        goal_pose = self._in_frame(goal, frame)
        if start is not None:
            start_pose = self._in_frame(start, frame)
        else:
            start_pose = self.tf.lookup_pose2d(frame, node.robot_base_frame)
        planner = self.planners[planner_id or next(iter(self.planners))]
        p = self.params
        if p.footprint_check and self.footprint is not None:
            # imported here: importing the servers must load no planner plugin module
            # (navstack.planning's package imports them; tests/core/test_plugins.py)
            from navstack.planning.footprint_path import plan_footprint_checked

            checked = plan_footprint_checked(
                lambda cm: planner.plan(start_pose, goal_pose, cm), node.costmap,
                self.footprint, margin=p.footprint_check_margin,
                replans=p.footprint_check_replans,
                block_radius=p.footprint_check_block_radius,
                shift=p.footprint_check_shift)
            path = checked.path
            if checked.replaced:
                self.footprint_replans += 1
        else:
            path = planner.plan(start_pose, goal_pose, node.costmap)
        self.plans_computed += 1
        self.last_path = path
        self.pub_plan.publish(path)
        return path

    def _in_frame(self, pose: PoseStamped, frame: str) -> Pose2D:
        p = pose.to_pose2d()
        src = pose.header.frame_id or frame
        if src == frame:
            return p
        return self.tf.lookup_pose2d(frame, src).compose(p)

    def is_path_valid(self, path: Path) -> bool:
        """Nav2 IsPathValid: no pose ahead of the robot lies in lethal/inscribed cost."""
        cm = self.global_costmap.costmap
        arr = path.as_array()
        if len(arr) == 0:
            return False
        try:
            robot = self.tf.lookup_pose2d(cm.frame_id, self.global_costmap.robot_base_frame)
            start = int(np.argmin(np.hypot(arr[:, 0] - robot.x, arr[:, 1] - robot.y)))
        except TransformError:
            start = 0
        mx, my, inside = cm.world_to_map_array(arr[start:, :2])
        if not np.all(inside):
            return False
        cost = cm.data[my, mx]
        return not bool(np.any((cost >= INSCRIBED_INFLATED_OBSTACLE) & (cost != NO_INFORMATION)))
