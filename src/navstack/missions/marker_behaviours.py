"""Mission behaviours for markers, packages and the gripper, on the mission layer.

They build on :mod:`navstack.missions.behaviours` (:class:`MissionBehaviour`,
:class:`NavigateToPose`, :class:`Spin`, ...) and a :class:`MarkerContext` -- a
:class:`~navstack.missions.context.MissionContext` that also keeps the marker map, the
packages and the gripper's status from their latched topics.  Every behaviour talks to
the stack through the bus only (actions, services, latched topics, TF), so a mission runs
the same on a real robot as in the simulator, and never blocks: each tick looks at a goal
handle or a topic and returns RUNNING until there is an outcome.  A failure is recorded
on the context with its reason (the mission's result reason).

* :class:`SpinSearch` -- a :class:`Spin` that succeeds (and cancels the turn) as soon as a
  condition holds;
* :class:`ApproachMarker` -- the rover's ``aruco_approach``: a :class:`NavigateToPose` to
  the marker's pose plus an offset, facing the marker, latched when it starts; the mode
  string ``auto`` is published while driving and ``success`` on arrival (the rover's LED
  modes);
* :class:`IgnorePackage`, :class:`DriveStraightTo` / :class:`DockToPackage`,
  :class:`Grip` -- the TurtleBot course's package pick: drop the target's virtual
  obstacle, face it and drive up until it is in the gripper's reach, close the gripper
  and check it holds the package.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from py_trees.common import Status

from navstack.core.errors import NavstackError
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import Pose2D, String
from navstack.core.msgs.fiducial_msgs import (
    IGNORE_PACKAGE_SERVICE,
    MARKER_MAP_TOPIC,
    PACKAGES_TOPIC,
    ArucoMarkerArray,
)
from navstack.core.msgs.gripper_msgs import GRIPPER_SERVICE, GRIPPER_STATUS_TOPIC, ServoCommand
from navstack.core.rotations import quaternion_to_matrix
from navstack.missions.behaviours import MissionBehaviour, NavigateToPose, Spin
from navstack.missions.context import MissionContext
from navstack.navigation import messages as m
from navstack.runtime.actions import GoalHandle, GoalStatus
from navstack.runtime.bus import LATCHED, QoS

__all__ = ["ApproachMarker", "DockToPackage", "DriveStraightTo", "Grip", "IgnorePackage",
           "MarkerContext", "SpinSearch", "marker_goal"]


@dataclass
class MarkerContext(MissionContext):
    """A mission context that also keeps the marker map (``markers``), the packages
    (``packages``, by marker id) and the gripper's status, and publishes the mode string
    on ``mode_topic``."""

    mode_topic: str = "/mode"

    def __post_init__(self) -> None:
        super().__post_init__()
        self.markers: dict[int, Any] = {}
        self.packages: dict[int, Any] = {}
        self.gripper_status = ""
        bus = self.runtime.bus
        self._subs += [bus.subscribe(MARKER_MAP_TOPIC, ArucoMarkerArray, self._on_markers,
                                     LATCHED),
                       bus.subscribe(PACKAGES_TOPIC, ArucoMarkerArray, self._on_packages,
                                     LATCHED),
                       bus.subscribe(GRIPPER_STATUS_TOPIC, String, self._on_gripper, LATCHED)]
        self.mode = bus.publisher(self.mode_topic, String, QoS(depth=1, latched=True))

    def _on_markers(self, msg: ArucoMarkerArray) -> None:
        self.markers = {mk.id: mk for mk in msg.markers}

    def _on_packages(self, msg: ArucoMarkerArray) -> None:
        self.packages = {mk.id: mk for mk in msg.markers}

    def _on_gripper(self, msg: String) -> None:
        self.gripper_status = msg.data

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


class SpinSearch(Spin):
    """Turn in place by ``angle`` [rad]; SUCCESS as soon as ``found()`` holds (the spin is
    cancelled), FAILURE when the turn ends without it."""

    def __init__(self, ctx: MissionContext, found: Callable[[], bool], what: str,
                 angle: float = 2.0 * math.pi, time_allowance: float = 30.0,
                 name: str = "SpinSearch") -> None:
        super().__init__(ctx, angle, name, time_allowance)
        self.found = found
        self.what = what

    def update(self) -> Status:
        if self.found():
            if self.handle is not None and not self.handle.done:
                self.handle.cancel()
            return Status.SUCCESS
        status = super().update()
        if status is Status.SUCCESS:
            return self.failed(f"turned {self.angle:.2f} rad without seeing {self.what}")
        return status


class ApproachMarker(NavigateToPose):
    """The rover's marker approach (module docstring): ``distance`` in front of marker
    ``marker_id`` (and ``lateral`` aside), facing it, goal latched when the behaviour
    starts; publishes ``auto`` while driving and ``success`` on arrival on the context's
    mode topic."""

    def __init__(self, ctx: MarkerContext, marker_id: int, distance: float = 1.0,
                 lateral: float = 0.0, name: str = "ApproachMarker") -> None:
        super().__init__(ctx, self._goal, name)
        self.mctx = ctx
        self.marker_id = marker_id
        self.distance = distance
        self.lateral = lateral

    def _goal(self) -> Pose2D | None:
        found = self.mctx.marker_facing(self.marker_id)
        return None if found is None else marker_goal(*found, self.distance, self.lateral)

    def make_goal(self) -> m.NavigateToPoseGoal | str:
        if self.mctx.marker_facing(self.marker_id) is None:
            return f"marker {self.marker_id} is not on the map"
        return super().make_goal()

    def update(self) -> Status:
        status = super().update()
        if status is Status.RUNNING:
            self.mctx.mode.publish(String("auto"))
        elif status is Status.SUCCESS:
            self.mctx.mode.publish(String("success"))
        return status


class IgnorePackage(MissionBehaviour):
    """Remove a package's ring from the costmaps (the one about to be gripped): out of the
    package cloud, then both costmaps cleared (Nav2's clear services), since the obstacle
    layer keeps marked cells until a ray clears them and the lidar's rays pass above a
    package's ring without ending there; the lidar and the cloud re-mark the rest at the
    next update."""

    def __init__(self, ctx: MissionContext, package_id: int,
                 name: str = "IgnorePackage") -> None:
        super().__init__(ctx, name)
        self.package_id = package_id
        self._asked_at: float | None = None

    def initialise(self) -> None:
        self._asked_at = None

    def update(self) -> Status:
        try:
            if self._asked_at is None:
                self.ctx.call(IGNORE_PACKAGE_SERVICE, self.package_id)
                self._asked_at = self.ctx.now
                return Status.RUNNING
            if self.ctx.now <= self._asked_at:
                return Status.RUNNING  # let the costmaps receive the cloud without it first
            for service in (m.CLEAR_GLOBAL_COSTMAP, m.CLEAR_LOCAL_COSTMAP):
                self.ctx.call(service, None)
        except NavstackError as exc:
            return self.failed(f"cannot take package {self.package_id} off the costmaps: "
                               f"{exc}")
        return Status.SUCCESS


class DriveStraightTo(MissionBehaviour):
    """Face the point ``target()`` (Spin) and drive straight to it (DriveOnHeading) until
    it is ``stop_distance`` ahead of ``base_link``, then optionally turn to ``final_yaw``
    (a heading, or a callable giving one when the turn starts); FAILURE if the point is
    unknown, farther than ``max_distance``, or a motion fails.  Docking to a package, or
    the last centimetres to a pose the navigator reached only within its goal tolerance:
    with ``stop_distance`` 0, a point behind the robot and within ``reverse_within`` [m]
    is reached backwards (no half turn, which a long-bodied robot cannot always make next
    to an obstacle)."""

    def __init__(self, ctx: MissionContext, target: Callable[[], tuple[float, float] | None],
                 stop_distance: float, max_distance: float = 1.0, speed: float = 0.05,
                 final_yaw: float | Callable[[], float | None] | None = None,
                 tolerance: float = 0.01, reverse_within: float = 0.3,
                 name: str = "DriveStraightTo") -> None:
        super().__init__(ctx, name)
        self.target = target
        self.stop_distance = stop_distance
        self.max_distance = max_distance
        self.speed = speed
        self.final_yaw = final_yaw
        self.tolerance = tolerance
        self.reverse_within = reverse_within
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
                why = result.error_msg if result is not None else "no reason given"
                return self.failed(f"{self._handle.status.value}: {why}")
            self._handle = None
        robot = self.ctx.robot_pose()
        point = self.target()
        if robot is None or point is None:
            return self.failed("the target point or the robot pose is unknown")
        dx, dy = point[0] - robot.x, point[1] - robot.y
        dist = math.hypot(dx, dy)
        turn = normalize_angle(math.atan2(dy, dx) - robot.theta)
        if dist > self.max_distance:
            return self.failed(f"the target is {dist:.2f} m away (at most "
                               f"{self.max_distance:.2f} m)")
        remaining = dist - self.stop_distance
        sign = 1.0
        if (self.stop_distance <= 0.0 and abs(turn) > 0.5 * math.pi
                and dist <= self.reverse_within):
            sign, turn = -1.0, normalize_angle(turn - math.pi)  # aim the rear at it
        # the Spin behavior stops within ~0.1 rad: aim again before each leg; the legs
        # shorten as the point nears so the last one starts well aimed
        if remaining > self.tolerance and self._drives < 4:
            if abs(turn) > 0.02 and self._spins < 4 + self._drives:
                self._spins += 1
                self._handle = self.ctx.spin.send_goal(m.SpinGoal(turn, 10.0))
                return Status.RUNNING
            self._drives += 1
            leg = remaining if remaining < 0.12 or self._drives >= 3 else 0.7 * remaining
            self._handle = self.ctx.drive_on_heading.send_goal(
                m.DriveOnHeadingGoal(sign * leg, sign * self.speed, 30.0))
            return Status.RUNNING
        final_yaw = self.final_yaw() if callable(self.final_yaw) else self.final_yaw
        if final_yaw is not None and self._turns < 3:
            rest = normalize_angle(final_yaw - robot.theta)
            if abs(rest) > 0.05:
                self._turns += 1
                self._handle = self.ctx.spin.send_goal(m.SpinGoal(rest, 10.0))
                return Status.RUNNING
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID and self._handle is not None and not self._handle.done:
            self._handle.cancel()
            self.ctx.stop_robot()


class DockToPackage(DriveStraightTo):
    """Face package ``package_id`` and drive up until its centre is ``grip_distance``
    ahead of ``base_link`` (within the gripper's reach)."""

    def __init__(self, ctx: MarkerContext, package_id: int, grip_distance: float,
                 max_distance: float = 1.0, speed: float = 0.05,
                 name: str = "DockToPackage") -> None:
        super().__init__(ctx, lambda: ctx.package_xy(package_id), grip_distance,
                         max_distance, speed, name=name)
        self.package_id = package_id


class Grip(MissionBehaviour):
    """Close the gripper through the servo service (``duty`` %, the course's 7 %) and wait
    until it reports holding a package (FAILURE after ``timeout`` s)."""

    def __init__(self, ctx: MarkerContext, pin: int = 20, duty: float = 7.0,
                 timeout: float = 4.0, name: str = "Grip") -> None:
        super().__init__(ctx, name)
        self.mctx = ctx
        self.pin = pin
        self.duty = duty
        self.timeout = timeout
        self._start: float | None = None

    def initialise(self) -> None:
        self._start = None

    def update(self) -> Status:
        if self._start is None:
            try:
                reply = self.ctx.call(GRIPPER_SERVICE, ServoCommand(self.pin, self.duty))
            except NavstackError as exc:
                return self.failed(f"gripper service: {exc}")
            if reply != "OK":
                return self.failed(f"gripper replied {reply!r}")
            self._start = self.ctx.now
        status = self.mctx.gripper_status
        if status.startswith("holding"):
            self.ctx.log(f"{self.name}: {status}")
            return Status.SUCCESS
        if self.ctx.now - self._start > self.timeout:
            return self.failed(f"gripper closed but holds nothing ({status})")
        self.ctx.feedback(f"{self.name}: closing the gripper")
        return Status.RUNNING
