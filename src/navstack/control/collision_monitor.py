"""Collision monitor (Nav2 ``nav2_collision_monitor``), pure: points in, command out.

Polygons (``polygons:``, each a section) are zones in ``base_link``: ``type: polygon``
with ``points`` ``[[x, y], ...]`` or ``type: circle`` with ``radius``, and an
``action_type``:

* ``stop`` -- ``min_points`` or more sensed points inside: the command becomes zero;
* ``slowdown`` -- points inside: the command times ``slowdown_ratio``;
* ``limit`` -- points inside: linear speed at most ``linear_limit``, angular at most
  ``angular_limit`` (Nav2 scales vx, vy by one ratio and clamps wz);
* ``approach`` -- the command's motion is simulated for ``time_before_collision`` in steps
  of ``simulation_time_step``; at the first step where the moved polygon holds
  ``min_points`` points the command is scaled by ``t / time_before_collision``, ``t`` the
  time at the start of that step (Nav2 ``getCollisionTime``), so the robot slows in
  proportion to the time left and stops one step short.

Every enabled polygon is evaluated against the incoming command and the most restrictive
result wins (Nav2 compares linear speed, then |wz|); a stop ends the evaluation.
Sources that are stale stop the robot (:meth:`CollisionMonitor.process` with
``invalid_source``) -- Nav2 Jazzy's rule for a non-zero ``source_timeout``.

navstack departure for ``approach``: only the *simulated* poses are checked, not the
current one (Nav2 returns 0, a stop, when the polygon already holds points at t = 0), and
a point that is already inside the polygon counts at a simulated pose only if the motion
takes it deeper (its distance to the outline grows by more than :data:`DEPTH_SLACK`).  A
robot whose polygon holds a point can still drive along it or away from it; motion that
brings a point in, or closer, is stopped.  Without this a robot within its approach
polygon of a wall -- a padded footprint in a door -- could neither move on nor back away.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from navstack.core.errors import ConfigError
from navstack.core.msgs import Twist2D
from navstack.core.params import Params
from navstack.core.polygon import points_in_polygon

__all__ = ["ActionType", "CollisionMonitor", "CollisionMonitorParams", "MonitorResult",
           "PolygonParams", "SourceParams", "ZonePolygon", "collision_monitor_params"]

FloatArray = NDArray[np.float64]

DEPTH_SLACK = 0.005
"""[m] how much deeper a point already inside an approach polygon may get before it
counts (sensor noise: the lidar's range noise is ~0.01 m)."""


class ActionType(IntEnum):
    """``nav2_msgs/CollisionMonitorState`` action types."""

    DO_NOTHING = 0
    STOP = 1
    SLOWDOWN = 2
    APPROACH = 3
    LIMIT = 4


class PolygonParams(Params):
    """One polygon section (Nav2 names and Jazzy defaults)."""

    type: Literal["polygon", "circle"]
    action_type: Literal["stop", "slowdown", "limit", "approach"]
    points: list[tuple[float, float]] | None = None
    """Vertices [[x, y], ...] in ``base_frame_id`` (``type: polygon``)."""
    radius: float | None = Field(None, gt=0.0)
    """[m] (``type: circle``)."""
    footprint_topic: str = ""
    """Nav2: take the polygon from the costmap's published footprint (the robot's outline
    padded by the costmap's ``footprint_padding``).  navstack: that padded footprint, given
    to the monitor when the stack is built (``type: polygon`` without ``points``)."""
    footprint_padding: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    """[m] navstack: grow a ``footprint_topic`` polygon by this much (every edge moved
    outward; Nav2 takes the costmap's footprint with the costmap's ``footprint_padding``).
    Only with ``footprint_topic``."""
    sources_names: list[str] | None = None
    """Nav2 Jazzy: the observation sources this polygon checks (default: all)."""
    min_points: int = Field(4, ge=1)
    slowdown_ratio: float = Field(0.5, ge=0.0, le=1.0)
    linear_limit: float = Field(0.5, ge=0.0)
    angular_limit: float = Field(0.5, ge=0.0)
    time_before_collision: float = Field(2.0, gt=0.0)
    simulation_time_step: float = Field(0.1, gt=0.0)
    enabled: bool = True
    visualize: bool = False
    polygon_pub_topic: str = ""
    polygon_sub_topic: str = ""

    @model_validator(mode="before")
    @classmethod
    def _max_points(cls, data: Any) -> Any:
        """Nav2 Humble's ``max_points`` (the most points that do *not* trigger the zone)
        is Iron's ``min_points - 1``; Nav2 still reads it, so do we."""
        if isinstance(data, Mapping) and "max_points" in data:
            data = dict(data)
            max_points = data.pop("max_points")
            if "min_points" in data:
                raise ValueError("give min_points or the former max_points, not both")
            if isinstance(max_points, int) and not isinstance(max_points, bool):
                data["min_points"] = max_points + 1
            else:
                data["min_points"] = max_points  # the field's check names the type
        return data

    @model_validator(mode="after")
    def _shape(self) -> PolygonParams:
        if self.type == "circle" and self.radius is None:
            raise ValueError("a circle needs 'radius'")
        if self.type == "polygon":
            if self.points is None and not self.footprint_topic:
                raise ValueError("a polygon needs 'points' (or 'footprint_topic' for the "
                                 "robot's footprint)")
            if self.points is not None and len(self.points) < 3:
                raise ValueError(f"a polygon needs at least 3 points, got {len(self.points)}")
        if self.footprint_padding > 0.0 and (self.type != "polygon" or self.points is not None
                                             or not self.footprint_topic):
            raise ValueError("footprint_padding pads the robot's footprint: only for a "
                             "polygon given by 'footprint_topic' (without 'points')")
        return self


class SourceParams(Params):
    """One observation source section (Nav2 names)."""

    type: Literal["scan", "pointcloud", "range"]
    topic: str
    min_height: float = 0.05
    max_height: float = 0.5
    obstacles_angle: float = Field(math.pi / 180.0, gt=0.0)
    """Range sources: angular step of the arc of points at the measured range [rad]."""
    enabled: bool = True
    source_timeout: float | None = Field(None, ge=0.0)
    """Per-source override of the top-level ``source_timeout`` (Nav2 Iron+)."""
    transform_tolerance: float | None = Field(None, ge=0.0)
    use_global_height: bool = False
    exclude_map_obstacles: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    """[m] navstack: drop the points within this distance of an occupied or unknown cell
    of the map, or off it (``map_topic``, located through ``map_frame_id``), keeping what
    the map does not explain -- people, carts, new obstacles.  0 keeps every point
    (Nav2)."""
    map_topic: str = "/map"
    map_frame_id: str = "map"


class CollisionMonitorParams(Params):
    """Top-level collision_monitor parameters (Nav2 names; ``polygons`` and
    ``observation_sources`` name the sections)."""

    base_frame_id: str = "base_link"
    odom_frame_id: str = "odom"
    cmd_vel_in_topic: str = "/cmd_vel_smoothed"
    cmd_vel_out_topic: str = "/cmd_vel"
    state_topic: str = "/collision_monitor_state"
    transform_tolerance: float = Field(0.1, ge=0.0)
    source_timeout: float = Field(2.0, ge=0.0)
    """[s] data older than this stops the robot; 0 disables the check."""
    base_shift_correction: bool = True
    stop_pub_timeout: float = Field(1.0, ge=0.0)
    """[s] after a stop, zero is published this long, then the output goes quiet."""
    polygons: list[str] = Field(default_factory=list)
    observation_sources: list[str] = Field(default_factory=list)
    use_sim_time: bool = True
    polygon_params: dict[str, PolygonParams] = Field(default_factory=dict)
    """The polygon sections, by name (filled from the Nav2 layout)."""
    source_params: dict[str, SourceParams] = Field(default_factory=dict)
    """The source sections, by name."""

    def source_timeout_of(self, name: str) -> float:
        own = self.source_params[name].source_timeout
        return self.source_timeout if own is None else own


def collision_monitor_params(section: Mapping[str, Any], *, file: str = "",
                             key_path: str = "collision_monitor") -> CollisionMonitorParams:
    """The Nav2 layout (``polygons: [names]`` plus one section per name, same for
    ``observation_sources``) -> validated params; errors name the file and key path."""
    raw = dict(section)
    polygons = raw.get("polygons", [])
    sources = raw.get("observation_sources", [])
    for key, names in (("polygons", polygons), ("observation_sources", sources)):
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise ConfigError("must be a list of section names", file=file,
                              key_path=f"{key_path}.{key}")
    sections: dict[str, dict[str, Any]] = {"polygon_params": {}, "source_params": {}}
    for kind, names, target in (("polygon", polygons, "polygon_params"),
                                ("source", sources, "source_params")):
        for name in names:
            body = raw.pop(name, None)
            if not isinstance(body, Mapping):
                raise ConfigError(f"{kind} '{name}' has no section", file=file,
                                  key_path=f"{key_path}.{name}",
                                  suggestion=f"add '{name}: {{type: ...}}' beside the list")
            sections[target][name] = body
    for name, body in sections["polygon_params"].items():
        chosen = body.get("sources_names")
        if isinstance(chosen, list):
            unknown = [str(n) for n in chosen if n not in sources]
            if unknown:
                raise ConfigError(
                    f"unknown source {unknown[0]!r}", file=file,
                    key_path=f"{key_path}.{name}.sources_names",
                    suggestion=f"name sources listed in observation_sources: {sources}")
    out: dict[str, Any] = {}
    for target in ("polygon_params", "source_params"):
        model = PolygonParams if target == "polygon_params" else SourceParams
        out[target] = {n: model.from_mapping(b, file=file, key_path=f"{key_path}.{n}")
                       for n, b in sections[target].items()}
    return CollisionMonitorParams.from_mapping({**raw, **out}, file=file, key_path=key_path)


def _vel_less(a: Twist2D, b: Twist2D) -> bool:
    """Nav2 ``Velocity::operator<``: slower linear speed, then slower |wz|."""
    va, vb = math.hypot(a.vx, a.vy), math.hypot(b.vx, b.vy)
    return va < vb or (va == vb and abs(a.wz) < abs(b.wz))


def offset_polygon(vertices: FloatArray, distance: float) -> FloatArray:
    """A convex polygon with every edge moved ``distance`` outward (its vertices moved
    along the bisector of the adjacent edges' normals by ``distance / cos(half-angle)``).
    Either winding order."""
    v = np.asarray(vertices, dtype=np.float64)
    area2 = float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    edge = np.roll(v, -1, axis=0) - v  # edge i: v_i -> v_(i+1)
    normal = np.column_stack((edge[:, 1], -edge[:, 0]))  # right normal: outward if CCW
    normal /= np.maximum(np.hypot(normal[:, 0], normal[:, 1]), 1e-12)[:, None]
    if area2 < 0.0:
        normal = -normal
    n_in, n_out = np.roll(normal, 1, axis=0), normal  # edges ending and starting at v_i
    scale = distance / np.maximum(1.0 + np.sum(n_in * n_out, axis=1), 1e-6)
    return np.asarray(v + (n_in + n_out) * scale[:, None])


class ZonePolygon:
    """One polygon or circle with its action."""

    def __init__(self, name: str, params: PolygonParams,
                 footprint: FloatArray | None = None) -> None:
        self.name = name
        self.params = params
        self.circle = params.radius if params.type == "circle" else None
        if params.type == "polygon":
            pts = (np.asarray(params.points, dtype=np.float64) if params.points is not None
                   else np.asarray(footprint, dtype=np.float64))
            if pts.ndim != 2 or len(pts) < 3:
                raise ConfigError(f"polygon '{name}' uses the robot footprint, but none was "
                                  "given", key_path=name)
            if params.footprint_padding > 0.0:
                pts = offset_polygon(pts, params.footprint_padding)
            self.vertices: FloatArray = pts
            self.radius = float(np.max(np.hypot(pts[:, 0], pts[:, 1])))
        else:
            assert self.circle is not None
            self.vertices = np.zeros((0, 2))
            self.radius = float(self.circle)
        steps = math.ceil(params.time_before_collision / params.simulation_time_step - 1e-9)
        self.times = np.arange(1, steps + 1) * params.simulation_time_step

    def inside(self, points_base: FloatArray) -> NDArray[np.bool_]:
        """Which of the ``(N, 2)`` points lie inside the zone."""
        if len(points_base) == 0:
            return np.zeros(0, dtype=bool)
        if self.circle is not None:
            return np.asarray(np.hypot(points_base[:, 0], points_base[:, 1]) <= self.circle)
        return points_in_polygon(points_base, self.vertices)

    def points_inside(self, points_base: FloatArray) -> int:
        return int(np.count_nonzero(self.inside(points_base)))

    def depth(self, points_local: FloatArray) -> FloatArray:
        """Distance [m] of each ``(N, 2)`` point (zone frame) inside the zone to its
        outline; 0 for points outside."""
        if len(points_local) == 0:
            return np.zeros(0)
        if self.circle is not None:
            return np.maximum(self.circle - np.hypot(points_local[:, 0], points_local[:, 1]),
                              0.0)
        a = self.vertices
        b = np.roll(a, -1, axis=0)
        ab = b - a  # (E, 2) edges
        ap = points_local[:, None, :] - a[None, :, :]  # (N, E, 2)
        u = np.clip(np.sum(ap * ab, axis=2) / np.maximum(np.sum(ab * ab, axis=1), 1e-18),
                    0.0, 1.0)
        closest = a[None, :, :] + u[:, :, None] * ab[None, :, :]
        d = np.min(np.hypot(*(points_local[:, None, :] - closest).transpose(2, 0, 1)), axis=1)
        return np.where(self.inside(points_local), d, 0.0)

    def collision_time(self, cmd: Twist2D, points_base: FloatArray) -> float | None:
        """Start time [s] of the first simulation step after which the moved zone holds
        ``min_points`` points that entered it or went deeper (``None``: none within
        ``time_before_collision``; module docstring)."""
        p = self.params
        if len(points_base) == 0 or (cmd.vx == 0.0 and cmd.vy == 0.0 and cmd.wz == 0.0):
            return None
        reach = self.radius + math.hypot(cmd.vx, cmd.vy) * p.time_before_collision
        d = np.hypot(points_base[:, 0], points_base[:, 1])
        pts = points_base[d <= reach]
        if len(pts) < p.min_points:
            return None
        depth0 = self.depth(pts)
        for t in self.times:  # few steps; each test is vectorised over points
            th = cmd.wz * t
            if abs(cmd.wz) < 1e-9:
                x, y = cmd.vx * t, cmd.vy * t
            else:  # exact arc for a constant body twist
                s, c = math.sin(th), math.cos(th)
                x = (cmd.vx * s + cmd.vy * (c - 1.0)) / cmd.wz
                y = (cmd.vx * (1.0 - c) + cmd.vy * s) / cmd.wz
            dx, dy = pts[:, 0] - x, pts[:, 1] - y
            near = dx * dx + dy * dy <= self.radius * self.radius  # broad phase
            if int(np.count_nonzero(near)) < p.min_points:
                continue
            cs, sn = math.cos(th), math.sin(th)
            dx, dy = dx[near], dy[near]
            local = np.column_stack((cs * dx + sn * dy, -sn * dx + cs * dy))
            inside = self.inside(local)
            if int(np.count_nonzero(inside)) < p.min_points:
                continue
            was_in = depth0[near] > 0.0
            counted = inside & (~was_in | (self.depth(local) > depth0[near] + DEPTH_SLACK))
            if int(np.count_nonzero(counted)) >= p.min_points:
                return float(t - p.simulation_time_step)
        return None

    def safe_velocity(self, cmd: Twist2D, points_base: FloatArray) -> Twist2D | None:
        """The zone's velocity for ``cmd`` (``None``: the zone does not act)."""
        p = self.params
        if p.action_type == "approach":
            t = self.collision_time(cmd, points_base)
            if t is None:
                return None
            r = max(0.0, t) / p.time_before_collision
            return Twist2D(cmd.vx * r, cmd.vy * r, cmd.wz * r)
        if self.points_inside(points_base) < p.min_points:
            return None
        if p.action_type == "stop":
            return Twist2D()
        if p.action_type == "slowdown":
            r = p.slowdown_ratio
            return Twist2D(cmd.vx * r, cmd.vy * r, cmd.wz * r)
        lin = math.hypot(cmd.vx, cmd.vy)  # limit
        r = min(max(p.linear_limit / lin, 0.0), 1.0) if lin != 0.0 else 1.0
        wz = min(max(cmd.wz, -p.angular_limit), p.angular_limit)
        return Twist2D(cmd.vx * r, cmd.vy * r, wz)


@dataclass(frozen=True)
class MonitorResult:
    """The command to publish, the action taken and the polygon (or cause) behind it."""

    cmd: Twist2D
    action: ActionType
    polygon: str = ""


_ACTIONS = {"stop": ActionType.STOP, "slowdown": ActionType.SLOWDOWN,
            "approach": ActionType.APPROACH, "limit": ActionType.LIMIT}


class CollisionMonitor:
    """All enabled zones of a configuration; ``footprint`` (``(K, 2)`` in base_link) is
    used by polygons given by ``footprint_topic``."""

    def __init__(self, params: CollisionMonitorParams,
                 footprint: FloatArray | None = None) -> None:
        self.params = params
        self.zones = [ZonePolygon(n, params.polygon_params[n], footprint)
                      for n in params.polygons]

    def process(self, cmd: Twist2D, points_base: FloatArray | Mapping[str, FloatArray],
                invalid_source: str = "") -> MonitorResult:
        """The safe command for ``cmd`` given the sensed points in base_link: one
        ``(N, 2)`` array, or an array per source name (polygons with ``sources_names``
        see only theirs).  ``invalid_source`` names a stale or missing source: the robot
        stops."""
        if invalid_source:
            return MonitorResult(Twist2D(), ActionType.STOP, invalid_source)
        best = MonitorResult(cmd, ActionType.DO_NOTHING)
        for zone in self.zones:
            if not zone.params.enabled:
                continue
            safe = zone.safe_velocity(cmd, _points_for(zone, points_base))
            if safe is None:
                continue
            action = _ACTIONS[zone.params.action_type]
            if action is ActionType.STOP:
                return MonitorResult(safe, action, zone.name)
            if _vel_less(safe, best.cmd):
                best = MonitorResult(safe, action, zone.name)
        return best


def _points_for(zone: ZonePolygon, points: FloatArray | Mapping[str, FloatArray]) -> FloatArray:
    if not isinstance(points, Mapping):
        return points
    names = zone.params.sources_names
    chunks = [a for n, a in points.items() if (names is None or n in names) and len(a)]
    return np.vstack(chunks) if chunks else np.zeros((0, 2))
