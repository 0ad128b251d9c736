"""``CollisionMonitorNode``: Nav2's collision_monitor on the bus.

``cmd_vel_in_topic`` (``/cmd_vel_smoothed``) -> zones against the latest data of every
enabled source -> ``cmd_vel_out_topic`` (``/nav_vel``, the twist mux's navigation input).
Sources: ``scan`` (``LaserScan``), ``pointcloud`` (``PointCloud``, kept between
``min_height`` and ``max_height``) and ``range`` (``Range``: an arc of points at the
measured distance across the field of view, every ``obstacles_angle``).  Each source's
points are kept in ``odom_frame_id`` at their stamp and brought into ``base_frame_id`` at
the command's time (``base_shift_correction``: the robot's motion since the sensor took
the data is accounted for), else into the base frame with the latest transform.

A source with ``exclude_map_obstacles`` (navstack) drops, when its data arrives, the points
within that distance of an occupied or unknown cell of the map, or outside it
(``map_topic``, through the ``map_frame_id`` -> sensor transform at the data's stamp):
what is left lies in space the map knows to be free -- people, carts, a dropped box.
Unknown space explains a point because a map being built (SLAM) has not yet published
the walls the robot is discovering: counting them as unexplained kept the robot away from
every new wall and changed the mapping run (docs/command_path.md, "Clearance").  A polygon
that checks only such a source (``sources_names``) keeps its distance from those and
ignores door frames.  Until the map and the transform are known every point is kept.

A source whose newest data is older than its ``source_timeout`` (or that never sent any)
stops the robot while it is stale.  After a stop the output is zero for
``stop_pub_timeout`` seconds and then quiet until the action changes (Nav2).  The action
and its polygon are published on ``state_topic`` (``nav2_msgs/CollisionMonitorState``)
when they change, and :meth:`CollisionMonitorNode.monitor_state` gives them to dashboards.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.control.collision_monitor import (
    ActionType,
    CollisionMonitor,
    CollisionMonitorParams,
    MonitorResult,
)
from navstack.core.errors import TransformError
from navstack.core.geometry import se2_apply
from navstack.core.msgs import (
    CollisionMonitorState,
    LaserScan,
    OccupancyGrid,
    PointCloud,
    Range,
    Twist,
    Twist2D,
)
from navstack.core.polygon import Footprint
from navstack.costmap.map_distance import MapDistance
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["CollisionMonitorNode"]

FloatArray = NDArray[np.float64]


@dataclass
class _Data:
    points: FloatArray  # (N, 2) in `frame`
    frame: str
    stamp: float


class CollisionMonitorNode(Node):
    """Filters velocity commands through the configured zones (Nav2 collision_monitor)."""

    def __init__(self, runtime: Runtime, footprint: Footprint,
                 params: CollisionMonitorParams, name: str = "collision_monitor") -> None:
        super().__init__(name, runtime)
        self.params = params
        self.monitor = CollisionMonitor(params, footprint.polygon)
        self.data: dict[str, _Data | None] = dict.fromkeys(params.observation_sources)
        self.last = MonitorResult(Twist2D(), ActionType.DO_NOTHING)
        self.actions: dict[str, int] = {}
        """How many commands each polygon (or stale source) changed."""
        self.slowed = 0
        self._stop_since: float | None = None
        self._maps: dict[str, MapDistance] = {}  # map topic -> distance to occupied

    def on_configure(self) -> None:
        p = self.params
        self.pub = self.create_publisher(p.cmd_vel_out_topic, Twist, QoS(depth=1))
        self.pub_state = self.create_publisher(p.state_topic, CollisionMonitorState,
                                               QoS(depth=1, latched=True))
        for name in p.observation_sources:
            src = p.source_params[name]
            if not src.enabled:
                continue
            cb = self._source_cb(name)
            kind = {"scan": LaserScan, "pointcloud": PointCloud, "range": Range}[src.type]
            self.create_subscription(src.topic, kind, cb, SENSOR_DATA)
            if src.exclude_map_obstacles > 0.0 and src.map_topic not in self._maps:
                self._maps[src.map_topic] = MapDistance()
                self.create_subscription(src.map_topic, OccupancyGrid,
                                         self._maps[src.map_topic].update, LATCHED)
        self.create_subscription(p.cmd_vel_in_topic, Twist, self._on_cmd, QoS(depth=1))

    def on_activate(self) -> None:
        self.pub_state.publish(CollisionMonitorState(int(ActionType.DO_NOTHING), ""))

    # --- sources ---------------------------------------------------------------------------
    def _source_cb(self, name: str) -> Any:
        return lambda msg: self._on_source(name, msg)

    def _on_source(self, name: str, msg: LaserScan | PointCloud | Range) -> None:
        src = self.params.source_params[name]
        if isinstance(msg, LaserScan):
            pts = msg.points()
        elif isinstance(msg, PointCloud):
            xyz = np.asarray(msg.xyz, dtype=np.float64).reshape(-1, 3)
            keep = (xyz[:, 2] >= src.min_height) & (xyz[:, 2] <= src.max_height)
            pts = xyz[keep, :2]
        else:
            pts = _range_points(msg, src.obstacles_angle)
        frame, stamp = msg.header.frame_id or self.params.base_frame_id, msg.header.stamp
        if src.exclude_map_obstacles > 0.0 and len(pts):
            pts = self._unexplained(pts, frame, stamp, name)
        target = self.params.odom_frame_id if self.params.base_shift_correction else None
        if target is not None:
            try:  # keep the points where they were when sensed
                pose = self.tf.lookup_pose2d(target, frame, stamp)
            except TransformError:
                try:
                    pose = self.tf.lookup_pose2d(target, frame)
                except TransformError:
                    return
            self.data[name] = _Data(se2_apply(pose.as_array(), pts), target, stamp)
        else:
            self.data[name] = _Data(pts, frame, stamp)

    def _unexplained(self, pts: FloatArray, frame: str, stamp: float,
                     name: str) -> FloatArray:
        """``pts`` (in ``frame``) without those the map explains (module docstring)."""
        src = self.params.source_params[name]
        field = self._maps[src.map_topic]
        if field.grid is None:
            return pts
        try:
            pose = self.tf.lookup_pose2d(src.map_frame_id, frame, stamp)
        except TransformError:
            try:
                pose = self.tf.lookup_pose2d(src.map_frame_id, frame)
            except TransformError:
                return pts
        return pts[field.beyond(se2_apply(pose.as_array(), pts), src.exclude_map_obstacles)]

    def _points(self) -> tuple[dict[str, FloatArray], str]:
        """Fresh points per source in the base frame, or the name of a stale source."""
        p, now = self.params, self.now
        chunks: dict[str, FloatArray] = {}
        for name in p.observation_sources:
            src = p.source_params[name]
            if not src.enabled:
                continue
            data, timeout = self.data[name], p.source_timeout_of(name)
            if timeout > 0.0 and (data is None or now - data.stamp > timeout):
                return {}, f"{name} (stale source)"
            if data is None or len(data.points) == 0:
                continue
            try:
                pose = self.tf.lookup_pose2d(p.base_frame_id, data.frame)
            except TransformError:
                return {}, f"{name} (no transform)"
            chunks[name] = se2_apply(pose.as_array(), data.points)
        return chunks, ""

    # --- commands ----------------------------------------------------------------------------
    def _on_cmd(self, msg: Twist) -> None:
        cmd = msg.to_twist2d()
        points, invalid = self._points()
        result = self.monitor.process(cmd, points, invalid)
        if result.action is not ActionType.DO_NOTHING:
            self.actions[result.polygon] = self.actions.get(result.polygon, 0) + 1
            if result.cmd != cmd:
                self.slowed += 1
        if (result.action, result.polygon) != (self.last.action, self.last.polygon):
            self.pub_state.publish(CollisionMonitorState(int(result.action), result.polygon))
        self.last = result
        out = result.cmd
        if out == Twist2D():
            if self._stop_since is None:
                self._stop_since = self.now
            elif self.now - self._stop_since > self.params.stop_pub_timeout:
                return  # Nav2: zero only for stop_pub_timeout after a stop
        else:
            self._stop_since = None
        self.pub.publish(out.to_twist())

    def monitor_state(self) -> dict[str, Any]:
        """For dashboards: the current action, its polygon and counts per polygon."""
        return {"action": self.last.action.name.lower(), "polygon": self.last.polygon,
                "actions": dict(self.actions), "slowed": self.slowed}


def _range_points(msg: Range, step: float) -> FloatArray:
    """Nav2 range source: points on the arc at ``range`` across the field of view, none
    when the reading is outside [min_range, max_range]."""
    r = float(msg.range)
    if not math.isfinite(r) or r < msg.min_range or r > msg.max_range:
        return np.zeros((0, 2))
    half = msg.field_of_view / 2.0
    n = max(1, math.floor(msg.field_of_view / step) + 1)
    a = np.linspace(-half, half, n) if n > 1 else np.zeros(1)
    return np.column_stack((r * np.cos(a), r * np.sin(a)))
