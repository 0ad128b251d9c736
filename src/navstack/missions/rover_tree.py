"""The rover's behaviour tree and its mission node (issue 20, part 5).

The tree has the rover's structure (``FIELD-ROBOTS.md``)::

    Parallel "Rover" (success on one)
    |-- Selector "Autonomous Navigation"
    |   |-- GoGps                       drive to the task's GPS / odom goal
    |   |-- AllPostsVisited             every post of the task visited -> task done
    |   |-- Sequence gate_control       OneGateDetected, RotateGate, GateDetected,
    |   |                               Retry x3 (PassGate: back, middle, front)
    |   |-- Sequence post_control       PostDetected, RotatePost (R20/L40), GoPost
    |   `-- Sequence get_goal           PointsAvailable, Timeout 12 s (GetPath), FacePoint,
    |                                   GoToPoint
    `-- OscillationGuard                the commands to the base oscillate -> FAILURE

on the mission layer's behaviours and a :class:`~navstack.missions.rover_context.
RoverContext` whose blackboard holds the task and the search state.

:class:`RoverMission` is the node that ticks it (10 Hz on the stack's clock) and offers
the rover's mission services (in-process bus services):

* ``/rover/go_to`` (:class:`GoToRequest`: odom x, y and the post ids to find there);
* ``/rover/go_to_gps`` (:class:`GoToGpsRequest`: latitude / longitude, decimal or
  ``"deg,min,sec"``, and the post ids) -- no ids: a GNSS leg, one: a post, two: a gate;
* ``/rover/stop_mission`` -- stops the tree (goals cancelled) and clears all state:
  blackboard and detected posts;
* ``/rover/estop`` -- an e-stop pulse: a zero twist on the twist_mux's ``/stop`` input
  (priority 255) for ``estop_pulse`` seconds, and the task paused;
* ``/rover/resume`` -- resume a paused task.

**Joystick takeover** (part 7): when the twist_mux's winning input (``/twist_mux/active``)
is anything but the navigation input, a lock is engaged, or the joystick node reports
``teleop`` on the mode topic (``/rover/mode``), the task pauses: the tree is
stopped, which cancels its navigation goal (the joystick node also cancels goals when
switched to teleop).  A mission command (``/rover/resume``, or a new goal) resumes it
from its blackboard: the GPS leg is restarted from the current fixes, the spiral points
left and the posts seen are kept.

The node publishes ``/mission/state`` (latched JSON: name, status, task, running
behaviour, feedback, posts seen and visited, reason) like the mission runner.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

from py_trees.behaviour import Behaviour
from py_trees.common import ParallelPolicy, Status
from py_trees.composites import Parallel, Selector, Sequence
from py_trees.decorators import Retry
from pydantic import Field

from navstack.control.oscillation import OscillationDetector, OscillationParams
from navstack.core.msgs import Bool, String, Twist
from navstack.core.params import Params
from navstack.geo.conversions import GeoError
from navstack.geo.gps_goal import parse_coordinate
from navstack.missions.gps_legs import (
    GpsChaseLeg,
    GpsChaseLegParams,
    GpsGoalFixLeg,
    GpsGoalFixParams,
    HeadingCalibration,
)
from navstack.missions.mission import MISSION_STATE_TOPIC
from navstack.missions.rover_behaviours import (
    AllPostsVisited,
    FacePoint,
    GateDetected,
    GetPath,
    GoGps,
    GoPost,
    GoToPoint,
    OneGateDetected,
    PassGate,
    PointsAvailable,
    PostDetected,
    RotateGate,
    RotatePost,
    RoverTreeParams,
    SimTimeout,
    mode_publisher,
)
from navstack.missions.rover_context import RoverContext, RoverTask, TaskStatus
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["GoToGpsRequest", "GoToRequest", "OscillationGuard", "RoverMission",
           "RoverMissionParams", "build_rover_tree"]


@dataclass(frozen=True)
class GoToRequest:
    """``/rover/go_to``: an odom goal and the marker ids to find there."""

    x: float
    y: float
    post_ids: tuple[int, ...] = ()
    name: str = ""


@dataclass(frozen=True)
class GoToGpsRequest:
    """``/rover/go_to_gps``: a GPS goal (decimal or D,M,S) and the marker ids."""

    latitude: float | str
    longitude: float | str
    post_ids: tuple[int, ...] = ()
    name: str = ""


class OscillationGuard(Behaviour):
    """The rover's parallel ``OscillationDetected``: feeds every command to the base
    (``/cmd_vel``) and the rover's odom position to an :class:`OscillationDetector`;
    RUNNING while none, FAILURE (which stops the navigation branch and its goal) with the
    detector's reason when the commands oscillate.  The spiral point being driven to is
    dropped; after ``max_reports`` the task fails."""

    def __init__(self, ctx: RoverContext, params: OscillationParams | None = None,
                 max_reports: int = 3, topic: str = "/cmd_vel",
                 name: str = "OscillationDetected") -> None:
        super().__init__(name)
        self.ctx = ctx
        self.detector = OscillationDetector(params)
        self.max_reports = max_reports
        self.reports: list[str] = []
        self._pending: str | None = None
        self._sub = ctx.runtime.bus.subscribe(topic, Twist, self._on_cmd, QoS(depth=10))

    def _on_cmd(self, msg: Twist) -> None:
        if self.ctx.bb.status is not TaskStatus.RUNNING:
            return
        pose = self.ctx.robot_pose()
        if pose is None:
            return
        report = self.detector.update(self.ctx.now, msg.linear.x, msg.angular.z, pose.x, pose.y)
        if report is not None and self._pending is None:
            self._pending = report.reason

    def reset(self) -> None:
        self.detector.reset()
        self._pending = None
        self.reports = []

    def update(self) -> Status:
        if self._pending is None:
            return Status.RUNNING
        reason, self._pending = self._pending, None
        self.detector.reset()
        self.reports.append(reason)
        bb = self.ctx.bb
        self.ctx.log(f"{self.name}: {reason}")
        if bb.point is not None and bb.point in bb.points:
            bb.points.remove(bb.point)
        if len(self.reports) >= self.max_reports and bb.status is TaskStatus.RUNNING:
            bb.finish(TaskStatus.FAILED, f"oscillating {len(self.reports)} times; last: "
                                         f"{reason}", self.ctx.now)
        return Status.FAILURE


def build_rover_tree(ctx: RoverContext, params: RoverTreeParams, calibration: HeadingCalibration,
                     leg: GpsGoalFixLeg | GpsChaseLeg, guard: OscillationGuard) -> Parallel:
    """The rover's tree (module docstring)."""
    mode = mode_publisher(ctx)
    gate_control = Sequence("gate_control", memory=True, children=[
        OneGateDetected(ctx, params, "one_gate_detected"),
        RotateGate(ctx, params, "rotate_gate"),
        GateDetected(ctx, params, "gate_detected"),
        Retry("go_gate", PassGate(ctx, params, "pass_gate"), params.gate_tries)])
    post_control = Sequence("post_control", memory=True, children=[
        PostDetected(ctx, params, "post_detected"),
        RotatePost(ctx, params, "rotate_post"),
        GoPost(ctx, params, mode, "go_post")])
    get_goal = Sequence("get_goal", memory=True, children=[
        PointsAvailable(ctx, params, "points_available"),
        SimTimeout(ctx, GetPath(ctx, params, "get_path"), params.path_timeout, "path_timeout"),
        FacePoint(ctx, params, "face_point"),
        GoToPoint(ctx, "go_to_point")])
    selector = Selector("Autonomous Navigation", memory=False, children=[
        GoGps(ctx, params, calibration, leg, "go_gps"),
        AllPostsVisited(ctx, params, "all_posts_visited"),
        gate_control, post_control, get_goal])
    return Parallel("Rover", ParallelPolicy.SuccessOnOne(), children=[selector, guard])


class RoverMissionParams(Params):
    """The rover mission node: the tree's figures, the GNSS antenna on ``base_link``
    (x, y) [m], the twist_mux's navigation input name, the e-stop pulse [s]."""

    tree: RoverTreeParams = Field(default_factory=RoverTreeParams)
    oscillation: OscillationParams = Field(default_factory=OscillationParams)
    antenna: tuple[float, float] = (0.0, 0.0)
    leg_timeout: float = Field(default=300.0, gt=0.0)
    navigation_input: str = "navigation"
    estop_topic: str = "/stop"
    estop_pulse: float = Field(default=1.0, gt=0.0)
    tick_period: float = Field(default=0.1, gt=0.0)
    post_radius: float = Field(default=0.15, gt=0.0)
    camera_range: float = Field(default=15.0, gt=0.0)


class RoverMission(Node):
    """Ticks the rover's tree and serves its mission commands (module docstring)."""

    def __init__(self, runtime: Runtime, params: RoverMissionParams | None = None,
                 name: str = "rover_mission") -> None:
        super().__init__(name, runtime)
        self.params = p = params or RoverMissionParams()
        self.ctx = RoverContext(runtime, post_radius=p.post_radius,
                                camera_range=p.camera_range)
        self.calibration = HeadingCalibration(runtime)
        self.leg: GpsGoalFixLeg | GpsChaseLeg
        if p.tree.variant == "pi":
            self.leg = GpsChaseLeg(runtime, math.nan, GpsChaseLegParams(
                antenna=p.antenna, timeout=p.leg_timeout))
        else:
            self.leg = GpsGoalFixLeg(runtime, math.nan, GpsGoalFixParams(
                antenna=p.antenna, timeout=p.leg_timeout))
        self.guard = OscillationGuard(self.ctx, p.oscillation)
        self.root = build_rover_tree(self.ctx, p.tree, self.calibration, self.leg, self.guard)
        self.root.setup_with_descendants()
        self.active_input = ""
        self.locked = False
        self.teleop = False
        self.pauses = 0
        self.tasks = 0
        self._estop_until = -math.inf

    @property
    def bb(self) -> Any:
        return self.ctx.bb

    def on_configure(self) -> None:
        p = self.params
        self.pub_state = self.create_latched_publisher(MISSION_STATE_TOPIC, String)
        self.pub_stop = self.create_publisher(p.estop_topic, Twist, QoS(depth=1))
        self.create_subscription("/twist_mux/active", String, self._on_active, LATCHED)
        self.create_subscription("/twist_mux/locked", Bool, self._on_locked, LATCHED)
        self.create_subscription(self.ctx.mode_topic, String, self._on_mode, LATCHED)
        bus = self.bus
        bus.advertise_service("/rover/go_to", self._srv_go_to)
        bus.advertise_service("/rover/go_to_gps", self._srv_go_to_gps)
        bus.advertise_service("/rover/stop_mission", self._srv_stop)
        bus.advertise_service("/rover/estop", self._srv_estop)
        bus.advertise_service("/rover/resume", self._srv_resume)
        self.create_timer(p.tick_period, self._tick)
        self.create_timer(0.1, self._estop_tick)

    def on_activate(self) -> None:
        self._publish()

    def start(self) -> RoverMission:
        self.configure()
        self.activate()
        return self

    # --- commands --------------------------------------------------------------------
    def _begin(self, task: RoverTask) -> dict[str, Any]:
        self._halt()
        self.tasks += 1
        self.bb.begin(task, self.now)
        self.guard.reset()
        self.ctx.log(f"task {task.name} ({task.kind}) started")
        self._publish()
        return {"accepted": True, "task": task.name, "kind": task.kind}

    def _name(self, name: str) -> str:
        return name or f"leg_{self.tasks + 1}"

    def _srv_go_to(self, req: GoToRequest) -> dict[str, Any]:
        if not (math.isfinite(req.x) and math.isfinite(req.y)):
            return {"accepted": False, "reason": f"go_to: x, y must be finite, got "
                                                 f"({req.x}, {req.y})"}
        return self._begin(RoverTask(self._name(req.name), tuple(req.post_ids),
                                     xy=(float(req.x), float(req.y))))

    def _srv_go_to_gps(self, req: GoToGpsRequest) -> dict[str, Any]:
        try:
            parse_coordinate(req.latitude, "go_to_gps.latitude", "latitude")
            parse_coordinate(req.longitude, "go_to_gps.longitude", "longitude")
        except GeoError as exc:
            return {"accepted": False, "reason": str(exc)}
        return self._begin(RoverTask(self._name(req.name), tuple(req.post_ids),
                                     req.latitude, req.longitude))

    def _srv_stop(self, _req: Any = None) -> dict[str, Any]:
        self._halt(at_once=True)
        if self.bb.status in (TaskStatus.RUNNING, TaskStatus.PAUSED):
            self.ctx.log("mission stopped: state cleared")
        self.bb.reset()
        self.ctx.tracker.clear()
        self.guard.reset()
        self._publish()
        return {"stopped": True}

    def _srv_estop(self, _req: Any = None) -> dict[str, Any]:
        self._estop_until = self.now + self.params.estop_pulse
        self.pub_stop.publish(Twist())
        self._pause("e-stop pulse")
        return {"estop_until": self._estop_until}

    def _srv_resume(self, _req: Any = None) -> dict[str, Any]:
        if self.bb.status is not TaskStatus.PAUSED:
            return {"resumed": False, "reason": f"no paused task (status "
                                                f"{self.bb.status.value})"}
        if self._overridden():
            who = ("the joystick node is in teleop" if self.teleop else
                   "the twist_mux is locked" if self.locked else
                   f"'{self.active_input}' still has the base")
            return {"resumed": False, "reason": who}
        self.bb.status = TaskStatus.RUNNING
        self.guard.reset()
        self.ctx.log("task resumed")
        self._publish()
        return {"resumed": True}

    # --- takeover ----------------------------------------------------------------------
    def _overridden(self) -> bool:
        return (self.locked or self.teleop
                or self.active_input not in ("", self.params.navigation_input))

    def _on_active(self, msg: String) -> None:
        self.active_input = msg.data
        if self._overridden():
            self._pause(f"'{msg.data}' took over the base")

    def _on_mode(self, msg: String) -> None:
        self.teleop = msg.data == "teleop"
        if self.teleop:  # the joystick node switched to teleop (goals cancelled)
            self._pause("the joystick node switched to teleop")

    def _on_locked(self, msg: Bool) -> None:
        self.locked = bool(msg.data)
        if self.locked:
            self._pause("the twist_mux is locked")

    def _pause(self, why: str) -> None:
        if self.bb.status is TaskStatus.RUNNING:
            self._halt(at_once=True)
            self.bb.status = TaskStatus.PAUSED
            self.pauses += 1
            self.ctx.log(f"task paused: {why}")
            self._publish()

    def _halt(self, at_once: bool = False) -> None:
        """Stop the tree: every running goal is cancelled (the behaviours' terminate);
        ``at_once`` (stop mission, a pause) also stops the velocity smoother's ramp."""
        self.root.stop(Status.INVALID)
        self.ctx.stop_robot(at_once=at_once)

    def _estop_tick(self) -> None:
        if self.now < self._estop_until:
            self.pub_stop.publish(Twist())

    # --- ticking -----------------------------------------------------------------------
    def _tick(self) -> None:
        bb = self.bb
        if bb.status is not TaskStatus.RUNNING:
            return
        self.root.tick_once()
        if bb.status is not TaskStatus.RUNNING:
            self._halt()
            self.ctx.log(f"task {bb.task.name if bb.task else ''} ended {bb.status.value}")
        self._publish()

    def mission_state(self) -> dict[str, Any]:
        bb, ctx = self.bb, self.ctx
        tip = self.root.tip()
        posts = {str(i): [round(v, 2) for v in est.xy()] + [est.count]
                 for i, est in ctx.tracker.posts.items() if est.count}
        return {"name": "rover", "status": bb.status.value,
                "task": bb.task.name if bb.task else "",
                "kind": bb.task.kind if bb.task else "",
                "behaviour": tip.name if tip is not None and bb.status is TaskStatus.RUNNING
                else "",
                "feedback": ctx.status_text, "posts": posts,
                "visited": sorted(bb.visited), "points_left": len(bb.points),
                "gate_tries": bb.gate_tries, "reason": bb.reason,
                "events": [[round(t, 2), text] for t, text in ctx.events[-5:]]}

    def _publish(self) -> None:
        self.pub_state.publish(String(json.dumps(self.mission_state(), separators=(",", ":"))))

    def close(self) -> None:
        self._halt()
        for service in ("/rover/go_to", "/rover/go_to_gps", "/rover/stop_mission",
                        "/rover/estop", "/rover/resume"):
            self.bus.remove_service(service)
        self.ctx.close()
