"""py_trees behaviours for missions with markers, packages and the gripper.

Every behaviour talks to the stack through the bus only (actions, services, latched
topics, TF), so a mission runs the same on a real robot as in the simulator; a
:class:`MarkerContext` holds the shared clients.  Behaviours never block: each tick looks
at a goal handle or a topic and returns RUNNING until there is an outcome.

* :class:`NavigateTo` -- a NavigateToPose goal to a pose computed once, on the first tick
  (latched), SUCCESS / FAILURE with the navigator's reason;
* :class:`SpinSearch` -- turn in place (the Spin behavior) until a condition holds;
* :class:`WaitFor` -- a condition within a timeout;
* :class:`ApproachMarker` -- the rover's ``aruco_approach``: the marker's pose plus an
  offset becomes a goal facing the marker, latched once; the mode string ``auto`` is
  published while driving and ``success`` on arrival (the rover's LED modes);
* :class:`IgnorePackage`, :class:`DockToPackage`, :class:`Grip` -- the TurtleBot course's
  package pick: drop the target's virtual obstacle, face it and drive up until it is in
  the gripper's reach, close the gripper and check it holds the package.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import py_trees
from py_trees.common import Status

from navstack.core.errors import NavstackError, TransformError
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import Pose2D, PoseStamped, String
from navstack.core.msgs.fiducial_msgs import (
    IGNORE_PACKAGE_SERVICE,
    MARKER_MAP_TOPIC,
    PACKAGES_TOPIC,
    ArucoMarkerArray,
)
from navstack.core.msgs.gripper_msgs import GRIPPER_SERVICE, GRIPPER_STATUS_TOPIC, ServoCommand
from navstack.core.rotations import quaternion_to_matrix
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Runtime

__all__ = ["ApproachMarker", "DockToPackage", "DriveStraightTo", "Grip", "IgnorePackage",
           "MarkerContext", "NavigateTo", "SpinSearch", "WaitFor", "marker_goal"]


class MarkerContext:
    """Clients and latest data shared by the behaviours of one mission."""

    def __init__(self, runtime: Runtime, map_frame: str = "map", base_frame: str = "base_link",
                 mode_topic: str = "/mode") -> None:
        self.runtime = runtime
        self.bus = runtime.bus
        self.map_frame = map_frame
        self.base_frame = base_frame
        self.navigate = ActionClient[m.NavigateToPoseGoal](self.bus, m.NAVIGATE_TO_POSE)
        self.spin = ActionClient[m.SpinGoal](self.bus, m.SPIN)
        self.drive = ActionClient[m.DriveOnHeadingGoal](self.bus, m.DRIVE_ON_HEADING)
        self.markers: dict[int, Any] = {}
        self.packages: dict[int, Any] = {}
        self.gripper_status = ""
        self.bus.subscribe(MARKER_MAP_TOPIC, ArucoMarkerArray, self._on_markers, LATCHED)
        self.bus.subscribe(PACKAGES_TOPIC, ArucoMarkerArray, self._on_packages, LATCHED)
        self.bus.subscribe(GRIPPER_STATUS_TOPIC, String, self._on_gripper, LATCHED)
        self.mode = self.bus.publisher(mode_topic, String, QoS(depth=1, latched=True))

    @property
    def now(self) -> float:
        return self.runtime.now

    def _on_markers(self, msg: ArucoMarkerArray) -> None:
        self.markers = {mk.id: mk for mk in msg.markers}

    def _on_packages(self, msg: ArucoMarkerArray) -> None:
        self.packages = {mk.id: mk for mk in msg.markers}

    def _on_gripper(self, msg: String) -> None:
        self.gripper_status = msg.data

    def robot_pose(self) -> Pose2D | None:
        try:
            return self.runtime.tf.lookup_pose2d(self.map_frame, self.base_frame)
        except TransformError:
            return None

    def package_xy(self, package_id: int) -> tuple[float, float] | None:
        found = self.packages.get(package_id)
        if found is None:
            return None
        p = found.pose.pose.position
        return float(p.x), float(p.y)

    def marker_facing(self, marker_id: int) -> tuple[float, float, float] | None:
        """``(x, y, facing yaw)`` of a mapped marker (facing: its z axis in the map)."""
        found = self.markers.get(marker_id)
        if found is None:
            return None
        pose = found.pose.pose
        r = quaternion_to_matrix(pose.orientation)
        return float(pose.position.x), float(pose.position.y), math.atan2(r[1, 2], r[0, 2])


def marker_goal(x: float, y: float, facing: float, distance: float, lateral: float = 0.0
                ) -> Pose2D:
    """The pose ``distance`` in front of a marker at ``(x, y)`` facing ``facing`` (plus
    ``lateral`` to its right as seen from the robot), looking at the marker."""
    c, s = math.cos(facing), math.sin(facing)
    return Pose2D(x + distance * c + lateral * s, y + distance * s - lateral * c,
                  normalize_angle(facing + math.pi))


class _ActionBehaviour(py_trees.behaviour.Behaviour):
    """Sends one goal (``send()``, or None: FAILURE) on the first tick, RUNNING until the
    goal ends."""

    def __init__(self, name: str, ctx: MarkerContext,
                 send: Callable[[], GoalHandle[Any] | None]) -> None:
        super().__init__(name)
        self.ctx = ctx
        self.send = send
        self.handle: GoalHandle[Any] | None = None
        self.reason = ""

    def initialise(self) -> None:
        self.handle = None
        self.reason = ""

    def update(self) -> Status:
        if self.handle is None:
            try:
                self.handle = self.send()
            except NavstackError as exc:
                self.reason = str(exc)
                return Status.FAILURE
            if self.handle is None:
                return Status.FAILURE
        if not self.handle.done:
            return Status.RUNNING
        result = self.handle.result
        if self.handle.status is GoalStatus.SUCCEEDED:
            return Status.SUCCESS
        self.reason = result.error_msg if result is not None else str(self.handle.status)
        self.feedback_message = self.reason
        return Status.FAILURE

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID and self.handle is not None and not self.handle.done:
            self.handle.cancel()


class NavigateTo(_ActionBehaviour):
    """NavigateToPose to ``target()``, evaluated once when the behaviour starts."""

    def __init__(self, name: str, ctx: MarkerContext, target: Callable[[], Pose2D | None]
                 ) -> None:
        super().__init__(name, ctx, self._send_goal)
        self.target = target
        self.goal: Pose2D | None = None

    def _send_goal(self) -> GoalHandle[Any] | None:
        self.goal = self.target()
        if self.goal is None:
            self.reason = "no goal pose available"
            return None
        pose = PoseStamped.from_pose2d(self.goal, self.ctx.map_frame, self.ctx.now)
        return self.ctx.navigate.send_goal(m.NavigateToPoseGoal(pose))


class SpinSearch(_ActionBehaviour):
    """Turn in place by ``angle`` [rad]; SUCCESS as soon as ``found()`` holds (the spin is
    cancelled), FAILURE when the turn ends without it."""

    def __init__(self, name: str, ctx: MarkerContext, found: Callable[[], bool],
                 angle: float = 2.0 * math.pi, time_allowance: float = 30.0) -> None:
        super().__init__(name, ctx, self._spin)
        self.found = found
        self.angle = angle
        self.time_allowance = time_allowance

    def _spin(self) -> GoalHandle[Any] | None:
        return self.ctx.spin.send_goal(m.SpinGoal(self.angle, self.time_allowance))

    def update(self) -> Status:
        if self.found():
            if self.handle is not None and not self.handle.done:
                self.handle.cancel()
            return Status.SUCCESS
        status = super().update()
        return Status.FAILURE if status is Status.SUCCESS else status


class WaitFor(py_trees.behaviour.Behaviour):
    """SUCCESS once ``condition()`` holds, FAILURE after ``timeout`` seconds (sim time)."""

    def __init__(self, name: str, ctx: MarkerContext, condition: Callable[[], bool],
                 timeout: float = math.inf) -> None:
        super().__init__(name)
        self.ctx = ctx
        self.condition = condition
        self.timeout = timeout
        self._start = 0.0

    def initialise(self) -> None:
        self._start = self.ctx.now

    def update(self) -> Status:
        if self.condition():
            return Status.SUCCESS
        if self.ctx.now - self._start > self.timeout:
            self.feedback_message = f"not within {self.timeout:.0f} s"
            return Status.FAILURE
        return Status.RUNNING


class ApproachMarker(NavigateTo):
    """The rover's marker approach (module docstring): ``distance`` in front of marker
    ``marker_id`` (and ``lateral`` aside), facing it, goal latched on the first tick;
    publishes ``auto`` while driving and ``success`` on arrival on the mode topic."""

    def __init__(self, name: str, ctx: MarkerContext, marker_id: int, distance: float = 1.0,
                 lateral: float = 0.0) -> None:
        super().__init__(name, ctx, self._goal)
        self.marker_id = marker_id
        self.distance = distance
        self.lateral = lateral

    def _goal(self) -> Pose2D | None:
        found = self.ctx.marker_facing(self.marker_id)
        if found is None:
            self.reason = f"marker {self.marker_id} is not on the map"
            return None
        return marker_goal(*found, self.distance, self.lateral)

    def update(self) -> Status:
        status = super().update()
        if status is Status.RUNNING and self.handle is not None:
            self.ctx.mode.publish(String("auto"))
        elif status is Status.SUCCESS:
            self.ctx.mode.publish(String("success"))
        return status


class IgnorePackage(py_trees.behaviour.Behaviour):
    """Remove a package's ring from the costmaps (the one about to be gripped): out of the
    package cloud, then both costmaps cleared (Nav2's clear services), since the obstacle
    layer keeps marked cells until a ray clears them and the lidar's rays pass above a
    package's ring without ending there; the lidar and the cloud re-mark the rest at the
    next update."""

    def __init__(self, name: str, ctx: MarkerContext, package_id: int) -> None:
        super().__init__(name)
        self.ctx = ctx
        self.package_id = package_id
        self._asked_at: float | None = None

    def initialise(self) -> None:
        self._asked_at = None

    def update(self) -> Status:
        try:
            if self._asked_at is None:
                self.ctx.bus.call(IGNORE_PACKAGE_SERVICE, self.package_id)
                self._asked_at = self.ctx.now
                return Status.RUNNING
            if self.ctx.now <= self._asked_at:
                return Status.RUNNING  # let the costmaps receive the cloud without it first
            for service in (m.CLEAR_GLOBAL_COSTMAP, m.CLEAR_LOCAL_COSTMAP):
                self.ctx.bus.call(service, None)
        except NavstackError as exc:
            self.feedback_message = str(exc)
            return Status.FAILURE
        return Status.SUCCESS


class DriveStraightTo(py_trees.behaviour.Behaviour):
    """Face the point ``target()`` (Spin) and drive straight to it (DriveOnHeading) until
    it is ``stop_distance`` ahead of ``base_link``, then optionally turn to ``final_yaw``;
    FAILURE if the point is unknown, farther than ``max_distance``, or a motion fails.
    Docking to a package, or the last centimetres to a pose the navigator reached only
    within its goal tolerance."""

    def __init__(self, name: str, ctx: MarkerContext,
                 target: Callable[[], tuple[float, float] | None], stop_distance: float,
                 max_distance: float = 1.0, speed: float = 0.05,
                 final_yaw: float | None = None, tolerance: float = 0.01) -> None:
        super().__init__(name)
        self.ctx = ctx
        self.target = target
        self.stop_distance = stop_distance
        self.max_distance = max_distance
        self.speed = speed
        self.final_yaw = final_yaw
        self.tolerance = tolerance
        self._spins = self._drives = self._turns = 0
        self._handle: GoalHandle[Any] | None = None

    def initialise(self) -> None:
        self._spins = self._drives = self._turns = 0
        self._handle = None

    def update(self) -> Status:
        if self._handle is not None:
            if not self._handle.done:
                return Status.RUNNING
            if self._handle.status is not GoalStatus.SUCCEEDED:
                result = self._handle.result
                self.feedback_message = result.error_msg if result is not None else "failed"
                return Status.FAILURE
            self._handle = None
        robot = self.ctx.robot_pose()
        point = self.target()
        if robot is None or point is None:
            self.feedback_message = "the target point or the robot pose is unknown"
            return Status.FAILURE
        dx, dy = point[0] - robot.x, point[1] - robot.y
        dist = math.hypot(dx, dy)
        turn = math.atan2(dy, dx) - robot.theta
        turn = math.atan2(math.sin(turn), math.cos(turn))
        if dist > self.max_distance:
            self.feedback_message = f"the target is {dist:.2f} m away"
            return Status.FAILURE
        remaining = dist - self.stop_distance
        # the Spin behavior stops within ~0.1 rad: aim again before each leg; the legs
        # shorten as the point nears so the last one starts well aimed
        if remaining > self.tolerance and self._drives < 4:
            if abs(turn) > 0.02 and self._spins < 4 + self._drives:
                self._spins += 1
                self._handle = self.ctx.spin.send_goal(m.SpinGoal(turn, 10.0))
                return Status.RUNNING
            self._drives += 1
            leg = remaining if remaining < 0.12 or self._drives >= 3 else 0.7 * remaining
            self._handle = self.ctx.drive.send_goal(m.DriveOnHeadingGoal(leg, self.speed, 30.0))
            return Status.RUNNING
        if self.final_yaw is not None and self._turns < 3:
            rest = self.final_yaw - robot.theta
            rest = math.atan2(math.sin(rest), math.cos(rest))
            if abs(rest) > 0.05:
                self._turns += 1
                self._handle = self.ctx.spin.send_goal(m.SpinGoal(rest, 10.0))
                return Status.RUNNING
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID and self._handle is not None and not self._handle.done:
            self._handle.cancel()


class DockToPackage(DriveStraightTo):
    """Face package ``package_id`` and drive up until its centre is ``grip_distance``
    ahead of ``base_link`` (within the gripper's reach)."""

    def __init__(self, name: str, ctx: MarkerContext, package_id: int, grip_distance: float,
                 max_distance: float = 1.0, speed: float = 0.05) -> None:
        super().__init__(name, ctx, lambda: ctx.package_xy(package_id), grip_distance,
                         max_distance, speed)
        self.package_id = package_id


class Grip(py_trees.behaviour.Behaviour):
    """Close the gripper through the servo service (``duty`` %, the course's 7 %) and wait
    until it reports holding a package (FAILURE after ``timeout`` s)."""

    def __init__(self, name: str, ctx: MarkerContext, pin: int = 20, duty: float = 7.0,
                 timeout: float = 4.0) -> None:
        super().__init__(name)
        self.ctx = ctx
        self.pin = pin
        self.duty = duty
        self.timeout = timeout
        self._start: float | None = None

    def initialise(self) -> None:
        self._start = None

    def update(self) -> Status:
        if self._start is None:
            try:
                reply = self.ctx.bus.call(GRIPPER_SERVICE, ServoCommand(self.pin, self.duty))
            except NavstackError as exc:
                self.feedback_message = str(exc)
                return Status.FAILURE
            if reply != "OK":
                self.feedback_message = f"gripper replied {reply!r}"
                return Status.FAILURE
            self._start = self.ctx.now
        if self.ctx.gripper_status.startswith("holding"):
            return Status.SUCCESS
        if self.ctx.now - self._start > self.timeout:
            self.feedback_message = f"gripper closed but holds nothing ({self.ctx.gripper_status})"
            return Status.FAILURE
        return Status.RUNNING
