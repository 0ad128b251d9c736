"""``navstack.Navigator``: the nav2_simple_commander ``BasicNavigator`` API on a stack.

Method names and semantics mirror nav2_simple_commander so Nav2 scripts port with few
changes: ``goToPose``, ``goThroughPoses``, ``followWaypoints``, ``followGpsWaypoints``,
``getFeedback``, ``isTaskComplete``, ``cancelTask``, ``getResult``, ``setInitialPose``,
``getPath``, ``clearAllCostmaps``.  The stack runs in this process on simulated time, so
``isTaskComplete()`` advances the simulation by ``spin_period`` (the counterpart of
``rclpy.spin_until_future_complete(timeout_sec=0.1)``) before it answers.
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum
from typing import Any

from navstack.core.errors import NavstackError
from navstack.core.msgs import (
    Header,
    Path,
    Pose2D,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
)
from navstack.interfaces.geo_frame import GeoFrame
from navstack.interfaces.gps_waypoints import gps_waypoints_in_map
from navstack.interfaces.stack import NavStack
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, ActionResult, GoalHandle, GoalStatus
from navstack.runtime.bus import LATCHED


class TaskResult(Enum):
    """nav2_simple_commander.robot_navigator.TaskResult."""

    UNKNOWN = 0
    SUCCEEDED = 1
    CANCELED = 2
    FAILED = 3


_RESULT = {GoalStatus.SUCCEEDED: TaskResult.SUCCEEDED, GoalStatus.CANCELED: TaskResult.CANCELED,
           GoalStatus.FAILED: TaskResult.FAILED, GoalStatus.REJECTED: TaskResult.FAILED}


class Navigator:
    """Drive a :class:`NavStack` the way BasicNavigator drives Nav2 (it is started here if
    it was not yet, like a Nav2 launch brought up before the commander script runs)."""

    def __init__(self, stack: NavStack | None = None, spin_period: float = 0.1) -> None:
        self.stack = (stack if stack is not None else NavStack()).start()
        self.spin_period = spin_period
        bus = self.stack.runtime.bus
        self._nav_to_pose: ActionClient[m.NavigateToPoseGoal] = ActionClient(
            bus, m.NAVIGATE_TO_POSE)
        self._nav_through: ActionClient[m.NavigateThroughPosesGoal] = ActionClient(
            bus, m.NAVIGATE_THROUGH_POSES)
        self._follow: ActionClient[m.FollowWaypointsGoal] = ActionClient(bus, m.FOLLOW_WAYPOINTS)
        self._initial_pose_pub = bus.publisher("/initialpose", PoseWithCovarianceStamped, LATCHED)
        self._task: GoalHandle[Any] | None = None
        self.last_error = ""

    # --- tasks ---------------------------------------------------------------------------
    def _start(self, client: ActionClient[Any], goal: Any) -> bool:
        if self._task is not None and not self._task.done:
            self._task.cancel()
        self.last_error = ""
        try:
            self._task = client.send_goal(goal)
        except NavstackError as exc:
            self.last_error = str(exc)
            self._task = None
            return False
        if self._task.status is GoalStatus.REJECTED:
            self.last_error = self._task.result.error_msg if self._task.result else "rejected"
            return False
        return True

    def goToPose(self, pose: PoseStamped, behavior_tree: str = "") -> bool:
        """Send a NavigateToPose goal; ``False`` (and ``last_error``) if it was rejected."""
        return self._start(self._nav_to_pose, m.NavigateToPoseGoal(pose, behavior_tree))

    def goThroughPoses(self, poses: list[PoseStamped], behavior_tree: str = "") -> bool:
        return self._start(self._nav_through, m.NavigateThroughPosesGoal(tuple(poses),
                                                                          behavior_tree))

    def followWaypoints(self, poses: list[PoseStamped], names: list[str] | None = None) -> bool:
        return self._start(self._follow, m.FollowWaypointsGoal(tuple(poses), tuple(names or ())))

    def followGpsWaypoints(self, gps_poses: Sequence[Any]) -> bool:
        """Follow GPS waypoints: ``(latitude, longitude[, enu_yaw])`` tuples, mappings or
        GeoPose-like objects with ``latitude``/``longitude`` (decimal degrees or
        ``"deg,min,sec"``).  Each is converted into ``map`` through the stack's navsat
        transform (``fromLL``, :meth:`GeoFrame.for_stack`), rotation against east-north
        included, then followed as :meth:`followWaypoints`.  ``False`` (and
        ``last_error`` naming the waypoint) for a bad coordinate."""
        try:
            poses = gps_waypoints_in_map(GeoFrame.for_stack(self.stack), gps_poses,
                                         self._robot_xy(), self.stack.now)
        except NavstackError as exc:  # GeoError included: names the waypoint
            if self._task is not None and not self._task.done:
                self._task.cancel()
            self._task = None
            self.last_error = str(exc)
            return False
        return self.followWaypoints(poses)

    def _robot_xy(self) -> tuple[float, float]:
        try:
            p = self.robot_pose()
        except NavstackError:
            return (0.0, 0.0)
        return (p.x, p.y)

    def isTaskComplete(self) -> bool:
        """Advance the simulation by ``spin_period`` and tell whether the task ended."""
        if self._task is None:
            return True
        if not self._task.done:
            self.stack.run_for(self.spin_period)
        return self._task.done

    def getFeedback(self) -> Any:
        return None if self._task is None else self._task.feedback

    def cancelTask(self) -> None:
        if self._task is not None and not self._task.done:
            self._task.cancel()
            self.stack.run_for(0.0)

    def getResult(self) -> TaskResult:
        if self._task is None or self._task.result is None:
            return TaskResult.UNKNOWN
        return _RESULT.get(self._task.result.status, TaskResult.UNKNOWN)

    def getTaskResult(self) -> ActionResult | None:
        """The full result: status, error code, reason and payload (navstack addition)."""
        return None if self._task is None else self._task.result

    # --- utilities -------------------------------------------------------------------------
    def setInitialPose(self, pose: PoseStamped) -> None:
        """Publish ``/initialpose`` (consumed by localization; the simulator's perfect
        localization ignores it)."""
        cov = PoseWithCovariance(pose.pose)
        cov.covariance[0, 0] = cov.covariance[1, 1] = 0.25
        cov.covariance[5, 5] = 0.0685
        self._initial_pose_pub.publish(PoseWithCovarianceStamped(
            Header(self.stack.now, pose.header.frame_id or "map"), cov))

    def getPath(self, start: PoseStamped, goal: PoseStamped, planner_id: str = "",
                use_start: bool = False) -> Path | None:
        """Plan without moving; ``None`` (and ``last_error``) when planning fails."""
        try:
            return self.stack.planner.compute_path(goal, start if use_start else None,
                                                   planner_id)
        except NavstackError as exc:
            self.last_error = str(exc)
            return None

    def clearAllCostmaps(self) -> None:
        self.stack.global_costmap.clear_all()
        self.stack.local_costmap.clear_all()

    def clearLocalCostmap(self) -> None:
        self.stack.local_costmap.clear_all()

    def clearGlobalCostmap(self) -> None:
        self.stack.global_costmap.clear_all()

    def waitUntilNav2Active(self) -> None:
        """The in-process stack is active once constructed (kept for API parity)."""

    def robot_pose(self) -> Pose2D:
        """The robot's pose in ``map`` from TF (navstack addition)."""
        return self.stack.runtime.tf.lookup_pose2d("map", "base_link")
