"""Foxglove live: the running stack on a Foxglove WebSocket server (foxglove-sdk).

Open https://app.foxglove.dev (or Foxglove desktop), "Open connection", and enter
``ws://127.0.0.1:8765``.  The server speaks the SDK's protocol (subprotocol
``foxglove.sdk.v1``) and publishes the stack's topics with the SDK's built-in Foxglove
schemas (protobuf), under their ROS names:

==========================  ==========================  ==========================================
topic                       schema                      source
==========================  ==========================  ==========================================
``/map``                    ``foxglove.Grid``           map server / SLAM (latched; re-sent)
``/global_costmap/costmap`` ``foxglove.Grid``           global costmap (occupancy 0..100, -1)
``/local_costmap/costmap``  ``foxglove.Grid``           local costmap (rolling, ``odom``)
``/scan``                   ``foxglove.LaserScan``      simulator / driver
``/tf``, ``/tf_static``     ``foxglove.FrameTransforms`` TF (``map``, ``odom``, ``base_link``, ...)
``/odom``                   ``foxglove.Odometry``       wheel odometry
``/plan``                   ``foxglove.PosesInFrame``   planner server
``/local_plan``             ``foxglove.PosesInFrame``   controller's chosen trajectory (DWB)
``/footprint``              ``foxglove.SceneUpdate``    robot body, locked to ``base_link``
``/markers``                ``foxglove.SceneUpdate``    goal(s), waypoints, e-stop label
``/aruco/marker_map/...``   ``foxglove.SceneUpdate``    ArUco markers and packages on the map
``/mission/state``          JSON                        a running mission: status, behaviour,
                                                        feedback, reason (missions/)
``/explore/frontiers``      ``foxglove.SceneUpdate``    exploration frontiers: cells (blue;
                                                        blacklisted red), goals (green spheres)
==========================  ==========================  ==========================================

Settings follow ``foxglove_bridge``'s parameter names (``port`` 8765, ``address``), except
that the default address is loopback (``127.0.0.1``) rather than all interfaces: the
stream carries the whole robot state.  Messages are stamped with simulated time and the
server broadcasts that time (``Capability.Time``) so Foxglove's clock follows the
simulation.  Nothing is encoded for a channel without subscribers, and latched data
(map, costmaps, static TF, plan) is re-sent when a client subscribes and every
``republish_period`` seconds, since the WebSocket protocol has no transient-local QoS.
Bus callbacks run in the simulation thread (attached through :class:`LiveRunner`).
"""

from __future__ import annotations

import math
import time
from functools import partial
from typing import Any

import foxglove
import numpy as np
from foxglove import channels as fc
from foxglove import messages as fm
from foxglove.websocket import ServerListener
from pydantic import Field

from navstack.core.errors import NavstackError, TransformError
from navstack.core.msgs import (
    LaserScan,
    MarkerArray,
    OccupancyGrid,
    Odometry,
    Path,
    String,
    TFMessage,
)
from navstack.core.msgs.fiducial_msgs import MARKER_MAP_VIZ_TOPIC as ARUCO_TOPIC
from navstack.core.params import Params
from navstack.interfaces.foxglove_markers import marker_array_scene
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack
from navstack.missions.explore import FRONTIERS_TOPIC
from navstack.missions.mission import MISSION_STATE_TOPIC
from navstack.navigation import messages as m
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS, Subscription

SUBPROTOCOL = "foxglove.sdk.v1"
"""WebSocket subprotocol spoken by the installed foxglove-sdk server (0.30)."""
GRIDS = ("/map", "/global_costmap/costmap", "/local_costmap/costmap")
MISSION_STATE_SCHEMA = {
    "type": "object", "title": "navstack mission state",
    "properties": {"name": {"type": "string"}, "status": {"type": "string"},
                   "behaviour": {"type": "string"}, "feedback": {"type": "string"},
                   "progress": {"type": "object"}, "elapsed": {"type": "number"},
                   "reason": {"type": "string"}, "events": {"type": "array"}}}
"""JSON schema of ``/mission/state`` (the MissionRunner's JSON)."""
MAX_FRONTIER_CUBES = 3000


class FoxgloveLiveError(NavstackError):
    """The Foxglove server could not start."""


class FoxgloveLiveParams(Params):
    """``foxglove_bridge``-named settings (``port``, ``address``) plus publishing rates."""

    port: int = Field(8765, ge=0, le=65535)
    address: str = "127.0.0.1"
    republish_period: float = Field(1.0, gt=0.0)
    frame_rate: float = Field(10.0, gt=0.0, le=60.0)


def _stamp(t: float) -> fm.Timestamp:
    t = max(t, 0.0)
    sec = math.floor(t)
    return fm.Timestamp(sec, min(round((t - sec) * 1e9), 999_999_999))


def _ns(t: float) -> int:
    return max(round(t * 1e9), 0)


def _pose(x: float, y: float, z: float, yaw: float) -> fm.Pose:
    return fm.Pose(position=fm.Vector3(x=x, y=y, z=z),
                   orientation=fm.Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2),
                                             w=math.cos(yaw / 2)))


def _color(r: float, g: float, b: float, a: float = 1.0) -> fm.Color:
    return fm.Color(r=r, g=g, b=b, a=a)


def grid_message(grid: OccupancyGrid) -> fm.Grid:
    """An OccupancyGrid as a ``foxglove.Grid`` with one int8 field ``occupancy`` (0..100,
    -1 unknown); rows run along +y from the origin, as in nav_msgs/OccupancyGrid."""
    info, o = grid.info, grid.info.origin
    data = np.ascontiguousarray(grid.data, dtype=np.int8)
    return fm.Grid(
        timestamp=_stamp(grid.header.stamp), frame_id=grid.header.frame_id or "map",
        pose=fm.Pose(position=fm.Vector3(x=o.position.x, y=o.position.y, z=o.position.z),
                     orientation=fm.Quaternion(x=o.orientation.x, y=o.orientation.y,
                                               z=o.orientation.z, w=o.orientation.w)),
        column_count=info.width, cell_size=fm.Vector2(x=info.resolution, y=info.resolution),
        row_stride=info.width, cell_stride=1,
        fields=[fm.PackedElementField(name="occupancy", offset=0,
                                      type=fm.PackedElementFieldNumericType.Int8)],
        data=data.tobytes())


def tf_message(msg: TFMessage) -> fm.FrameTransforms:
    out = []
    for ts in msg.transforms:
        t, q = ts.transform.translation, ts.transform.rotation
        out.append(fm.FrameTransform(
            timestamp=_stamp(ts.header.stamp), parent_frame_id=ts.header.frame_id,
            child_frame_id=ts.child_frame_id, translation=fm.Vector3(x=t.x, y=t.y, z=t.z),
            rotation=fm.Quaternion(x=q.x, y=q.y, z=q.z, w=q.w)))
    return fm.FrameTransforms(transforms=out)


def scan_message(scan: LaserScan) -> fm.LaserScan:
    end = scan.angle_min + scan.angle_increment * max(len(scan.ranges) - 1, 0)
    return fm.LaserScan(timestamp=_stamp(scan.header.stamp), frame_id=scan.header.frame_id,
                        pose=_pose(0.0, 0.0, 0.0, 0.0), start_angle=scan.angle_min,
                        end_angle=end, ranges=np.asarray(scan.ranges, np.float64).tolist(),
                        intensities=np.asarray(scan.intensities, np.float64).tolist())


def poses_message(xyt: np.ndarray, frame_id: str, t: float) -> fm.PosesInFrame:
    return fm.PosesInFrame(timestamp=_stamp(t), frame_id=frame_id,
                           poses=[_pose(float(x), float(y), 0.0, float(th))
                                  for x, y, th in np.asarray(xyt)[:, :3]])


def frontier_scene(msg: MarkerArray, t: float) -> fm.SceneUpdate:
    """explore_lite's frontier markers as a SceneUpdate: a small cube per frontier cell
    (the marker's colour; at most ``MAX_FRONTIER_CUBES``) and a sphere per goal."""
    cubes: list[fm.CubePrimitive] = []
    spheres: list[fm.SpherePrimitive] = []
    for mk in msg.markers:
        if mk.action != mk.ADD:
            continue
        color = _color(mk.color.r, mk.color.g, mk.color.b, mk.color.a)
        if mk.type == mk.SPHERE:
            p = mk.pose.position
            spheres.append(fm.SpherePrimitive(pose=_pose(p.x, p.y, 0.1, 0.0),
                                              size=fm.Vector3(x=mk.scale.x, y=mk.scale.y,
                                                              z=mk.scale.z), color=color))
        elif mk.type == mk.POINTS:
            for p in mk.points:
                if len(cubes) >= MAX_FRONTIER_CUBES:
                    break
                cubes.append(fm.CubePrimitive(pose=_pose(p.x, p.y, 0.02, 0.0),
                                              size=fm.Vector3(x=0.05, y=0.05, z=0.04),
                                              color=color))
    frame = msg.markers[0].header.frame_id if msg.markers else "map"
    return fm.SceneUpdate(entities=[fm.SceneEntity(timestamp=_stamp(t), frame_id=frame or "map",
                                                   id="frontiers", cubes=cubes,
                                                   spheres=spheres)])


class _Listener(ServerListener):
    """Marks topics whose latched data must be re-sent (called from the server's thread);
    the other callbacks keep the protocol's no-op defaults."""

    def __init__(self) -> None:
        self.resend: set[str] = set()

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self.resend.add(channel.topic)


class FoxgloveLive:
    """Publishes a :class:`LiveRunner`'s stack to a Foxglove WebSocket server."""

    def __init__(self, runner: LiveRunner, params: FoxgloveLiveParams | None = None) -> None:
        self.runner = runner
        self.stack = runner.stack
        self.params = p = params or FoxgloveLiveParams()
        self.context = foxglove.Context()
        self._listener = _Listener()
        ctx = self.context
        self.grids = {topic: fc.GridChannel(topic, context=ctx) for topic in GRIDS}
        self.scan = fc.LaserScanChannel("/scan", context=ctx)
        self.tf = fc.FrameTransformsChannel("/tf", context=ctx)
        self.tf_static = fc.FrameTransformsChannel("/tf_static", context=ctx)
        self.odom = fc.OdometryChannel("/odom", context=ctx)
        self.plan = fc.PosesInFrameChannel("/plan", context=ctx)
        self.local_plan = fc.PosesInFrameChannel("/local_plan", context=ctx)
        self.footprint = fc.SceneUpdateChannel("/footprint", context=ctx)
        self.markers = fc.SceneUpdateChannel("/markers", context=ctx)
        self.aruco = fc.SceneUpdateChannel(ARUCO_TOPIC, context=ctx)
        self.mission = foxglove.Channel(MISSION_STATE_TOPIC, schema=MISSION_STATE_SCHEMA,
                                        context=ctx)
        self.frontiers = fc.SceneUpdateChannel(FRONTIERS_TOPIC, context=ctx)
        try:
            self.server = foxglove.start_server(
                name="navstack", host=p.address, port=p.port, context=ctx,
                capabilities=[foxglove.Capability.Time], server_listener=self._listener)
        except Exception as exc:  # the SDK raises its own RuntimeError / OSError variants
            raise FoxgloveLiveError(
                f"cannot start the Foxglove server on {p.address}:{p.port} ({exc}); choose "
                f"another port (0 picks a free one) or stop the program using it") from None
        self.port = int(self.server.port)
        self._latched: dict[str, Any] = {}
        self._subs: list[Subscription[Any]] = []
        self._last_frame = -math.inf
        self._last_republish = time.monotonic()
        self._remove_observer: Any = None
        self._attach()

    @property
    def url(self) -> str:
        return f"ws://{self.params.address}:{self.port}"

    # --- wiring (simulation thread) -------------------------------------------------------------
    def _attach(self) -> None:
        def setup(stack: NavStack) -> None:
            bus = stack.runtime.bus
            for topic in GRIDS:
                qos = LATCHED if topic == "/map" else QoS(depth=1)
                self._subs.append(bus.subscribe(topic, OccupancyGrid,
                                                partial(self._on_grid, topic), qos))
            self._subs.append(bus.subscribe("/scan", LaserScan, self._on_scan, SENSOR_DATA))
            self._subs.append(bus.subscribe("/tf", TFMessage, self._on_tf, QoS(depth=100)))
            self._subs.append(bus.subscribe("/tf_static", TFMessage, self._on_tf_static,
                                            QoS(depth=10, latched=True)))
            self._subs.append(bus.subscribe("/odom", Odometry, self._on_odom, QoS(depth=10)))
            plan_topic = getattr(stack.planner.params, "plan_topic", "/plan")
            self._subs.append(bus.subscribe(plan_topic, Path, self._on_plan, LATCHED))
            self._subs.append(bus.subscribe(ARUCO_TOPIC, MarkerArray, self._on_aruco, LATCHED))
            self._subs.append(bus.subscribe(MISSION_STATE_TOPIC, String, self._on_mission,
                                            LATCHED))
            self._subs.append(bus.subscribe(FRONTIERS_TOPIC, MarkerArray, self._on_frontiers,
                                            QoS(depth=1)))

        self.runner.call(setup)
        self._remove_observer = self.runner.add_observer(self._on_step)

    def stop(self) -> None:
        """Stop publishing and close the server (idempotent)."""
        if self._remove_observer is not None:
            self._remove_observer()
            self._remove_observer = None

            def teardown(_: NavStack) -> None:
                for sub in self._subs:
                    sub.unsubscribe()
                self._subs.clear()

            self.runner.call(teardown)
            self.server.stop()

    # --- bus callbacks ----------------------------------------------------------------------------
    def _log(self, channel: Any, msg: Any, t: float) -> None:
        channel.log(msg, log_time=_ns(t))

    def _on_grid(self, topic: str, grid: OccupancyGrid) -> None:
        self._latched[topic] = grid
        channel = self.grids[topic]
        if channel.has_sinks():
            self._log(channel, grid_message(grid), self.stack.now)

    def _on_scan(self, scan: LaserScan) -> None:
        if self.scan.has_sinks():
            self._log(self.scan, scan_message(scan), scan.header.stamp)

    def _on_tf(self, msg: TFMessage) -> None:
        if self.tf.has_sinks() and msg.transforms:
            self._log(self.tf, tf_message(msg), self.stack.now)

    def _on_tf_static(self, msg: TFMessage) -> None:
        merged = {ts.child_frame_id: ts for ts in
                  (*getattr(self._latched.get("/tf_static"), "transforms", ()), *msg.transforms)}
        self._latched["/tf_static"] = TFMessage(tuple(merged.values()))
        if self.tf_static.has_sinks():
            self._log(self.tf_static, tf_message(self._latched["/tf_static"]), self.stack.now)

    def _on_odom(self, msg: Odometry) -> None:
        if not self.odom.has_sinks():
            return
        p, tw = msg.pose.pose, msg.twist.twist
        self._log(self.odom, fm.Odometry(
            timestamp=_stamp(msg.header.stamp), frame_id=msg.header.frame_id,
            body_frame_id=msg.child_frame_id,
            pose=fm.Pose(position=fm.Vector3(x=p.position.x, y=p.position.y, z=p.position.z),
                         orientation=fm.Quaternion(x=p.orientation.x, y=p.orientation.y,
                                                   z=p.orientation.z, w=p.orientation.w)),
            linear_velocity=fm.Vector3(x=tw.linear.x, y=tw.linear.y, z=tw.linear.z),
            angular_velocity=fm.Vector3(x=tw.angular.x, y=tw.angular.y, z=tw.angular.z)),
            msg.header.stamp)

    def _on_aruco(self, msg: MarkerArray) -> None:
        self._latched[ARUCO_TOPIC] = msg
        if self.aruco.has_sinks():
            self._log(self.aruco, marker_array_scene(msg, _ns(self.stack.now)), self.stack.now)

    def _on_plan(self, path: Path) -> None:
        self._latched["/plan"] = path
        if self.plan.has_sinks():
            self._send_plan(path)

    def _on_mission(self, msg: String) -> None:
        self._latched[MISSION_STATE_TOPIC] = msg
        if self.mission.has_sinks():
            self.mission.log(msg.data, log_time=_ns(self.stack.now))

    def _on_frontiers(self, msg: MarkerArray) -> None:
        if self.frontiers.has_sinks():
            self._log(self.frontiers, frontier_scene(msg, self.stack.now), self.stack.now)

    def _send_plan(self, path: Path) -> None:
        self._log(self.plan, poses_message(path.as_array(), path.header.frame_id or "map",
                                           path.header.stamp), self.stack.now)

    # --- per step ---------------------------------------------------------------------------------
    def _on_step(self, now: float) -> None:
        wall = time.monotonic()
        resend = self._listener.resend
        if wall - self._last_republish >= self.params.republish_period:
            self._last_republish = wall
            resend.update((*GRIDS, "/tf_static", "/plan", "/footprint", ARUCO_TOPIC,
                           MISSION_STATE_TOPIC))
        while resend:
            self._republish(resend.pop(), now)
        if wall - self._last_frame < 1.0 / self.params.frame_rate:
            return
        self._last_frame = wall
        self.server.broadcast_time(_ns(now))
        if self.local_plan.has_sinks():
            self._send_local_plan(now)
        if self.markers.has_sinks():
            self._log(self.markers, self._markers(now), now)

    def _republish(self, topic: str, now: float) -> None:
        latched = self._latched.get(topic)
        if topic in self.grids and latched is not None and self.grids[topic].has_sinks():
            self._log(self.grids[topic], grid_message(latched), now)
        elif topic == "/tf_static" and latched is not None and self.tf_static.has_sinks():
            self._log(self.tf_static, tf_message(latched), now)
        elif topic == "/plan" and latched is not None and self.plan.has_sinks():
            self._send_plan(latched)
        elif topic == ARUCO_TOPIC and latched is not None and self.aruco.has_sinks():
            self._log(self.aruco, marker_array_scene(latched, _ns(now)), now)
        elif topic == "/footprint" and self.footprint.has_sinks():
            self._log(self.footprint, self._footprint(now), now)
        elif topic == MISSION_STATE_TOPIC and latched is not None and self.mission.has_sinks():
            self.mission.log(latched.data, log_time=_ns(now))

    def _send_local_plan(self, now: float) -> None:
        for ctrl in self.stack.controller.controllers.values():
            evaluation = getattr(ctrl, "last_evaluation", None)
            traj = getattr(evaluation, "best_trajectory", None) if evaluation else None
            if traj is not None and len(traj):
                self._log(self.local_plan, poses_message(
                    traj, self.stack.local_costmap.global_frame, now), now)
                return

    def _footprint(self, now: float) -> fm.SceneUpdate:
        poly = np.asarray(self.stack.body_footprint.polygon)
        pts = [fm.Point3(x=float(x), y=float(y), z=0.05) for x, y in (*poly, poly[0])]
        line = fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineStrip, thickness=0.02,
                                points=pts, color=_color(0.0, 0.63, 1.0))
        return fm.SceneUpdate(entities=[fm.SceneEntity(
            timestamp=_stamp(now), frame_id="base_link", id="footprint", frame_locked=True,
            lines=[line])])

    def _markers(self, now: float) -> fm.SceneUpdate:
        """Goal arrows (navigator), waypoint spheres (waypoint follower), e-stop label."""
        arrows, spheres = [], []
        active = self.stack.navigator.active_goal
        goal = active.goal if active is not None else None
        poses: tuple[Any, ...] = ()
        if isinstance(goal, m.NavigateThroughPosesGoal):
            poses = goal.poses
        elif isinstance(goal, m.NavigateToPoseGoal):
            poses = (goal.pose,)
        for ps in poses:
            p = ps.pose.to_pose2d()
            arrows.append(fm.ArrowPrimitive(pose=_pose(p.x, p.y, 0.05, p.theta),
                                            shaft_length=0.45, shaft_diameter=0.06,
                                            head_length=0.2, head_diameter=0.16,
                                            color=_color(1.0, 0.0, 1.0)))
        server = self.stack.runtime.bus.action_servers.get("/follow_waypoints")
        for handle in getattr(server, "goals", [])[-1:]:
            if handle.done:
                continue
            for ps in handle.goal.poses:
                p = ps.pose.to_pose2d()
                spheres.append(fm.SpherePrimitive(pose=_pose(p.x, p.y, 0.1, 0.0),
                                                  size=fm.Vector3(x=0.2, y=0.2, z=0.2),
                                                  color=_color(0.7, 0.53, 1.0, 0.9)))
        texts = []
        if self.runner.estop.latched:
            try:
                robot = self.stack.runtime.tf.lookup_pose2d("map", "base_link")
                texts.append(fm.TextPrimitive(
                    pose=_pose(robot.x, robot.y, 0.8, 0.0), billboard=True, font_size=18.0,
                    scale_invariant=True, color=_color(1.0, 0.1, 0.1), text="E-STOP LATCHED"))
            except TransformError:
                pass
        stamp = _stamp(now)
        return fm.SceneUpdate(entities=[
            fm.SceneEntity(timestamp=stamp, frame_id="map", id="goals", arrows=arrows,
                           spheres=spheres),
            fm.SceneEntity(timestamp=stamp, frame_id="map", id="estop", texts=texts)])


def start_foxglove(target: NavStack | LiveRunner, host: str = "127.0.0.1", port: int = 8765,
                   *, real_time_factor: float | None = 1.0) -> FoxgloveHandle:
    """Serve ``target`` to Foxglove on ``ws://host:port``; ``port=0`` picks a free port.

    Given a :class:`NavStack`, a :class:`LiveRunner` at ``real_time_factor`` is created and
    started (and stopped by :meth:`FoxgloveHandle.stop`); given a runner, it is shared.
    """
    params = FoxgloveLiveParams.from_mapping({"port": port, "address": host},
                                             key_path="foxglove")
    owns = isinstance(target, NavStack)
    runner = LiveRunner(target, real_time_factor=real_time_factor) if isinstance(
        target, NavStack) else target
    live = FoxgloveLive(runner, params)
    if owns:
        runner.start()
    return FoxgloveHandle(live, owns)


class FoxgloveHandle:
    """A running Foxglove server: ``url``, ``port``, ``live`` and :meth:`stop`."""

    def __init__(self, live: FoxgloveLive, owns_runner: bool) -> None:
        self.live = live
        self.runner = live.runner
        self.port = live.port
        self.url = live.url
        self._owns = owns_runner

    def stop(self, timeout: float = 5.0) -> None:
        self.live.stop()
        if self._owns:
            self.runner.stop(timeout)
