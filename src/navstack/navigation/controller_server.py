"""``ControllerServer``: the FollowPath action (Nav2 ``nav2_controller``).

At ``controller_frequency`` it looks up the robot pose in the local costmap's frame
(``odom``), brings the plan from its frame (``map``) into that frame with the latest
TF, checks the goal checker and the progress checker, asks the controller plugin for a
velocity and publishes it.  Parameters are Nav2's (``controller_frequency``,
``failure_tolerance``, ``controller_plugins``, ``goal_checker_plugins``,
``progress_checker_plugins`` and the plugin sections).  A goal never fails silently:
every abort carries a FollowPath error code and a sentence naming the cause.
Speed limits (``nav2_msgs/SpeedLimit`` on ``speed_limit_topic``, from a costmap speed
filter) are passed to every controller plugin with ``set_speed_limit(limit, percentage)``,
as Nav2's ``speedLimitCallback`` does; 0 restores the plugins' own maxima.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, TypeVar

import numpy as np
from pydantic import Field

from navstack.core.errors import ControllerError, InvalidMessage, InvalidPath, TransformError
from navstack.core.geometry import angle_diff, se2_compose
from navstack.core.interfaces import Controller, GoalChecker, ProgressChecker
from navstack.core.msgs import Odometry, Path, Pose2D, SpeedLimit, Twist, Twist2D
from navstack.core.params import Params
from navstack.core.plugins import CONTROLLERS, GOAL_CHECKERS, PROGRESS_CHECKERS
from navstack.core.polygon import Footprint
from navstack.core.registry import ClassRegistry
from navstack.navigation.costmap_node import CostmapNode
from navstack.navigation.messages import (
    FOLLOW_PATH,
    ControllerErrorCode,
    FollowPathFeedback,
    FollowPathGoal,
)
from navstack.navigation.plugins import load_plugin, plugin_section
from navstack.runtime.actions import ActionServer, GoalHandle
from navstack.runtime.bus import QoS
from navstack.runtime.node import Node, Runtime


class ControllerServerParams(Params):
    """nav2_controller parameters (names and Humble defaults)."""

    controller_frequency: float = Field(20.0, gt=0.0)
    min_x_velocity_threshold: float = 0.001
    min_y_velocity_threshold: float = 0.5
    min_theta_velocity_threshold: float = 0.001
    failure_tolerance: float = 0.3
    controller_plugins: list[str] = Field(default_factory=lambda: ["FollowPath"])
    goal_checker_plugins: list[str] = Field(default_factory=lambda: ["general_goal_checker"])
    progress_checker_plugins: list[str] = Field(default_factory=lambda: ["progress_checker"])
    progress_checker_plugin: str = ""
    goal_checker_plugin: str = ""
    cmd_vel_topic: str = "/cmd_vel"
    odom_topic: str = "/odom"
    use_sim_time: bool = True
    use_realtime_priority: bool = False
    speed_limit_topic: str = "speed_limit"


_KNOWN = set(ControllerServerParams.model_fields)

C = TypeVar("C", GoalChecker, ProgressChecker)


def path_distance(xy: np.ndarray, x: float, y: float) -> float:
    """Length of the path from its point closest to (x, y) to its end."""
    if len(xy) == 0:
        return 0.0
    i = int(np.argmin(np.hypot(xy[:, 0] - x, xy[:, 1] - y)))
    rest = xy[i:]
    first = math.hypot(rest[0, 0] - x, rest[0, 1] - y)
    return first + float(np.sum(np.hypot(*np.diff(rest, axis=0).T))) if len(rest) > 1 else first


class ControllerServer(Node):
    """FollowPath action server driving a controller plugin on the local costmap."""

    def __init__(self, runtime: Runtime, params: Mapping[str, Any], local_costmap: CostmapNode,
                 footprint: Footprint | None = None, file: str = "",
                 name: str = "controller_server") -> None:
        super().__init__(name, runtime)
        server = {k: v for k, v in params.items() if k in _KNOWN}
        self.params = ControllerServerParams.from_mapping(server, file=file, key_path=name)
        p = self.params
        self.local_costmap = local_costmap
        self.controllers: dict[str, Controller] = {}
        for cname in p.controller_plugins:
            key = f"{name}.{cname}"
            plugin, section = plugin_section(params, cname, "dwb_core::DWBLocalPlanner",
                                             file=file, key_path=name)
            cls = load_plugin(CONTROLLERS, plugin, file=file, key_path=key)
            self.controllers[cname] = cls(
                cls.params_model.from_mapping(section, file=file, key_path=key),
                footprint=footprint)
        self.goal_checkers: dict[str, GoalChecker] = {
            g: self._checker(params, g, GOAL_CHECKERS, "nav2_controller::SimpleGoalChecker",
                             file) for g in p.goal_checker_plugins}
        self.progress_checkers: dict[str, ProgressChecker] = {
            c: self._checker(params, c, PROGRESS_CHECKERS,
                             "nav2_controller::SimpleProgressChecker", file)
            for c in p.progress_checker_plugins}
        self._goal: GoalHandle[FollowPathGoal] | None = None
        self._velocity = Twist2D()
        self._last_valid_cmd_t = 0.0
        self.cycles = 0
        self.last_cmd = Twist2D()
        self._plan_cache: tuple[Path, Pose2D, Path] | None = None
        self.speed_limit: tuple[float, bool] = (0.0, True)
        """Last speed limit given to the controllers: ``(limit, percentage)``, 0 = none."""
        self.rejected_speed_limits = 0

    def _checker(self, params: Mapping[str, Any], name: str, registry: ClassRegistry[C],
                 default: str, file: str) -> C:
        key = f"{self.name}.{name}"
        plugin, section = plugin_section(params, name, default, file=file, key_path=self.name)
        cls = load_plugin(registry, plugin, file=file, key_path=key)
        return cls(cls.params_model.from_mapping(section, file=file, key_path=key))

    # --- lifecycle ---------------------------------------------------------------------
    def on_configure(self) -> None:
        p = self.params
        self.pub_cmd = self.create_publisher(p.cmd_vel_topic, Twist, QoS(depth=1))
        self.create_subscription(p.odom_topic, Odometry, self._on_odom, QoS(depth=1))
        self.create_subscription(p.speed_limit_topic, SpeedLimit, self._on_speed_limit,
                                 QoS(depth=10))
        self.server: ActionServer[FollowPathGoal] = ActionServer(
            self.bus, FOLLOW_PATH, self._on_goal, self._on_cancel)
        self.create_timer(1.0 / p.controller_frequency, self._cycle)

    def on_cleanup(self) -> None:
        self.server.close()

    def _on_odom(self, msg: Odometry) -> None:
        self._velocity = msg.twist.twist.to_twist2d()

    def _on_speed_limit(self, msg: SpeedLimit) -> None:
        """Nav2 ``speedLimitCallback``: every controller gets the new limit."""
        limit = float(msg.speed_limit)
        if not math.isfinite(limit) or limit < 0.0 or (msg.percentage and limit > 100.0):
            self.rejected_speed_limits += 1
            self.log.error("ignoring SpeedLimit %r on %s: the limit must be finite and in "
                           "[0, 100] %% or >= 0 m/s", limit, self.params.speed_limit_topic)
            return
        for controller in self.controllers.values():
            controller.set_speed_limit(limit, bool(msg.percentage))
        self.speed_limit = (limit, bool(msg.percentage))

    # --- goals --------------------------------------------------------------------------
    def _on_goal(self, handle: GoalHandle[FollowPathGoal]) -> bool | str:
        goal = handle.goal
        if not goal.path.num_poses:
            return "FollowPath needs a non-empty path"
        cid = goal.controller_id or next(iter(self.controllers))
        if cid not in self.controllers:
            return (f"unknown controller_id '{cid}'; known: {', '.join(self.controllers)}")
        if not np.all(np.isfinite(goal.path.as_array())):
            return "FollowPath path contains NaN or inf"
        if self._goal is not None and not self._goal.done:
            # Nav2 semantics: a new path replaces the running one without stopping
            self._goal.canceled(reason="preempted by a new path")
        else:
            for goal_checker in self.goal_checkers.values():
                goal_checker.reset()
            for progress_checker in self.progress_checkers.values():
                progress_checker.reset()
            self._last_valid_cmd_t = self.now
        handle.execute()
        self._goal = handle
        return True

    def _on_cancel(self, handle: GoalHandle[FollowPathGoal]) -> None:
        if handle is self._goal:
            self._stop()
            self._goal = None
        handle.canceled()

    def _stop(self) -> None:
        self.last_cmd = Twist2D()
        self.pub_cmd.publish(Twist())

    def _abort(self, code: ControllerErrorCode, reason: str) -> None:
        self._stop()
        if self._goal is not None:
            self._goal.fail(int(code), reason)
        self._goal = None

    # --- control cycle --------------------------------------------------------------------
    def _cycle(self) -> None:
        handle = self._goal
        if handle is None or handle.done:
            self._goal = None
            return
        self.cycles += 1
        goal = handle.goal
        costmap = self.local_costmap.costmap
        frame = costmap.frame_id
        try:
            pose = self.tf.lookup_pose2d(frame, self.local_costmap.robot_base_frame)
            path = self._plan_in(goal.path, frame)
        except TransformError as exc:
            self._abort(ControllerErrorCode.TF_ERROR,
                        f"cannot locate the robot or the plan: {exc}")
            return
        # the goal check always uses the current transform (the cached plan may lag a cell)
        goal_pose = Pose2D.from_array(goal.path.as_array()[-1])
        src = goal.path.header.frame_id or frame
        if src != frame:
            try:
                goal_pose = self.tf.lookup_pose2d(frame, src).compose(goal_pose)
            except TransformError as exc:
                self._abort(ControllerErrorCode.TF_ERROR, f"cannot locate the goal: {exc}")
                return
        checker = self.goal_checkers[goal.goal_checker_id or next(iter(self.goal_checkers))]
        if checker.is_goal_reached(pose, goal_pose, self._velocity):
            self._stop()
            handle.succeed()
            self._goal = None
            return
        progress = next(iter(self.progress_checkers.values()))
        if not progress.check(pose, self.now, goal_pose):
            self._abort(ControllerErrorCode.FAILED_TO_MAKE_PROGRESS,
                        f"failed to make progress: {progress.failure_message()}")
            return
        controller = self.controllers[goal.controller_id or next(iter(self.controllers))]
        try:
            cmd = controller.compute(pose, self._velocity, path, costmap, self.now)
        except (ControllerError, InvalidMessage) as exc:
            if self.now - self._last_valid_cmd_t > self.params.failure_tolerance:
                code = ControllerErrorCode.INVALID_PATH if isinstance(
                    exc, InvalidPath | InvalidMessage) else ControllerErrorCode.NO_VALID_CONTROL
                self._abort(code, f"controller failed for longer than failure_tolerance "
                                  f"{self.params.failure_tolerance:.2f} s: {exc}")
            else:
                self._stop()
            return
        self._last_valid_cmd_t = self.now
        self.last_cmd = cmd
        self.pub_cmd.publish(cmd.to_twist())
        xy = path.as_array()[:, :2]
        handle.publish_feedback(FollowPathFeedback(path_distance(xy, pose.x, pose.y),
                                                   math.hypot(cmd.vx, cmd.vy)))

    def _plan_in(self, path: Path, frame: str) -> Path:
        """The plan in the controller's frame.

        Re-transformed only when the plan changes or ``frame <- plan frame`` has moved by
        more than a fifth of a costmap cell (1 cm) / 0.005 rad since the last transform:
        the controller keeps one plan object (a new object resets DWB's critics, as
        Nav2's setPlan does) and odometry jitter does not rebuild the plan every cycle,
        while a SLAM correction of ``map -> odom`` moves the plan's end with the goal the
        goal checker sees (5 cm of lag left the robot turning in place just outside
        the goal tolerance).
        """
        src = path.header.frame_id or frame
        if src == frame:
            return path
        t = self.tf.lookup_pose2d(frame, src)
        cached = self._plan_cache
        if (cached is not None and cached[0] is path and t.distance_to(cached[1]) < 0.01
                and abs(angle_diff(t.theta, cached[1].theta)) < 0.005):
            return cached[2]
        moved = Path.from_array(se2_compose(t.as_array(), path.as_array()), frame,
                                path.header.stamp)
        self._plan_cache = (path, t, moved)
        return moved
