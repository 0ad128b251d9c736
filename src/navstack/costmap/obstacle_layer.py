"""Obstacle layer (Nav2 ``nav2_costmap_2d::ObstacleLayer``) and its VoxelLayer alias.

Sensor data enters through :meth:`ObstacleLayer.add_scan` / :meth:`ObstacleLayer.add_points`
with the sensor pose given explicitly in the costmap frame (no TF lookups here).  Each
update (``update_bounds``), in Nav2's order:

1. rolling window: the layer grid follows the robot (cells keep their world position);
2. clearing: for every observation of a ``clearing`` source, Bresenham rays from the
   sensor origin to each point (clipped to the map, ``raytrace_min_range`` ..
   ``raytrace_max_range``) set FREE_SPACE - the end cell is not cleared;
3. marking: every point of a ``marking`` source with ``min_obstacle_height <= z <=
   max_obstacle_height`` (layer level) and ``obstacle_min_range <= |p - origin| <
   obstacle_max_range`` (3D, per source) sets LETHAL_OBSTACLE;
4. ``footprint_clearing_enabled``: the footprint cells are cleared in ``update_costs``
   before combining into the master with ``combination_method`` (0 overwrite, 1 max,
   2 max without overwriting unknown).

``unmapped_padding`` (navstack, 0 = Nav2): a marked point that the map of the same
costmap's static layer does not explain -- farther than ``unmapped_distance`` from its
occupied and unknown cells (:mod:`navstack.costmap.map_distance`) -- is marked as a disc
of that radius, so the inflation keeps the robot that much further from people and carts
than from walls and door frames (docs/command_path.md, "Clearance").  Without a static
layer or before its map arrives, nothing is padded.

The layer grid starts NO_INFORMATION when tracking unknown space, else FREE.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field, field_validator

from navstack.core.errors import ConfigError, UnknownNameError
from navstack.core.msgs import LaserScan, Pose2D
from navstack.costmap.costmap_2d import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D
from navstack.costmap.footprint import set_polygon_cost, transform_footprint
from navstack.costmap.layer import (
    Bounds,
    CellWindow,
    CostmapLayer,
    LayerParams,
    combine,
    register_layer,
)
from navstack.costmap.map_distance import MapDistance
from navstack.costmap.observation_buffer import (
    Observation,
    ObservationBuffer,
    ObservationSourceParams,
    observation_from_points,
    observation_from_scan,
)
from navstack.costmap.raytrace import clip_rays_to_map, raytrace_lines

if TYPE_CHECKING:
    from navstack.costmap.layered_costmap import LayeredCostmap


class ObstacleLayerParams(LayerParams):
    """Nav2 ObstacleLayer parameters (names and defaults)."""

    footprint_clearing_enabled: bool = True
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 2.0
    combination_method: int = Field(1, ge=0, le=2)
    observation_sources: str | list[str] = ""
    track_unknown_space: bool | None = None
    """Defaults to the costmap's ``track_unknown_space``."""
    transform_tolerance: float = 0.2
    tf_filter_tolerance: float = 0.05
    tf_message_filter: bool = False
    """navstack: hold each scan up to ``tf_filter_tolerance`` for the transforms of its own
    instant (Nav2's obstacle layer always does, with a ``tf2_ros::MessageFilter``).  Off:
    a scan whose odometry is not in the TF buffer yet is dropped -- on the in-process bus
    that is a scan stamped at the same instant as an odometry sample still queued, more
    than half of them in some runs, all of them for seconds at a time.  Off by default
    (the parameter is navstack's); the packaged nav2_params.yaml and fleet turn it on
    (docs/command_path.md, "Clearance")."""
    unmapped_padding: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    """[m] navstack: mark a point the static layer's map does not explain as a disc of
    this radius (module docstring); 0 marks its cell only (Nav2)."""
    unmapped_distance: float = Field(0.15, ge=0.0, allow_inf_nan=False)
    """[m] navstack: a point this close to an occupied or unknown cell of the map (or off
    it) is explained and marked as in Nav2."""

    @field_validator("observation_sources")
    @classmethod
    def _split(cls, v: str | list[str]) -> str | list[str]:
        return v.split() if isinstance(v, str) else list(v)

    @property
    def source_names(self) -> list[str]:
        src = self.observation_sources
        return src.split() if isinstance(src, str) else list(src)


@register_layer("ObstacleLayer", nav2="nav2_costmap_2d::ObstacleLayer")
class ObstacleLayer(CostmapLayer):
    """Marks sensor returns LETHAL and clears free space by ray tracing."""

    params_model: ClassVar[type[LayerParams]] = ObstacleLayerParams
    clearable = True
    params: ObstacleLayerParams

    def __init__(self, name: str = "obstacle_layer", params: ObstacleLayerParams | None = None,
                 sources: dict[str, ObservationSourceParams] | None = None) -> None:
        super().__init__(name, params)
        sources = dict(sources or {})
        names = self.params.source_names or list(sources)
        unlisted = sorted(set(sources) - set(names))
        if unlisted:
            raise ConfigError(f"observation source '{unlisted[0]}' is configured but not "
                              "listed", key_path=f"{name}.observation_sources",
                              suggestion=f"add '{unlisted[0]}' to observation_sources")
        self.buffers: dict[str, ObservationBuffer] = {}
        for src in names:
            p = sources.get(src, ObservationSourceParams())
            if not p.topic:
                p = p.updated(topic=src)
            self.buffers[src] = ObservationBuffer(src, p)
        self._footprint_world: NDArray[np.float64] | None = None
        self._was_reset = False
        self._map_distance = MapDistance()
        self._disc = _disc_offsets(0.0, 1.0)

    @classmethod
    def from_mapping(cls, name: str, data: dict[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Nav2 YAML: layer keys plus one sub-dict per name in ``observation_sources``."""
        data = {k: v for k, v in (data or {}).items() if k != "plugin"}
        path = key_path or name
        raw = data.get("observation_sources", "")
        names = raw.split() if isinstance(raw, str) else [str(s) for s in raw]
        src_dicts = {n: data.pop(n) for n in names if n in data}
        params = cls.params_model.from_mapping(data, file=file, key_path=path)
        assert isinstance(params, ObstacleLayerParams)
        sources = {n: ObservationSourceParams.from_mapping(d, file=file,
                                                           key_path=f"{path}.{n}")
                   for n, d in src_dicts.items()}
        return cls(name, params, sources)

    # --- Layer hooks -----------------------------------------------------------------
    def initialize(self, layered: LayeredCostmap) -> None:
        track = self.params.track_unknown_space
        if track is None:
            track = layered.track_unknown_space
        self.default_value = NO_INFORMATION if track else FREE_SPACE
        super().initialize(layered)

    def reset(self) -> None:
        super().reset()
        for buf in self.buffers.values():
            buf.reset_last_updated(self.now)
        self._was_reset = True

    def is_current(self, now: float | None = None) -> bool:
        t = now if now is not None else self._data_time()
        return all(b.is_current(t) for b in self.buffers.values())

    # --- sensor input ----------------------------------------------------------------
    def _buffer(self, source: str | None) -> ObservationBuffer:
        if source is None:
            if len(self.buffers) == 1:
                return next(iter(self.buffers.values()))
            raise ConfigError(f"layer '{self.name}' has {len(self.buffers)} observation "
                              "sources; pass source=<name>",
                              key_path=f"{self.name}.observation_sources")
        if source not in self.buffers:
            raise UnknownNameError(f"observation source of layer '{self.name}'", source,
                                   self.buffers)
        return self.buffers[source]

    def add_scan(self, scan: LaserScan, sensor_pose: Pose2D, sensor_z: float = 0.0,
                 source: str | None = None) -> Observation:
        """Buffer a laser scan taken at ``sensor_pose`` (costmap frame), height ``sensor_z``."""
        buf = self._buffer(source)
        res = self.master.resolution if self.layered is not None else 0.0
        obs = observation_from_scan(scan, sensor_pose, sensor_z, buf.params,
                                    buf.params.raytrace_max_range + 1.5 * res)
        buf.add(obs)
        return obs

    def add_points(self, xyz: ArrayLike, sensor_origin: ArrayLike, source: str | None = None,
                   stamp: float = 0.0) -> Observation:
        """Buffer ``(N, 3)`` points in the costmap frame seen from ``sensor_origin`` (x, y, z)."""
        buf = self._buffer(source)
        obs = observation_from_points(xyz, sensor_origin, buf.params, stamp)
        buf.add(obs)
        return obs

    def clear_observations(self) -> None:
        for buf in self.buffers.values():
            buf.clear()

    def _data_time(self) -> float | None:
        stamps = [b.last_updated for b in self.buffers.values() if b.last_updated is not None]
        return max(stamps) if stamps else None

    def _observations(self, marking: bool) -> list[Observation]:
        now = self.now if self.now is not None else self._data_time()
        out: list[Observation] = []
        for buf in self.buffers.values():
            if (buf.params.marking if marking else buf.params.clearing):
                out.extend(buf.observations(now))
        return out

    # --- update cycle ----------------------------------------------------------------
    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        cm = self.costmap
        if self.layered is not None and self.layered.rolling_window:
            cm.update_origin(robot_x - cm.size_x_m / 2.0, robot_y - cm.size_y_m / 2.0)
        if not self.enabled:
            return bounds
        self.use_extra_bounds(bounds)
        self.current = self.is_current(self.now)
        for obs in self._observations(marking=False):
            self._raytrace(obs, bounds)
        for obs in self._observations(marking=True):
            self._mark(obs, bounds)
        if self.params.footprint_clearing_enabled and self.layered is not None:
            self._footprint_world = transform_footprint(self.layered.footprint,
                                                        (robot_x, robot_y, robot_yaw))
            bounds.touch_points(self._footprint_world)
        return bounds

    def _mark(self, obs: Observation, bounds: Bounds) -> None:
        p = obs.points
        if not len(p):
            return
        z = p[:, 2]
        d2 = np.sum((p - obs.origin) ** 2, axis=1)
        keep = ((z >= self.params.min_obstacle_height) & (z <= self.params.max_obstacle_height)
                & (d2 < obs.obstacle_max_range ** 2) & (d2 >= obs.obstacle_min_range ** 2))
        mx, my, inside = self.costmap.world_to_map_array(p[keep, :2])
        self.costmap.data[my[inside], mx[inside]] = LETHAL_OBSTACLE
        bounds.touch_points(p[keep][inside, :2])
        if self.params.unmapped_padding > 0.0:
            self._pad_unmapped(p[keep, :2], bounds)

    def _pad_unmapped(self, xy: NDArray[np.float64], bounds: Bounds) -> None:
        """Mark a disc of ``unmapped_padding`` around each point the map does not explain."""
        static = self._static_layer()
        if static is None or not len(xy):
            return
        grid = static._grid
        if grid is None:
            return
        if self._map_distance.grid is not grid:
            self._map_distance.update(grid)
        xy_map = xy if static.map_in_costmap is None else \
            static.map_in_costmap.inverse().transform_points(xy)
        far = self._map_distance.beyond(xy_map, self.params.unmapped_distance)
        if not far.any():
            return
        cm = self.costmap
        r = self.params.unmapped_padding
        if self._disc[1] != (r, cm.resolution):
            self._disc = _disc_offsets(r, cm.resolution)
        offsets = self._disc[0]
        mx, my, inside = cm.world_to_map_array(xy[far])
        cx = (mx[inside, None] + offsets[None, :, 0]).ravel()
        cy = (my[inside, None] + offsets[None, :, 1]).ravel()
        ok = (cx >= 0) & (cy >= 0) & (cx < cm.size_x) & (cy < cm.size_y)
        cm.data[cy[ok], cx[ok]] = LETHAL_OBSTACLE
        pts = xy[far][inside]
        for dx, dy in ((-r, -r), (r, r)):
            bounds.touch_points(pts + np.array([dx, dy]))

    def _static_layer(self) -> Any:
        from navstack.costmap.static_layer import StaticLayer

        if self.layered is None:
            return None
        return next((lay for lay in self.layered.layers if isinstance(lay, StaticLayer)),
                    None)

    def _raytrace(self, obs: Observation, bounds: Bounds) -> None:
        cm = self.costmap
        ox, oy = float(obs.origin[0]), float(obs.origin[1])
        cell0 = cm.world_to_map(ox, oy)
        if cell0 is None:
            return  # Nav2: the sensor origin is off the map, nothing can be ray traced
        ends = np.concatenate([obs.points[:, :2], obs.clear_only[:, :2]])
        if not len(ends):
            return
        bounds.touch(ox, oy)
        wx, wy = clip_rays_to_map(ox, oy, ends[:, 0], ends[:, 1], cm.origin_x, cm.origin_y,
                                  cm.origin_x + cm.size_x_m, cm.origin_y + cm.size_y_m)
        mx, my, inside = cm.world_to_map_array(np.column_stack((wx, wy)))
        res = cm.resolution
        max_cells = float(int(obs.raytrace_max_range / res + 1e-9))
        min_cells = float(int(obs.raytrace_min_range / res + 1e-9))
        raytrace_lines(cm.data, cell0[0], cell0[1], np.ascontiguousarray(mx[inside]),
                       np.ascontiguousarray(my[inside]), max_cells, min_cells, FREE_SPACE)
        # Nav2 updateRaytraceBounds: touch each ray end, shortened to raytrace_max_range
        dx, dy = wx[inside] - ox, wy[inside] - oy
        full = np.hypot(dx, dy)
        long_enough = full >= obs.raytrace_min_range
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(full > 0, np.minimum(1.0, obs.raytrace_max_range / full), 1.0)
        ex = ox + dx * scale
        ey = oy + dy * scale
        bounds.touch_points(np.column_stack((ex[long_enough], ey[long_enough])))

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        if not self.enabled:
            return
        if not self.current and self._was_reset:
            self._was_reset = False
            self.current = True
        if self.params.footprint_clearing_enabled and self._footprint_world is not None:
            set_polygon_cost(self.costmap, self._footprint_world, FREE_SPACE)
        combine(self, master, window, self.params.combination_method)


def _disc_offsets(radius: float, resolution: float
                  ) -> tuple[NDArray[np.int64], tuple[float, float]]:
    """Cell offsets ``(K, 2)`` (dx, dy) whose centres lie within ``radius`` of a cell's
    centre, and the ``(radius, resolution)`` they were made for."""
    n = int(radius / resolution)
    d = np.arange(-n, n + 1)
    dx, dy = np.meshgrid(d, d)
    inside = (dx * dx + dy * dy) * resolution * resolution <= radius * radius + 1e-12
    return np.column_stack((dx[inside], dy[inside])).astype(np.int64), (radius, resolution)


class VoxelLayerParams(ObstacleLayerParams):
    """Nav2 VoxelLayer parameters; the voxel column is collapsed (see :class:`VoxelLayer`)."""

    origin_z: float = 0.0
    z_resolution: float = Field(0.2, gt=0.0)
    z_voxels: int = Field(10, ge=1, le=16)
    unknown_threshold: int = Field(15, ge=0)
    mark_threshold: int = Field(0, ge=0)
    publish_voxel_map: bool = False


@register_layer("VoxelLayer", nav2="nav2_costmap_2d::VoxelLayer")
class VoxelLayer(ObstacleLayer):
    """``nav2_costmap_2d::VoxelLayer`` served by the 2D obstacle layer.

    Heights are honoured at marking time: a point marks only if it lies inside the voxel
    column ``[origin_z, origin_z + z_voxels * z_resolution)`` and within the layer's
    ``min/max_obstacle_height``; with ``mark_threshold: 0`` (Nav2's default) this gives the
    same 2D result as the voxel grid.  Clearing is 2D: a ray clears the whole column of
    each cell it crosses, so an obstacle seen at one height is cleared by a ray passing
    below/above it - more aggressive than Nav2's 3D ray tracing.  ``unknown_threshold``
    and ``publish_voxel_map`` are accepted for compatibility and have no effect.
    """

    params_model: ClassVar[type[LayerParams]] = VoxelLayerParams
    params: VoxelLayerParams

    def _mark(self, obs: Observation, bounds: Bounds) -> None:
        top = self.params.origin_z + self.params.z_voxels * self.params.z_resolution
        z = obs.points[:, 2]
        in_column = (z >= self.params.origin_z) & (z < top)
        if in_column.all():
            super()._mark(obs, bounds)
            return
        trimmed = Observation(obs.stamp, obs.origin, obs.points[in_column], obs.clear_only,
                              obs.obstacle_max_range, obs.obstacle_min_range,
                              obs.raytrace_max_range, obs.raytrace_min_range)
        super()._mark(trimmed, bounds)
