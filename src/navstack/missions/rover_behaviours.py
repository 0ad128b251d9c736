"""The leaves of the rover's behaviour tree (:mod:`navstack.missions.rover_tree`).

Each is a mission-layer behaviour on a :class:`~navstack.missions.rover_context.
RoverContext` (odom frame, posts by marker id, the blackboard ``ctx.bb``) and talks to the
stack through the bus only.  Conditions (``AllPostsVisited``, ``OneGateDetected``,
``GateDetected``, ``PostDetected``, ``PointsAvailable``) answer at once; actions send
navigation goals and cancel them when the tree stops them (a higher branch won, the
joystick took over, *stop mission*).  Figures and their reasons: ``docs/rover.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from py_trees.common import Status
from py_trees.decorators import Decorator
from pydantic import Field

from navstack.core.msgs import Pose2D, String
from navstack.core.params import Params
from navstack.missions.behaviours import MissionBehaviour, NavigateToPose, Spin
from navstack.missions.gps_legs import (
    GpsChaseLeg,
    GpsGoalFixLeg,
    HeadingCalibration,
    LegStatus,
)
from navstack.missions.rover_context import RoverContext, TaskStatus
from navstack.missions.search_pattern import circle_points, gate_points, spiral_points
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus

__all__ = ["AllPostsVisited", "FacePoint", "GateDetected", "GetPath", "GoGps", "GoPost",
           "GoToPoint", "OneGateDetected", "PassGate", "PointsAvailable", "PostDetected",
           "RotateGate", "RotatePost", "RoverTreeParams", "SimTimeout", "segment_crossing"]


class RoverTreeParams(Params):
    """The rover tree's figures (``docs/rover.md``): the spiral (``create_points(0, 25,
    pi/4)``), ``reach_radius`` [m] within which a spiral point counts as visited (the
    points of the first turn are 0.4-1.6 m apart, less than the 1.2 m body), the path
    request's ``path_timeout`` (12 s), the post approach (``post_standoff`` from the post
    centre, done within ``post_done_radius``), the gate (``gate_spacing`` 4 m between
    back, middle and front, ``gate_tries`` 3, circle points ``circle_radius`` around a
    first-seen post), the scan (right 20, left 40 degrees), ``min_sightings`` before a
    post counts as detected."""

    spiral_start: int = 0
    spiral_stop: int = 25
    spiral_step: float = math.pi / 4
    reach_radius: float = Field(default=1.5, ge=0.0)
    path_timeout: float = Field(default=12.0, gt=0.0)
    post_standoff: float = Field(default=1.2, gt=0.0)
    post_done_radius: float = Field(default=1.6, gt=0.0)
    post_resend: float = Field(default=0.5, gt=0.0)
    gate_spacing: float = Field(default=4.0, gt=0.0)
    gate_tries: int = Field(default=3, ge=1)
    circle_radius: float = Field(default=6.0, gt=0.0)
    scan_right_deg: float = 20.0
    scan_left_deg: float = 40.0
    min_sightings: int = Field(default=3, ge=1)
    face_angle_deg: float = Field(default=60.0, ge=0.0, le=180.0)
    variant: str = Field(default="nav2", pattern="^(nav2|pi)$")
    """GPS chase: the gps_goal_fix loop (``nav2``) or the PI chase (``pi``)."""


def segment_crossing(p0: tuple[float, float], p1: tuple[float, float],
                     a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Does the move ``p0 -> p1`` cross the segment ``a - b``?"""

    def side(p: tuple[float, float], q: tuple[float, float], r: tuple[float, float]) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    return (side(a, b, p0) * side(a, b, p1) < 0.0) and (side(p0, p1, a) * side(p0, p1, b) < 0.0)


class _RoverBehaviour(MissionBehaviour):
    def __init__(self, ctx: RoverContext, params: RoverTreeParams, name: str) -> None:
        super().__init__(ctx, name)
        self.rctx = ctx
        self.params = params

    def _finish(self, status: TaskStatus, reason: str) -> Status:
        bb = self.rctx.bb
        if bb.status in (TaskStatus.RUNNING, TaskStatus.PAUSED):
            bb.finish(status, reason, self.ctx.now)
            self.ctx.log(f"task {bb.task.name if bb.task else ''} {status.value}: {reason}")
        return Status.SUCCESS if status is TaskStatus.SUCCEEDED else Status.FAILURE

    def _unvisited_seen(self) -> list[int]:
        bb, tr = self.rctx.bb, self.rctx.tracker
        return [i for i in bb.targets if i not in bb.visited
                and tr.seen(i, self.params.min_sightings)]


class SimTimeout(Decorator):
    """py_trees' Timeout on the stack's clock (py_trees times with ``time.monotonic``,
    wall time, which is not the simulated time): FAILURE if the child still runs after
    ``duration`` seconds."""

    def __init__(self, ctx: RoverContext, child: MissionBehaviour, duration: float,
                 name: str = "Timeout") -> None:
        super().__init__(name, child)
        self.ctx = ctx
        self.duration = duration
        self.finish_time = math.inf

    def initialise(self) -> None:
        self.finish_time = self.ctx.now + self.duration

    def update(self) -> Status:
        if self.decorated.status is Status.RUNNING and self.ctx.now > self.finish_time:
            self.decorated.stop(Status.INVALID)
            self.ctx.log(f"{self.decorated.name}: no answer within {self.duration:g} s")
            return Status.FAILURE
        return self.decorated.status


# --- go to the GPS / odom goal -----------------------------------------------------------
class GoGps(_RoverBehaviour):
    """Drive to the task's goal: the heading calibration first (once), then the GPS leg
    (gps_goal_fix loop or PI chase) to a lat/lon goal, or a NavigateToPose to an odom
    goal.  On arrival the search starts there: the spiral points relative to the pose
    (``create_points``), and a GNSS-only task is done.  FAILURE (no record) when there is
    nothing to drive to, so the selector moves on."""

    def __init__(self, ctx: RoverContext, params: RoverTreeParams,
                 calibration: HeadingCalibration, leg: GpsGoalFixLeg | GpsChaseLeg,
                 name: str = "GoGps") -> None:
        super().__init__(ctx, params, name)
        self.calibration = calibration
        self.leg = leg
        self._xy_nav: NavigateToPose | None = None
        self._leg_started = False

    def initialise(self) -> None:
        self._leg_started = False
        self._xy_nav = None

    def update(self) -> Status:
        bb = self.rctx.bb
        task = bb.task
        if task is None or bb.goal_reached or bb.status is not TaskStatus.RUNNING:
            return Status.FAILURE
        if task.xy is not None:
            return self._go_xy(task.xy)
        cal = self.calibration
        if cal.origin is None:
            if cal.status is not LegStatus.RUNNING:
                if cal.status is LegStatus.FAILED:
                    return self._finish(TaskStatus.FAILED, f"heading calibration: {cal.reason}")
                cal.start()
                self.ctx.log("heading calibration: 2.5 s straight at 1.5 m/s")
            self.ctx.feedback(f"{self.name}: heading calibration")
            return Status.RUNNING
        leg = self.leg
        if not self._leg_started:
            assert task.latitude is not None and task.longitude is not None
            leg.axis_course_deg = cal.course_deg
            leg.start(task.latitude, task.longitude)
            self._leg_started = True
            self.ctx.log(f"{self.name}: {leg.name} to ({task.latitude}, {task.longitude})")
        if leg.status is LegStatus.RUNNING:
            self.ctx.feedback(f"{self.name}: {leg.distance:.1f} m to the GPS goal",
                              distance_remaining=leg.distance
                              if math.isfinite(leg.distance) else -1.0)
            return Status.RUNNING
        if leg.status is LegStatus.SUCCEEDED:
            bb.goal_odom = leg.goal_odom
            return self._arrived(leg.reason)
        return self._finish(TaskStatus.FAILED, f"GPS leg {leg.status.value}: {leg.reason}")

    def _go_xy(self, xy: tuple[float, float]) -> Status:
        if self._xy_nav is None:
            robot = self.ctx.robot_pose()
            yaw = 0.0 if robot is None else math.atan2(xy[1] - robot.y, xy[0] - robot.x)
            self._xy_nav = NavigateToPose(self.ctx, Pose2D(xy[0], xy[1], yaw), name=self.name)
        self._xy_nav.tick_once()
        status = self._xy_nav.status
        if status is Status.RUNNING:
            return Status.RUNNING
        self._xy_nav = None
        if status is Status.SUCCESS:
            self.rctx.bb.goal_odom = xy
            return self._arrived("reached the goal")
        reason = self.ctx.failures[-1].reason if self.ctx.failures else "navigation failed"
        return self._finish(TaskStatus.FAILED, f"goal ({xy[0]:.1f}, {xy[1]:.1f}): {reason}")

    def _arrived(self, how: str) -> Status:
        bb = self.rctx.bb
        robot = self.ctx.robot_pose()
        bb.goal_reached, bb.goal_reached_at = True, self.ctx.now
        self.ctx.log(f"{self.name}: {how}")
        if not bb.targets:
            return self._finish(TaskStatus.SUCCEEDED, f"GNSS goal: {how}")
        if robot is not None:
            p = self.params
            pts = spiral_points(p.spiral_start, p.spiral_stop, p.spiral_step,
                                (robot.x, robot.y), robot.theta)
            bb.search_origin = (robot.x, robot.y)
            bb.points = [(float(x), float(y)) for x, y in pts]
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID:
            if self.leg.status is LegStatus.RUNNING:
                self.leg.cancel("stopped by the tree")
            if self._xy_nav is not None:
                self._xy_nav.stop(Status.INVALID)
            self._xy_nav = None
            self._leg_started = False


class AllPostsVisited(_RoverBehaviour):
    """SUCCESS (the task succeeded) once every marker id of the task has been visited."""

    def update(self) -> Status:
        bb = self.rctx.bb
        if bb.targets and all(i in bb.visited for i in bb.targets):
            what = "gate passed" if len(bb.targets) == 2 else "post reached"
            return self._finish(TaskStatus.SUCCEEDED,
                                f"{what} ({', '.join(map(str, bb.targets))})")
        return Status.FAILURE


# --- gate control ----------------------------------------------------------------------
class OneGateDetected(_RoverBehaviour):
    """A gate task with at least one of its posts detected."""

    def update(self) -> Status:
        bb = self.rctx.bb
        return (Status.SUCCESS if len(bb.targets) == 2 and self._unvisited_seen()
                else Status.FAILURE)


class GateDetected(_RoverBehaviour):
    """Both posts of the gate detected."""

    def update(self) -> Status:
        bb = self.rctx.bb
        return (Status.SUCCESS if len(bb.targets) == 2 and len(self._unvisited_seen()) == 2
                else Status.FAILURE)


class _NavSteps(_RoverBehaviour):
    """Runs NavigateToPose goals one after another (ticked by the subclass)."""

    def __init__(self, ctx: RoverContext, params: RoverTreeParams, name: str) -> None:
        super().__init__(ctx, params, name)
        self.nav: NavigateToPose | None = None

    def _drive(self, pose: Pose2D) -> Status:
        if self.nav is None:
            self.nav = NavigateToPose(self.ctx, pose, name=self.name)
        self.nav.tick_once()
        status = self.nav.status
        if status is not Status.RUNNING:
            self.nav = None
        return status

    def _stop_nav(self) -> None:
        if self.nav is not None:
            self.nav.stop(Status.INVALID)
        self.nav = None

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID:
            self._stop_nav()


class RotateGate(_NavSteps):
    """One gate post seen: drive round it on four circle points (nearest first), each
    facing the post, until the other post is seen (SUCCESS); FAILURE after the four
    points (once per task: the spiral goes on, and a later sighting still counts)."""

    def initialise(self) -> None:
        self._stop_nav()
        self.points: list[tuple[float, float]] | None = None
        self.anchor: tuple[float, float] | None = None

    def update(self) -> Status:
        bb, tr = self.rctx.bb, self.rctx.tracker
        seen = self._unvisited_seen()
        if len(seen) == 2:
            self._stop_nav()
            return Status.SUCCESS
        if not seen:
            return Status.FAILURE
        if self.points is None:
            if bb.gate_circled:
                return Status.FAILURE
            robot = self.ctx.robot_pose()
            anchor = tr.xy(seen[0])
            if robot is None or anchor is None:
                return Status.FAILURE
            self.anchor = anchor
            pts = circle_points(anchor, self.params.circle_radius, (robot.x, robot.y))
            self.points = [(float(x), float(y)) for x, y in pts]
            self.ctx.log(f"{self.name}: gate post {seen[0]} seen, circling it for the other")
        if not self.points:
            bb.gate_circled = True
            self.ctx.log(f"{self.name}: circled the gate post without seeing the other")
            return Status.FAILURE
        assert self.anchor is not None
        x, y = self.points[0]
        yaw = math.atan2(self.anchor[1] - y, self.anchor[0] - x)
        status = self._drive(Pose2D(x, y, yaw))
        if status is not Status.RUNNING:
            self.points.pop(0)
        return Status.RUNNING


class PassGate(_NavSteps):
    """Through the gate: back, middle and front points ``gate_spacing`` apart along the
    gate normal (from the two posts' estimates, the back one on the rover's side), each
    facing through the gate.  SUCCESS when the rover's path crossed the segment between
    the posts (both posts visited); FAILURE otherwise (the Retry decorator tries again, up
    to ``gate_tries``; after the last try the task fails)."""

    def initialise(self) -> None:
        self._stop_nav()
        self.points: list[Pose2D] = []
        self.posts: tuple[tuple[float, float], tuple[float, float]] | None = None
        self.crossed = False
        self.last: tuple[float, float] | None = None

    def update(self) -> Status:
        bb, tr = self.rctx.bb, self.rctx.tracker
        robot = self.ctx.robot_pose()
        if self.posts is None:
            a, b = (tr.xy(i) for i in bb.targets)
            if robot is None or a is None or b is None:
                return Status.FAILURE
            if bb.gate_tries >= self.params.gate_tries:
                return self._finish(TaskStatus.FAILED, f"gate not passed in {bb.gate_tries} "
                                                       "tries")
            bb.gate_tries += 1
            self.posts = (a, b)
            pts, heading = gate_points(a, b, (robot.x, robot.y), self.params.gate_spacing)
            self.points = [Pose2D(float(x), float(y), heading) for x, y in pts]
            self.ctx.log(f"{self.name}: try {bb.gate_tries}, gate between "
                         f"({a[0]:.1f}, {a[1]:.1f}) and ({b[0]:.1f}, {b[1]:.1f})")
        if robot is not None:
            here = (robot.x, robot.y)
            if self.last is not None and segment_crossing(self.last, here, *self.posts):
                self.crossed = True
            self.last = here
        if self.points:
            status = self._drive(self.points[0])
            if status is Status.RUNNING:
                return Status.RUNNING
            if status is Status.FAILURE:
                return Status.FAILURE
            self.points.pop(0)
            return Status.RUNNING
        if not self.crossed:
            self.ctx.log(f"{self.name}: ended on the far side without crossing the gate")
            return Status.FAILURE
        bb.visited.update(bb.targets)
        bb.gate_crossed_at = self.ctx.now
        return Status.SUCCESS


# --- post control ----------------------------------------------------------------------
class PostDetected(_RoverBehaviour):
    """A post task whose post has been detected (and not visited yet)."""

    def update(self) -> Status:
        bb = self.rctx.bb
        if len(bb.targets) != 1 or not self._unvisited_seen():
            return Status.FAILURE
        if bb.first_seen_at is None:
            bb.first_seen_at = self.ctx.now
        return Status.SUCCESS


class RotatePost(_RoverBehaviour):
    """Bring the detected post back into view before the approach: SUCCESS at once if it
    was seen in the last 0.5 s, else the rover's scan -- turn right ``scan_right_deg``,
    then left ``scan_left_deg`` -- stopping as soon as it is seen.  Unseen after the scan,
    the approach still goes to the stored position (SUCCESS, logged)."""

    def __init__(self, ctx: RoverContext, params: RoverTreeParams,
                 name: str = "RotatePost") -> None:
        super().__init__(ctx, params, name)
        self.turns = [-math.radians(params.scan_right_deg), math.radians(params.scan_left_deg)]
        self.spin: Spin | None = None

    def initialise(self) -> None:
        self.step = 0
        self.spin = None

    def update(self) -> Status:
        bb, tr = self.rctx.bb, self.rctx.tracker
        target = bb.targets[0]
        if tr.visible(target, self.ctx.now):
            if self.spin is not None:
                self.spin.stop(Status.INVALID)
            return Status.SUCCESS
        if self.spin is None:
            if self.step >= len(self.turns):
                self.ctx.log(f"{self.name}: post {target} not in view after the scan; "
                             "approaching its stored position")
                return Status.SUCCESS
            self.spin = Spin(self.ctx, self.turns[self.step], name=self.name)
            self.step += 1
        self.spin.tick_once()
        if self.spin.status is not Status.RUNNING:
            self.spin = None
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID and self.spin is not None:
            self.spin.stop(Status.INVALID)
        self.spin = None


class GoPost(_NavSteps):
    """Drive up to the post: a goal ``post_standoff`` short of its estimate on the line
    from the rover, facing it, re-sent when the estimate moves by ``post_resend``; the
    post is visited once the rover is within ``post_done_radius`` of it (mode string
    ``success``)."""

    def __init__(self, ctx: RoverContext, params: RoverTreeParams, mode: Callable[[str], None],
                 name: str = "GoPost") -> None:
        super().__init__(ctx, params, name)
        self.mode = mode

    def initialise(self) -> None:
        self._stop_nav()
        self.aim: tuple[float, float] | None = None
        self.failures = 0

    def update(self) -> Status:
        bb, tr = self.rctx.bb, self.rctx.tracker
        target = bb.targets[0]
        post = tr.xy(target)
        robot = self.ctx.robot_pose()
        if post is None or robot is None:
            return Status.FAILURE
        dist = math.hypot(post[0] - robot.x, post[1] - robot.y)
        if dist <= self.params.post_done_radius:
            self._stop_nav()
            bb.visited.add(target)
            self.mode("success")
            self.ctx.log(f"{self.name}: at post {target} ({dist:.2f} m from its estimate)")
            return Status.SUCCESS
        self.mode("auto")
        if self.aim is not None and math.hypot(post[0] - self.aim[0],
                                               post[1] - self.aim[1]) > self.params.post_resend:
            self._stop_nav()
        if self.nav is None:
            self.aim = post
        yaw = math.atan2(post[1] - robot.y, post[0] - robot.x)
        k = self.params.post_standoff / max(dist, 1e-6)
        goal = Pose2D(post[0] - k * (post[0] - robot.x), post[1] - k * (post[1] - robot.y), yaw)
        status = self._drive(goal)
        self.ctx.feedback(f"{self.name}: {dist:.1f} m to post {target}",
                          distance_remaining=dist)
        if status is Status.FAILURE:
            self.failures += 1
            if self.failures >= 3:
                return Status.FAILURE
        return Status.RUNNING


# --- get goal: the spiral ----------------------------------------------------------------
class PointsAvailable(_RoverBehaviour):
    """Spiral points left: drop those within ``reach_radius`` of the rover and pick the
    nearest (nearest-first order) as ``bb.point``; none left fails the
    task (the post or gate was not found)."""

    def update(self) -> Status:
        bb = self.rctx.bb
        robot = self.ctx.robot_pose()
        if robot is None or not bb.goal_reached or not bb.targets:
            return Status.FAILURE
        r = self.params.reach_radius
        bb.points = [p for p in bb.points if math.hypot(p[0] - robot.x, p[1] - robot.y) > r]
        if not bb.points:
            missing = [i for i in bb.targets if i not in bb.visited]
            return self._finish(TaskStatus.FAILED, f"spiral search ended without finding "
                                                   f"post(s) {missing}")
        nearest = min(bb.points, key=lambda p: math.hypot(p[0] - robot.x, p[1] - robot.y))
        bb.point = nearest
        return Status.SUCCESS


def _point_pose(ctx: RoverContext) -> Pose2D | None:
    pt = ctx.bb.point
    robot = ctx.robot_pose()
    if pt is None or robot is None:
        return None
    return Pose2D(pt[0], pt[1], math.atan2(pt[1] - robot.y, pt[0] - robot.x))


def _drop_point(ctx: RoverContext) -> None:
    pt = ctx.bb.point
    if pt in ctx.bb.points:
        ctx.bb.points.remove(pt)


class GetPath(_RoverBehaviour):
    """The path request to the chosen spiral point (``/compute_path_to_pose``); a point
    without a path (in a rock) is dropped (FAILURE)."""

    def __init__(self, ctx: RoverContext, params: RoverTreeParams, name: str = "GetPath") -> None:
        super().__init__(ctx, params, name)
        self.client: ActionClient[m.ComputePathToPoseGoal] = ActionClient(
            ctx.runtime.bus, m.COMPUTE_PATH_TO_POSE)
        self.handle: GoalHandle[m.ComputePathToPoseGoal] | None = None

    def initialise(self) -> None:
        pose = _point_pose(self.rctx)
        self.handle = (None if pose is None else
                       self.client.send_goal(m.ComputePathToPoseGoal(self.ctx.pose_stamped(pose))))

    def update(self) -> Status:
        if self.handle is None:
            return Status.FAILURE
        if not self.handle.done:
            return Status.RUNNING
        if self.handle.status is GoalStatus.SUCCEEDED:
            return Status.SUCCESS
        _drop_point(self.rctx)
        return Status.FAILURE

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID:
            if self.handle is not None and not self.handle.done:
                self.handle.cancel()
            _drop_point(self.rctx)  # timed out (or preempted): do not ask again


class FacePoint(_RoverBehaviour):
    """Turn in place towards the chosen spiral point when it is more than ``face_angle``
    off the heading (the rover's controller "first rotates to face the goal"): DWB
    without a rotation shim turns round slowly and can stall on a goal behind the
    rover, until its progress checker's recoveries give up (~40 s at a time)."""

    def initialise(self) -> None:
        self.spin: Spin | None = None

    def update(self) -> Status:
        if self.spin is None:
            pose, robot = _point_pose(self.rctx), self.ctx.robot_pose()
            if pose is None or robot is None:
                return Status.FAILURE
            turn = math.remainder(pose.theta - robot.theta, 2.0 * math.pi)
            if abs(turn) <= math.radians(self.params.face_angle_deg):
                return Status.SUCCESS
            self.spin = Spin(self.ctx, turn, name=self.name)
        self.spin.tick_once()
        if self.spin.status is Status.RUNNING:
            return Status.RUNNING
        if self.spin.status is Status.FAILURE and self.ctx.failures:
            self.ctx.failures.pop()  # the navigation goal still turns if it must
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID and self.spin is not None:
            self.spin.stop(Status.INVALID)
        self.spin = None


class GoToPoint(NavigateToPose):
    """Navigate to the chosen spiral point, facing along the way; the point is dropped
    when the goal ends either way (a failed one is not retried)."""

    def __init__(self, ctx: RoverContext, name: str = "GoToPoint") -> None:
        super().__init__(ctx, lambda: _point_pose(ctx), name)
        self.rctx = ctx

    def update(self) -> Status:
        status = super().update()
        if status is not Status.RUNNING:
            _drop_point(self.rctx)
            if status is Status.FAILURE and self.ctx.failures:
                self.ctx.failures.pop()  # a missed spiral point is not the task's failure
        return status


def mode_publisher(ctx: RoverContext) -> Callable[[str], None]:
    """Publishes the rover's mode string (``auto`` / ``success``) on ``ctx.mode_topic``."""
    pub = ctx.runtime.bus.publisher(ctx.mode_topic, String)
    last: list[str] = [""]

    def publish(mode: str) -> None:
        if mode != last[0]:
            last[0] = mode
            pub.publish(String(mode))

    return publish

