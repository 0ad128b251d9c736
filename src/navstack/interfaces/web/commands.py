"""``NavCommander``: the dashboard's navigation commands, executed in the simulation thread.

Goals go to the stack's BT navigator through the Nav2 action names (``/navigate_to_pose``,
``/navigate_through_poses``) and waypoint lists to the waypoint follower
(``/follow_waypoints``), exactly as nav2_simple_commander's ``goToPose``,
``goThroughPoses`` and ``followWaypoints`` do; a new task cancels the running one (as
``BasicNavigator`` does).  A goal without a heading faces along the straight line from the
robot to the goal (RViz's "2D Goal Pose" is a click plus a drag; a plain click keeps the
direction of travel).  :meth:`NavCommander.status` reports the task, its status, the
navigator feedback (distance remaining, estimated time, recoveries) and the waypoint being
driven to.

Every method must run in the simulation thread (see :class:`LiveRunner.submit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

from navstack.core.errors import NavstackError, TransformError
from navstack.core.msgs import Header, Pose2D, PoseStamped
from navstack.interfaces.stack import NavStack
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus

TaskKind = Literal["navigate_to_pose", "navigate_through_poses", "follow_waypoints"]
GoMode = Literal["follow_waypoints", "navigate_through_poses"]
MAX_WAYPOINTS = 100


class CommandRejected(NavstackError):
    """A dashboard command cannot be carried out; the message says why and what to do."""


class GoalOutOfBounds(CommandRejected):
    """A goal or waypoint outside the map navigation plans on (``field`` names the
    offending coordinate)."""

    def __init__(self, message: str, field: str) -> None:
        super().__init__(message)
        self.field = field


@dataclass
class _Task:
    kind: TaskKind
    handle: GoalHandle[Any]
    poses: tuple[Pose2D, ...]
    started: float


def goal_heading(robot: Pose2D | None, x: float, y: float) -> float:
    """Heading [rad] of a goal at (x, y) given without one: along robot -> goal (0 when the
    robot pose is unknown or the goal is on top of the robot)."""
    if robot is None or math.hypot(x - robot.x, y - robot.y) < 1e-6:
        return 0.0
    return math.atan2(y - robot.y, x - robot.x)


class NavCommander:
    """Sends and tracks navigation tasks on a :class:`NavStack` (simulation thread only)."""

    def __init__(self, stack: NavStack, frame_id: str = "map") -> None:
        self.stack = stack
        self.frame_id = frame_id
        bus = stack.runtime.bus
        self._clients: dict[TaskKind, ActionClient[Any]] = {
            "navigate_to_pose": ActionClient(bus, m.NAVIGATE_TO_POSE),
            "navigate_through_poses": ActionClient(bus, m.NAVIGATE_THROUGH_POSES),
            "follow_waypoints": ActionClient(bus, m.FOLLOW_WAYPOINTS),
        }
        self.waypoints: list[Pose2D] = []
        self._task: _Task | None = None
        self._last: dict[str, Any] | None = None

    # --- helpers -------------------------------------------------------------------------------
    def robot_pose(self) -> Pose2D | None:
        try:
            return self.stack.runtime.tf.lookup_pose2d(self.frame_id, "base_link")
        except TransformError:
            return None

    def _pose(self, x: float, y: float, theta: float | None,
              origin: Pose2D | None = None) -> Pose2D:
        if not (math.isfinite(x) and math.isfinite(y)
                and (theta is None or math.isfinite(theta))):
            raise CommandRejected(f"goal ({x}, {y}, {theta}) is not finite; send numbers")
        self._check_bounds(x, y)
        heading = goal_heading(origin or self.robot_pose(), x, y) if theta is None else theta
        return Pose2D(x, y, math.atan2(math.sin(heading), math.cos(heading)))

    def goal_bounds(self) -> tuple[float, float, float, float] | None:
        """(xmin, ymin, xmax, ymax) [m] of the global costmap when it is in ``frame_id``:
        goals outside it cannot be planned to (None: no bound known)."""
        try:
            node = self.stack.global_costmap
        except NavstackError:
            return None
        if node.global_frame != self.frame_id:
            return None
        cm = node.costmap
        return (cm.origin_x, cm.origin_y, cm.origin_x + cm.size_x * cm.resolution,
                cm.origin_y + cm.size_y * cm.resolution)

    def _check_bounds(self, x: float, y: float) -> None:
        bounds = self.goal_bounds()
        if bounds is None:
            return
        xmin, ymin, xmax, ymax = bounds
        for name, v, lo, hi in (("x", x, xmin, xmax), ("y", y, ymin, ymax)):
            if not lo <= v <= hi:
                raise GoalOutOfBounds(f"{name}={v:g} is outside the map: {name} must lie in "
                                      f"[{lo:g}, {hi:g}] m ({self.frame_id} frame)", name)

    def _stamped(self, pose: Pose2D) -> PoseStamped:
        return PoseStamped(Header(self.stack.now, self.frame_id), pose.to_pose())

    def _start(self, kind: TaskKind, goal: Any, poses: tuple[Pose2D, ...]) -> dict[str, Any]:
        self.cancel()
        try:
            handle = self._clients[kind].send_goal(goal)
        except NavstackError as exc:
            raise CommandRejected(str(exc)) from None
        if handle.status is GoalStatus.REJECTED:
            reason = handle.result.error_msg if handle.result else "goal rejected"
            raise CommandRejected(f"{kind} goal rejected: {reason}")
        self._task = _Task(kind, handle, poses, self.stack.now)
        self._last = None
        return {"task": kind, "goal_id": handle.goal_id, "status": handle.status.value,
                "poses": [[p.x, p.y, p.theta] for p in poses], "time": self.stack.now}

    # --- commands -------------------------------------------------------------------------------
    def go_to(self, x: float, y: float, theta: float | None = None) -> dict[str, Any]:
        """NavigateToPose to (x, y, theta) in ``frame_id`` (``theta=None``: face the goal)."""
        pose = self._pose(x, y, theta)
        return self._start("navigate_to_pose",
                           m.NavigateToPoseGoal(self._stamped(pose)), (pose,))

    def add_waypoint(self, x: float, y: float, theta: float | None = None) -> dict[str, Any]:
        """Append a waypoint; without a heading it faces away from the previous waypoint
        (or the robot, for the first one)."""
        if len(self.waypoints) >= MAX_WAYPOINTS:
            raise CommandRejected(f"already {MAX_WAYPOINTS} waypoints; send 'go' or clear them")
        origin = self.waypoints[-1] if self.waypoints else None
        self.waypoints.append(self._pose(x, y, theta, origin))
        return self.waypoint_list()

    def clear_waypoints(self) -> dict[str, Any]:
        self.waypoints.clear()
        return self.waypoint_list()

    def waypoint_list(self) -> dict[str, Any]:
        return {"waypoints": [[p.x, p.y, p.theta] for p in self.waypoints]}

    def go(self, mode: GoMode = "follow_waypoints") -> dict[str, Any]:
        """Drive the waypoint list: FollowWaypoints (stop at each) or NavigateThroughPoses
        (one smooth pass).  The list is consumed."""
        if not self.waypoints:
            raise CommandRejected("no waypoints to go to; add waypoints first (waypoint mode, "
                                  "then click the map)")
        poses = tuple(self.waypoints)
        stamped = tuple(self._stamped(p) for p in poses)
        if mode == "follow_waypoints":
            goal: Any = m.FollowWaypointsGoal(
                stamped, tuple(f"waypoint {i + 1}" for i in range(len(poses))))
        elif mode == "navigate_through_poses":
            goal = m.NavigateThroughPosesGoal(stamped)
        else:
            raise CommandRejected(f"unknown mode '{mode}'; use 'follow_waypoints' or "
                                  f"'navigate_through_poses'")
        out = self._start(mode, goal, poses)
        self.waypoints.clear()
        return out

    def cancel(self) -> dict[str, Any]:
        """Cancel the running task (no-op when idle)."""
        task = self._task
        if task is not None and not task.handle.done:
            task.handle.cancel()
            return {"canceled": task.kind, "goal_id": task.handle.goal_id}
        return {"canceled": None}

    # --- status ---------------------------------------------------------------------------------
    def status(self) -> dict[str, Any]:
        """Task, status, feedback and waypoint progress (plain JSON-able values)."""
        task = self._task
        out: dict[str, Any] = {"task": None, "status": "IDLE", "reason": "",
                               "distance_remaining": None, "eta": None, "recoveries": 0,
                               "navigation_time": None, "current_waypoint": None,
                               "waypoint_count": 0, "waypoint_name": "", "goal": None,
                               "goals": [], "goal_id": None}
        if task is None:
            return out
        h = task.handle
        out.update(task=task.kind, status=h.status.value, goal_id=h.goal_id,
                   goals=[[p.x, p.y, p.theta] for p in task.poses])
        if h.result is not None:
            out["reason"] = h.result.error_msg
        nav_fb: Any = h.feedback
        goal_index = len(task.poses) - 1
        if task.kind == "follow_waypoints":
            out["waypoint_count"] = len(task.poses)
            fb = h.feedback
            if isinstance(fb, m.FollowWaypointsFeedback):
                goal_index = min(fb.current_waypoint, len(task.poses) - 1)
                out["current_waypoint"] = fb.current_waypoint
                out["waypoint_name"] = fb.current_waypoint_name
            active = self.stack.navigator.active_goal
            nav_fb = active.feedback if active is not None and not h.done else None
        elif task.kind == "navigate_through_poses":
            out["waypoint_count"] = len(task.poses)
            if isinstance(nav_fb, m.NavigateFeedback):
                remaining = nav_fb.number_of_poses_remaining
                goal_index = max(0, len(task.poses) - max(remaining, 1))
                out["current_waypoint"] = goal_index
        out["goal"] = [task.poses[goal_index].x, task.poses[goal_index].y,
                       task.poses[goal_index].theta]
        if isinstance(nav_fb, m.NavigateFeedback):
            out.update(distance_remaining=_finite(nav_fb.distance_remaining),
                       eta=_finite(nav_fb.estimated_time_remaining),
                       recoveries=nav_fb.number_of_recoveries,
                       navigation_time=_finite(nav_fb.navigation_time))
        result = h.result.result if h.result is not None else None
        if result is not None and hasattr(result, "number_of_recoveries"):
            out["recoveries"] = int(result.number_of_recoveries)
        if isinstance(result, m.FollowWaypointsResult) and result.missed_waypoints:
            out["missed_waypoints"] = [w.index for w in result.missed_waypoints]
        return out


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None
