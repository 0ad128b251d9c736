"""Simulated worlds: a static occupancy grid plus deterministic moving obstacles.

A :class:`World` is what the simulator's sensors and collision checks see: a boolean
grid ``occupied[H, W]`` (row 0 at ``origin_y``, column 0 at ``origin_x``, cells
``resolution`` metres square) and a tuple of :class:`MovingObstacle` that follow
polylines at constant speed.  Everything about a moving obstacle is a pure function
of time ``t`` (seconds), so a simulation replays identically from the same seed.

Worlds are built from primitives YAML or ROS map files by :mod:`navstack.sim.world_io`
and catalogued in :mod:`navstack.sim.worlds`.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import SimulationError
from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose, Pose2D
from navstack.core.polygon import points_in_polygon
from navstack.sim.markers import PackageSpec, WorldMarker

FloatArray = NDArray[np.float64]


class ObstacleState(NamedTuple):
    """A moving obstacle's clock [s] and its offset [m] from the point of its path at that
    clock (a walker that stepped aside to pass a robot, :mod:`navstack.sim.simulator`)."""

    clock: float
    dx: float = 0.0
    dy: float = 0.0


ObstacleClock = float | ObstacleState
"""One obstacle's clock, or its clock and offset while it is off its path."""
MovingTime = float | tuple[ObstacleClock, ...]
"""One time for all moving obstacles, or one clock (or state) per obstacle."""
_NO_SEGMENTS: FloatArray = np.zeros((0, 4))
_NO_SEGMENTS.setflags(write=False)
BoolArray = NDArray[np.bool_]
ObstacleShape = Literal["circle", "box"]
PathMode = Literal["pingpong", "loop"]


@dataclass(frozen=True, eq=False)
class MovingObstacle:
    """An obstacle moving along ``path`` (``(P, 2)`` metres) at ``speed`` m/s.

    ``pingpong`` walks to the last point and back again; ``loop`` continues from the last
    point straight back to the first.  ``phase`` is the distance [m] already travelled
    at ``t = 0``.  A ``box`` of ``size`` (length along its heading, width) faces its
    direction of travel unless ``yaw`` fixes its heading; a ``circle`` has ``radius``.
    """

    name: str
    shape: ObstacleShape
    path: FloatArray
    speed: float
    mode: PathMode = "pingpong"
    radius: float = 0.3
    size: tuple[float, float] = (0.6, 0.6)
    yaw: float | None = None
    phase: float = 0.0
    _verts: FloatArray = field(init=False, repr=False)
    _cum: FloatArray = field(init=False, repr=False)
    _cum_list: list[float] = field(init=False, repr=False)
    _verts_list: list[tuple[float, float]] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        path = np.asarray(self.path, dtype=np.float64).reshape(-1, 2)
        if len(path) == 0:
            raise SimulationError(f"moving obstacle '{self.name}' needs at least one path point")
        verts = np.vstack((path, path[:1])) if self.mode == "loop" and len(path) > 1 else path
        seg = np.hypot(*np.diff(verts, axis=0).T) if len(verts) > 1 else np.zeros(0)
        object.__setattr__(self, "path", path)
        object.__setattr__(self, "_verts", verts)
        object.__setattr__(self, "_cum", np.concatenate(([0.0], np.cumsum(seg))))
        # plain-float copies: pose_at runs every physics step, where numpy scalars are slow
        object.__setattr__(self, "_cum_list", [float(v) for v in self._cum])
        object.__setattr__(self, "_verts_list", [(float(a), float(b)) for a, b in verts])

    @property
    def length(self) -> float:
        """Length [m] of one pass (pingpong: one way; loop: the closed circuit)."""
        return float(self._cum[-1])

    def pose_at(self, t: float) -> tuple[float, float, float]:
        """``(x, y, heading)`` at time ``t`` [s]; heading is the direction of travel."""
        cum, verts = self._cum_list, self._verts_list
        total = cum[-1]
        if total <= 0.0:
            x, y = verts[0]
            return x, y, 0.0 if self.yaw is None else self.yaw
        s = self.phase + self.speed * t
        backward = False
        if self.mode == "pingpong":
            s = math.fmod(s, 2.0 * total)
            s = s + 2.0 * total if s < 0.0 else s
            if s > total:
                s, backward = 2.0 * total - s, True
        else:
            s = math.fmod(s, total)
            s = s + total if s < 0.0 else s
        i = bisect.bisect_right(cum, s) - 1
        i = min(max(i, 0), len(cum) - 2)
        a, b = verts[i], verts[i + 1]
        seg = cum[i + 1] - cum[i]
        f = (s - cum[i]) / seg if seg > 0.0 else 0.0
        heading = math.atan2(b[1] - a[1], b[0] - a[0]) + (math.pi if backward else 0.0)
        if self.yaw is not None:
            heading = self.yaw
        heading = math.atan2(math.sin(heading), math.cos(heading))
        return a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), heading

    def pose_in(self, state: ObstacleClock) -> tuple[float, float, float]:
        """``(x, y, heading)`` at a clock, or at an :class:`ObstacleState` (its offset
        added; the heading stays the path's)."""
        if isinstance(state, ObstacleState):
            x, y, h = self.pose_at(state.clock)
            return x + state.dx, y + state.dy, h
        return self.pose_at(state)

    def polygon_at(self, t: ObstacleClock) -> FloatArray:
        """Corners ``(4, 2)`` of a box obstacle at time (or state) ``t``
        (counter-clockwise)."""
        x, y, h = self.pose_in(t)
        hl, hw = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
        c, s = math.cos(h), math.sin(h)
        return np.column_stack((x + c * local[:, 0] - s * local[:, 1],
                                y + s * local[:, 0] + c * local[:, 1]))


@dataclass(eq=False)
class World:
    """Static grid + moving obstacles + named places (+ markers and packages for cameras).

    ``occupied`` is ``bool[H, W]`` with row 0 at ``origin_y`` (lowest y); cell ``(r, c)``
    covers ``[origin_x + c*res, origin_x + (c+1)*res) x [origin_y + r*res, ...)``.
    """

    occupied: BoolArray
    resolution: float
    origin_x: float = 0.0
    origin_y: float = 0.0
    name: str = "world"
    moving_obstacles: tuple[MovingObstacle, ...] = ()
    spawn: Pose2D = field(default_factory=Pose2D)
    waypoints: dict[str, Pose2D] = field(default_factory=dict)
    source: Path | None = None
    markers: tuple[WorldMarker, ...] = ()
    """Fiducial markers on walls and obstacles (:mod:`navstack.sim.markers`)."""
    packages: tuple[PackageSpec, ...] = ()
    """Marked boxes on the floor, below the lidar plane (initial placement)."""
    wall_height: float = 2.0
    """Height [m] of every occupied cell as the camera sees it (a 2.5-D world)."""
    _distance: FloatArray | None = field(default=None, init=False, repr=False)
    _moving_cache: tuple[MovingTime, FloatArray, FloatArray] | None = field(
        default=None, init=False, repr=False)
    _shapes_cache: tuple[MovingTime, FloatArray, FloatArray] | None = field(
        default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        occ = np.ascontiguousarray(self.occupied, dtype=np.bool_)
        if occ.ndim != 2 or occ.size == 0:
            raise SimulationError(f"world '{self.name}': occupied must be a non-empty 2-D grid, "
                                  f"got shape {occ.shape}")
        if not self.resolution > 0.0:
            raise SimulationError(f"world '{self.name}': resolution must be positive, "
                                  f"got {self.resolution}")
        self.occupied = occ
        self.moving_obstacles = tuple(self.moving_obstacles)

    # --- geometry ------------------------------------------------------------------
    @property
    def height(self) -> int:
        return int(self.occupied.shape[0])

    @property
    def width(self) -> int:
        return int(self.occupied.shape[1])

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` of the grid in metres."""
        return (self.origin_x, self.origin_y, self.origin_x + self.width * self.resolution,
                self.origin_y + self.height * self.resolution)

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """``(row, col)`` of the cell containing ``(x, y)``; may lie outside the grid."""
        return (math.floor((y - self.origin_y) / self.resolution),
                math.floor((x - self.origin_x) / self.resolution))

    def cell_center(self, row: int, col: int) -> tuple[float, float]:
        return (self.origin_x + (col + 0.5) * self.resolution,
                self.origin_y + (row + 0.5) * self.resolution)

    def in_bounds(self, x: float, y: float) -> bool:
        r, c = self.world_to_cell(x, y)
        return 0 <= r < self.height and 0 <= c < self.width

    def is_free(self, x: float, y: float, t: MovingTime | None = None) -> bool:
        """True if ``(x, y)`` is inside the grid, not in an occupied cell and, when ``t``
        is given, not inside a moving obstacle at time ``t``."""
        r, c = self.world_to_cell(x, y)
        if not (0 <= r < self.height and 0 <= c < self.width) or self.occupied[r, c]:
            return False
        if t is None or not self.moving_obstacles:
            return True
        circles, boxes = self.moving_shapes_at(t)
        if len(circles) and np.any(np.hypot(circles[:, 0] - x, circles[:, 1] - y)
                                   <= circles[:, 2]):
            return False
        pt = np.array([[x, y]])
        return not any(points_in_polygon(pt, poly)[0] for poly in boxes)

    # --- moving obstacles ----------------------------------------------------------
    def moving_shapes_at(self, t: MovingTime) -> tuple[FloatArray, FloatArray]:
        """``(circles (k, 3) as (cx, cy, r), boxes (b, 4, 2) corners)`` at time ``t``.

        ``t`` is one time for every obstacle, or a tuple with each obstacle's own clock
        (the simulator holds an obstacle's clock while it yields to the robot), or its
        :class:`ObstacleState` while it has stepped off its path to pass a robot.
        Memoised for the last ``t`` (physics and sensors ask about the same instant);
        callers must not modify the arrays.
        """
        cached = self._shapes_cache
        if cached is not None and cached[0] == t:
            return cached[1], cached[2]
        obstacles = self.moving_obstacles
        times = t if isinstance(t, tuple) else (t,) * len(obstacles)
        circles = [(*o.pose_in(ti)[:2], o.radius) for o, ti in zip(obstacles, times, strict=True)
                   if o.shape == "circle"]
        boxes = [o.polygon_at(ti) for o, ti in zip(obstacles, times, strict=True)
                 if o.shape == "box"]
        out = (np.array(circles, dtype=np.float64).reshape(-1, 3),
               np.array(boxes, dtype=np.float64).reshape(-1, 4, 2))
        self._shapes_cache = (t, *out)
        return out

    def moving_at(self, t: MovingTime) -> tuple[FloatArray, FloatArray]:
        """``(circles (k, 3) (cx, cy, r), segments (m, 4) (x1, y1, x2, y2))`` at time ``t``.

        Box obstacles contribute their four edges as segments (what a lidar can hit).
        Deterministic: a pure function of ``t`` (the last answer is memoised because
        physics and sensors ask for the same instant).  Callers must not modify it.
        """
        cached = self._moving_cache
        if cached is not None and cached[0] == t:
            return cached[1], cached[2]
        circles, boxes = self.moving_shapes_at(t)
        if len(boxes):
            segs = np.concatenate((boxes, np.roll(boxes, -1, axis=1)), axis=2).reshape(-1, 4)
        else:
            segs = _NO_SEGMENTS
        self._moving_cache = (t, circles, segs)
        return circles, segs

    # --- static map ----------------------------------------------------------------
    def to_occupancy_grid(self, frame_id: str = "map", stamp: float = 0.0) -> OccupancyGrid:
        """The true static map: occupied cells 100, all others 0 (no unknown)."""
        data = np.where(self.occupied, 100, 0).astype(np.int8)
        info = MapMetaData(map_load_time=stamp, resolution=self.resolution, width=self.width,
                           height=self.height,
                           origin=Pose(Point(self.origin_x, self.origin_y, 0.0)))
        return OccupancyGrid(Header(stamp, frame_id), info, data)

    @staticmethod
    def from_occupancy_grid(grid: OccupancyGrid, name: str = "map",
                            spawn: Pose2D | None = None,
                            waypoints: dict[str, Pose2D] | None = None,
                            source: Path | None = None) -> World:
        """A world whose static obstacles are the grid's cells of value 100.

        Unknown (-1) and partly occupied cells count as free for the simulator.  Grids
        with a rotated origin are refused.  Without ``spawn`` the robot starts at the
        free cell farthest from any obstacle.
        """
        o = grid.info.origin.to_pose2d()
        if abs(o.theta) > 1e-9:
            raise SimulationError(f"map '{name}': origin yaw {o.theta} is not supported by the "
                                  "simulator; rotate the image instead and set yaw 0")
        world = World(np.asarray(grid.data) == 100, grid.info.resolution, o.x, o.y, name,
                      waypoints=dict(waypoints or {}), source=source)
        if spawn is None:
            dist = world.distance_field()
            r, c = np.unravel_index(int(np.argmax(dist)), dist.shape)
            spawn = Pose2D(*world.cell_center(int(r), int(c)), 0.0)
        world.spawn = spawn
        return world

    def distance_field(self) -> FloatArray:
        """Distance [m] from each cell centre to the nearest occupied cell centre.

        Computed once with ``scipy.ndimage.distance_transform_edt`` and cached; cells
        of a grid with no obstacle get ``inf``.
        """
        if self._distance is None:
            if not self.occupied.any():
                self._distance = np.full(self.occupied.shape, np.inf)
            else:
                from scipy.ndimage import distance_transform_edt

                dist = distance_transform_edt(~self.occupied, sampling=self.resolution)
                self._distance = np.asarray(dist, dtype=np.float64)
        return self._distance

    def cast_rays(self, x: float, y: float, theta: float, angles: FloatArray,
                  range_min: float, range_max: float, t: float) -> FloatArray:
        """Lidar ranges [m] from ``(x, y)`` at time ``t``; see :func:`raycast.cast_rays`."""
        from navstack.sim.raycast import cast_rays

        circles, segments = self.moving_at(t) if self.moving_obstacles else (None, None)
        return cast_rays(self.occupied, self.origin_x, self.origin_y, self.resolution, x, y,
                         theta, angles, range_min, range_max, circles, segments)
