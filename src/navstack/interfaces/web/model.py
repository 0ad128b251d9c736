"""``DashboardModel``: what the web page shows, gathered in the simulation thread.

It listens on the bus like any other node -- ``/map`` (latched), ``/global_costmap/costmap``,
``/local_costmap/costmap``, ``/scan``, the planner's ``/plan``, ``/amcl_pose`` and
``/odometry/filtered`` when present, and a running mission's ``/mission/state`` (JSON) and
frontier markers (``/explore/frontiers``) -- and after each simulation step (at most
``frame_rate`` times per wall second) builds one immutable snapshot: robot pose from TF
(``map`` <- ``base_link``), the scan in ``map``, the controller's chosen local trajectory,
the navigation status, the e-stop state and a health block.  The server thread only ever
reads these snapshots (single reference swaps), so it never touches the stack.

Images are re-encoded only when a grid's content or placement changes, and carry a
``version`` so clients download each image once.  The trajectory history is append-only
(with an ``offset`` once old points are dropped) so clients fetch only new points.
"""

from __future__ import annotations

import json
import math
import time
from collections import deque
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import TransformError
from navstack.core.geometry import se2_apply
from navstack.core.msgs import (
    LaserScan,
    MarkerArray,
    OccupancyGrid,
    Odometry,
    Path,
    Pose2D,
    PoseWithCovarianceStamped,
    String,
)
from navstack.core.msgs.fiducial_msgs import MARKER_MAP_VIZ_TOPIC as ARUCO_TOPIC
from navstack.core.rotations import quaternion_to_matrix
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.web.commands import NavCommander
from navstack.interfaces.web.images import Scheme, grid_png
from navstack.missions.explore import FRONTIERS_TOPIC
from navstack.missions.mission import MISSION_STATE_TOPIC
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS, Subscription

LAYERS: dict[str, tuple[str, Scheme]] = {
    "map": ("/map", "map"),
    "global_costmap": ("/global_costmap/costmap", "costmap"),
    "local_costmap": ("/local_costmap/costmap", "costmap"),
}
HEALTH_TOPICS = ("/scan", "/odom", "/cmd_vel")
RATE_WINDOW = 2.0
"""Simulated seconds over which topic rates are measured."""
TRAIL_STEP = 0.05
"""Metres the robot moves before the trajectory history gets a new point."""
TRAIL_MAX = 20000


@dataclass(frozen=True)
class LayerImage:
    """One grid as a PNG, with its placement: ``pose`` of the grid origin in ``map``."""

    name: str
    version: int
    png: bytes
    width: int
    height: int
    resolution: float
    pose: tuple[float, float, float]
    frame_id: str

    def meta(self) -> dict[str, Any]:
        return {"name": self.name, "version": self.version, "width": self.width,
                "height": self.height, "resolution": self.resolution,
                "pose": list(self.pose), "frame_id": self.frame_id}


def _flat(xy: NDArray[np.float64], max_points: int) -> list[float]:
    """``(N, 2)`` points as a flat list rounded to 1 cm, decimated to ``max_points``."""
    if len(xy) > max_points:
        idx = np.unique(np.linspace(0, len(xy) - 1, max_points).round().astype(np.int64))
        xy = xy[idx]
    return [float(v) for v in np.round(xy, 2).reshape(-1)]


class TopicRates:
    """Publish rates of bus topics over a sliding window of simulated time."""

    def __init__(self, topics: tuple[str, ...], window: float = RATE_WINDOW) -> None:
        self.topics = topics
        self.window = window
        self._samples: deque[tuple[float, tuple[int, ...]]] = deque()

    def sample(self, now: float, counts: tuple[int, ...]) -> dict[str, float]:
        """Record the topics' message counts at ``now``; rates [Hz] over the window."""
        self._samples.append((now, counts))
        while len(self._samples) > 2 and now - self._samples[1][0] >= self.window:
            self._samples.popleft()
        t0, c0 = self._samples[0]
        span = now - t0
        if span <= 0.0:
            return dict.fromkeys(self.topics, 0.0)
        return {name: (c - c_old) / span
                for name, c, c_old in zip(self.topics, counts, c0, strict=True)}


class DashboardModel:
    """Collects the dashboard's view of a running stack (simulation thread side)."""

    def __init__(self, runner: LiveRunner, commander: NavCommander,
                 frame_rate: float = 20.0) -> None:
        self.runner = runner
        self.stack = runner.stack
        self.commander = commander
        self.frame_period = 1.0 / frame_rate
        self.rates = TopicRates(HEALTH_TOPICS)
        # snapshots read by the server thread: each is replaced, never mutated
        self.frame: tuple[int, str] = (0, "{}")
        self.layers: dict[str, LayerImage] = {}
        self.plan: tuple[int, list[float]] = (0, [])
        self.trail: tuple[int, list[tuple[float, float]]] = (0, [])
        self._scan: LaserScan | None = None
        self._loc: tuple[str, float, NDArray[np.float64]] | None = None
        self._aruco: list[list[Any]] = []
        self._mission: dict[str, Any] | None = None
        self._frontiers: dict[str, list[float]] = {"points": [], "blacklisted": [],
                                                   "goals": []}
        self._grids: dict[str, OccupancyGrid] = {}
        self._subs: list[Subscription[Any]] = []
        self._last_frame_wall = -math.inf
        self._seq = 0
        self._remove_observer: Any = None

    # --- attach / detach (simulation thread, through runner.call) ---------------------------------
    def attach(self) -> None:
        def setup(_: Any) -> None:
            bus = self.stack.runtime.bus
            for name, (topic, scheme) in LAYERS.items():
                qos = LATCHED if name == "map" else QoS(depth=1)
                self._subs.append(bus.subscribe(
                    topic, OccupancyGrid, partial(self._on_grid, name, scheme), qos))
            self._subs.append(bus.subscribe("/scan", LaserScan, self._on_scan, SENSOR_DATA))
            plan_topic = getattr(self.stack.planner.params, "plan_topic", "/plan")
            self._subs.append(bus.subscribe(plan_topic, Path, self._on_plan, LATCHED))
            self._subs.append(bus.subscribe("/amcl_pose", PoseWithCovarianceStamped,
                                            self._on_amcl, QoS(depth=1)))
            self._subs.append(bus.subscribe("/odometry/filtered", Odometry, self._on_ekf,
                                            QoS(depth=1)))
            self._subs.append(bus.subscribe(ARUCO_TOPIC, MarkerArray, self._on_aruco, LATCHED))
            self._subs.append(bus.subscribe(MISSION_STATE_TOPIC, String, self._on_mission,
                                            LATCHED))
            self._subs.append(bus.subscribe(FRONTIERS_TOPIC, MarkerArray, self._on_frontiers,
                                            QoS(depth=1)))
            self._build_frame(self.stack.now)

        self.runner.call(setup)
        self._remove_observer = self.runner.add_observer(self.on_step)

    def detach(self) -> None:
        if self._remove_observer is not None:
            self._remove_observer()
            self._remove_observer = None

        def teardown(_: Any) -> None:
            for sub in self._subs:
                sub.unsubscribe()
            self._subs.clear()

        self.runner.call(teardown)

    # --- bus callbacks ----------------------------------------------------------------------------
    def _on_scan(self, scan: LaserScan) -> None:
        self._scan = scan

    def _on_plan(self, path: Path) -> None:
        xy = path.as_array()[:, :2]
        if path.header.frame_id and path.header.frame_id != "map" and len(xy):
            try:
                tf = self.stack.runtime.tf.lookup_pose2d("map", path.header.frame_id)
                xy = se2_apply(tf.as_array(), xy)
            except TransformError:
                return
        self.plan = (self.plan[0] + 1, _flat(np.asarray(xy), 1000))

    def _on_aruco(self, msg: MarkerArray) -> None:
        """ArUco markers and packages on the map: ``[id, x, y, facing yaw, kind]`` (map
        frame; the facing yaw is the marker's z axis)."""
        out = []
        for m in msg.markers:
            if m.ns not in ("aruco_markers", "packages") or (m.header.frame_id or "map") != "map":
                continue
            r = quaternion_to_matrix(m.pose.orientation)
            facing = math.atan2(r[1, 2], r[0, 2]) if m.ns == "aruco_markers" else 0.0
            out.append([m.id, round(m.pose.position.x, 3), round(m.pose.position.y, 3),
                        round(facing, 3), "package" if m.ns == "packages" else "marker"])
        self._aruco = out

    def _on_amcl(self, msg: PoseWithCovarianceStamped) -> None:
        self._loc = ("/amcl_pose", msg.header.stamp, np.asarray(msg.pose.covariance))

    def _on_ekf(self, msg: Odometry) -> None:
        if self._loc is None or self._loc[0] != "/amcl_pose":
            self._loc = ("/odometry/filtered", msg.header.stamp, np.asarray(msg.pose.covariance))

    def _on_mission(self, msg: String) -> None:
        try:
            self._mission = json.loads(msg.data)
        except ValueError:
            self._mission = {"name": "?", "status": "?", "feedback": msg.data[:200]}

    def _on_frontiers(self, msg: MarkerArray) -> None:
        """Frontier cells (blue), blacklisted cells (red) and goals, as flat x, y lists."""
        points: list[float] = []
        black: list[float] = []
        goals: list[float] = []
        for m in msg.markers:
            if m.action != m.ADD:
                continue
            if m.type == m.SPHERE:
                goals += [round(m.pose.position.x, 2), round(m.pose.position.y, 2)]
            elif m.type == m.POINTS:
                flat = [round(v, 2) for p in m.points for v in (p.x, p.y)]
                (black if m.ns == "blacklist" else points).extend(flat)
        self._frontiers = {"points": points[:4000], "blacklisted": black[:2000],
                           "goals": goals}

    def _on_grid(self, name: str, scheme: Scheme, grid: OccupancyGrid) -> None:
        """Re-encode only when the content or the placement in ``map`` changed."""
        pose = self._grid_pose(grid)
        if pose is None:
            return
        old, prev = self._grids.get(name), self.layers.get(name)
        if (old is not None and prev is not None and old.info == grid.info
                and np.array_equal(old.data, grid.data)
                and np.allclose(prev.pose, pose, atol=1e-3)):
            return
        self._grids[name] = grid
        version = prev.version + 1 if prev is not None else 1
        info = grid.info
        layers = dict(self.layers)
        layers[name] = LayerImage(name, version, grid_png(grid, scheme), info.width,
                                  info.height, info.resolution, pose,
                                  grid.header.frame_id or "map")
        self.layers = layers

    def _grid_pose(self, grid: OccupancyGrid) -> tuple[float, float, float] | None:
        """Pose of the grid's origin corner in ``map``."""
        o = grid.info.origin.to_pose2d()
        frame = grid.header.frame_id or "map"
        if frame != "map":
            try:
                o = self.stack.runtime.tf.lookup_pose2d("map", frame).compose(o)
            except TransformError:
                return None
        return (round(o.x, 4), round(o.y, 4), round(o.theta, 5))

    # --- per step ---------------------------------------------------------------------------------
    def on_step(self, now: float) -> None:
        wall = time.monotonic()
        if wall - self._last_frame_wall < self.frame_period:
            return
        self._last_frame_wall = wall
        self._build_frame(now)

    def _build_frame(self, now: float) -> None:
        stack, tf = self.stack, self.stack.runtime.tf
        robot: Pose2D | None
        try:
            robot = tf.lookup_pose2d("map", "base_link")
        except TransformError:
            robot = None
        if robot is not None:
            self._extend_trail(robot)
        topics = stack.runtime.bus.topics
        counts = tuple(topics[n].count if n in topics else 0 for n in HEALTH_TOPICS)
        self._seq += 1
        frame = {
            "type": "state", "seq": self._seq, "t": round(now, 3),
            "robot": None if robot is None else [round(robot.x, 4), round(robot.y, 4),
                                                 round(robot.theta, 4)],
            "scan": self._scan_points(),
            "local_plan": self._local_plan(),
            "nav": self.commander.status(),
            "waypoints": self.commander.waypoint_list()["waypoints"],
            "aruco": self._aruco,
            "estop": self.runner.estop.state(),
            "health": self._health(now, counts),
            "layers": {k: v.version for k, v in self.layers.items()},
            "plan_version": self.plan[0],
            "trail_end": self.trail[0] + len(self.trail[1]),
            "mission": self._mission,
            "frontiers": self._frontiers,
        }
        self.frame = (self._seq, json.dumps(frame, allow_nan=False, separators=(",", ":")))

    def _extend_trail(self, robot: Pose2D) -> None:
        offset, points = self.trail
        if points and math.hypot(robot.x - points[-1][0], robot.y - points[-1][1]) < TRAIL_STEP:
            return
        points.append((round(robot.x, 3), round(robot.y, 3)))
        if len(points) > TRAIL_MAX:
            drop = TRAIL_MAX // 4
            self.trail = (offset + drop, points[drop:])

    def trail_since(self, index: int) -> tuple[int, list[tuple[float, float]]]:
        """Points from absolute ``index`` on (server thread): ``(start, points)``."""
        offset, points = self.trail
        start = max(index, offset)
        return start, points[start - offset:]

    def _scan_points(self) -> list[float]:
        scan = self._scan
        if scan is None:
            return []
        try:
            mount = self.stack.runtime.tf.lookup_pose2d("map", scan.header.frame_id)
        except TransformError:
            return []
        return _flat(se2_apply(mount.as_array(), scan.points()), 720)

    def _local_plan(self) -> list[float]:
        """The controller's chosen trajectory (DWB ``last_evaluation``), in ``map``."""
        traj = None
        for ctrl in self.stack.controller.controllers.values():
            evaluation = getattr(ctrl, "last_evaluation", None)
            traj = getattr(evaluation, "best_trajectory", None) if evaluation else None
            if traj is not None:
                break
        if traj is None or len(traj) == 0:
            return []
        try:
            tf = self.stack.runtime.tf.lookup_pose2d("map", self.stack.local_costmap.global_frame)
        except TransformError:
            return []
        return _flat(se2_apply(tf.as_array(), np.asarray(traj)[:, :2]), 60)

    def _health(self, now: float, counts: tuple[int, ...]) -> dict[str, Any]:
        tf = self.stack.runtime.tf
        tf_age: float | None
        tf_error = ""
        try:
            tf_age = round(now - tf.lookup("map", "base_link").header.stamp, 3)
        except TransformError as exc:
            tf_age, tf_error = None, str(exc)
        loc: dict[str, Any] | None = None
        if self._loc is not None:
            topic, stamp, cov = self._loc
            loc = {"topic": topic, "age": round(now - stamp, 3),
                   "std_x": round(math.sqrt(max(cov[0, 0], 0.0)), 4),
                   "std_y": round(math.sqrt(max(cov[1, 1], 0.0)), 4),
                   "std_yaw": round(math.sqrt(max(cov[5, 5], 0.0)), 4)}
        rates = self.rates.sample(now, counts)
        return {"rates": {k: round(v, 2) for k, v in rates.items()},
                "tf_age": tf_age, "tf_error": tf_error, "localization": loc,
                "collisions": int(self.stack.sim.sim.collisions),
                "real_time_factor": round(self.runner.real_time_factor, 2),
                "running": self.runner.running,
                "error": str(self.runner.error) if self.runner.error else ""}

    def hello(self) -> dict[str, Any]:
        """Static facts for a new client (server thread: read-only constants)."""
        stack = self.stack
        xmin, ymin, xmax, ymax = stack.world.bounds
        return {"type": "hello", "frame_id": "map",
                "bounds": [xmin, ymin, xmax, ymax],
                "footprint": [[round(float(x), 4), round(float(y), 4)]
                              for x, y in stack.body_footprint.polygon],
                "waypoints": {name: [p.x, p.y, p.theta]
                              for name, p in stack.world.waypoints.items()},
                "frame_rate": 1.0 / self.frame_period}
