"""LayeredCostmap: the master grid and its ordered plugins (Nav2 ``LayeredCostmap``).

``update_map(robot_x, robot_y, robot_yaw)`` runs one Nav2 update cycle:

1. rolling window: the master grid is re-centred on the robot (``Costmap2D.update_origin``,
   whole cells, overlapping cells keep their world position);
2. every enabled plugin, then every filter, grows the world bounds with
   ``update_bounds(robot_x, robot_y, robot_yaw, bounds)``;
3. the bounds become a cell window (clamped to the grid, Nav2
   ``worldToMapEnforceBounds`` plus one cell), which is reset to the default value
   (NO_INFORMATION when tracking unknown space, else FREE);
4. every enabled plugin, then every filter, writes into the window with
   ``update_costs(master, window)``.

The master grid object is updated in place, so planners and controllers may hold
``layered.costmap``.  ``from_nav2`` builds the whole stack from the dict under
``<name>: ros__parameters:`` of a Nav2 params file; :mod:`navstack.costmap.builders`
documents the global and local costmap set-ups.

Clearing follows Nav2's ClearCostmap services: :meth:`LayeredCostmap.clear_around`
(ClearCostmapAroundRobot) resets the clearable layers (obstacle/voxel) inside the square
of side ``reset_distance`` centred on the robot, :meth:`LayeredCostmap.clear_except_region`
(ClearCostmapExceptRegion) everywhere else, and :meth:`LayeredCostmap.clear_all`
(ClearEntireCostmap) resets the master and every layer.  All take effect at the next
``update_map``.  An observation still held by a source (``observation_persistence``)
is re-applied then, as in Nav2.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from numpy.typing import ArrayLike
from pydantic import Field

from navstack.core.errors import ConfigError, UnknownNameError
from navstack.core.params import Params
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import FREE_SPACE, NO_INFORMATION, Costmap2D
from navstack.costmap.footprint import make_footprint
from navstack.costmap.inflation_layer import InflationLayer
from navstack.costmap.layer import Bounds, CellWindow, CostmapLayer, Layer


class Costmap2DParams(Params):
    """Nav2 ``Costmap2DROS`` parameters (names and defaults).

    Runtime-only keys (frames, frequencies, topics, QoS) are accepted so Nav2 files load;
    the runtime layer uses them.
    """

    width: float = 5.0
    height: float = 5.0
    resolution: float = 0.1
    origin_x: float = 0.0
    origin_y: float = 0.0
    rolling_window: bool = False
    track_unknown_space: bool = False
    footprint: str | list[list[float]] = "[]"
    robot_radius: float = 0.1
    footprint_padding: float = 0.01
    lethal_cost_threshold: int = 100
    unknown_cost_value: int = 255
    trinary_costmap: bool = True
    use_maximum: bool = False
    plugins: list[str] = Field(
        default_factory=lambda: ["static_layer", "obstacle_layer", "inflation_layer"])
    filters: list[str] = Field(default_factory=list)
    clearable_layers: list[str] = Field(
        default_factory=lambda: ["obstacle_layer", "voxel_layer", "range_layer"])
    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    update_frequency: float = 5.0
    publish_frequency: float = 1.0
    transform_tolerance: float = 0.3
    always_send_full_costmap: bool = False
    map_topic: str = "map"
    observation_sources: str = ""
    use_sim_time: bool = False
    map_vis_z: float = 0.0
    initial_transform_timeout: float = 60.0
    introspection_mode: str = "disabled"
    allow_parameter_qos_overrides: bool = True
    subscribe_to_stamped_footprint: bool = False


class LayeredCostmap:
    """Master ``Costmap2D`` plus ordered layers; see the module docstring."""

    def __init__(self, size_x: int, size_y: int, resolution: float,
                 origin: tuple[float, float] = (0.0, 0.0), frame_id: str = "map",
                 rolling_window: bool = False, track_unknown_space: bool = False,
                 footprint: Footprint | None = None, *, lethal_cost_threshold: int = 100,
                 unknown_cost_value: int = 255, trinary_costmap: bool = True,
                 use_maximum: bool = False, clearable_layers: Iterable[str] | None = None,
                 update_frequency: float = 5.0) -> None:
        self.rolling_window = rolling_window
        self.track_unknown_space = track_unknown_space
        self.lethal_cost_threshold = lethal_cost_threshold
        self.unknown_cost_value = unknown_cost_value
        self.trinary_costmap = trinary_costmap
        self.use_maximum = use_maximum
        self.clearable_layers = None if clearable_layers is None else set(clearable_layers)
        self.update_frequency = update_frequency
        default = NO_INFORMATION if track_unknown_space else FREE_SPACE
        self.costmap = Costmap2D(int(size_x), int(size_y), float(resolution),
                                 float(origin[0]), float(origin[1]), frame_id, default)
        self.footprint = footprint if footprint is not None else make_footprint()
        self.plugins: list[Layer] = []
        self.filters: list[Layer] = []
        self.window: CellWindow | None = None
        self.initialized = False
        self.params: Costmap2DParams | None = None
        """The validated Nav2 parameters when built with :meth:`from_nav2`."""

    # --- construction --------------------------------------------------------------------
    @classmethod
    def from_nav2(cls, params: Mapping[str, Any], footprint: Footprint | None = None, *,
                  file: str = "") -> LayeredCostmap:
        """Build from the dict under ``<costmap>: <costmap>: ros__parameters:``.

        ``footprint`` overrides the ``footprint``/``robot_radius`` keys.  Plugin dicts not
        listed in ``plugins``/``filters`` are ignored, as Nav2 ignores them.
        """
        from navstack.costmap.plugins import (
            NAV2_DEFAULT_PLUGINS,
            NAV2_DEFAULT_TYPES,
            layer_from_nav2,
        )

        p = dict(params)
        if "ros__parameters" in p and isinstance(p["ros__parameters"], Mapping):
            p = dict(p["ros__parameters"])
        plugin_names = [str(n) for n in p.get("plugins", NAV2_DEFAULT_PLUGINS)]
        filter_names = [str(n) for n in p.get("filters", [])]
        layer_dicts = {k: v for k, v in p.items() if isinstance(v, Mapping)}
        scalars = {k: v for k, v in p.items() if k not in layer_dicts}
        cp = Costmap2DParams.from_mapping(scalars, file=file)
        fp = footprint if footprint is not None else _footprint(cp, file)
        size_x = math.floor(cp.width / cp.resolution + 1e-9)
        size_y = math.floor(cp.height / cp.resolution + 1e-9)
        if size_x <= 0 or size_y <= 0:
            raise ConfigError(f"costmap of {cp.width} x {cp.height} m at {cp.resolution} m "
                              "has no cells", file=file, key_path="width",
                              suggestion="width and height must be at least one resolution")
        lc = cls(size_x, size_y, cp.resolution, (cp.origin_x, cp.origin_y), cp.global_frame,
                 cp.rolling_window, cp.track_unknown_space, fp,
                 lethal_cost_threshold=cp.lethal_cost_threshold,
                 unknown_cost_value=cp.unknown_cost_value,
                 trinary_costmap=cp.trinary_costmap, use_maximum=cp.use_maximum,
                 clearable_layers=cp.clearable_layers if "clearable_layers" in p else None,
                 update_frequency=cp.update_frequency)
        lc.params = cp
        use_defaults = plugin_names == NAV2_DEFAULT_PLUGINS
        for name in plugin_names:
            default_type = NAV2_DEFAULT_TYPES.get(name) if use_defaults else None
            lc.add_plugin(layer_from_nav2(name, _dict(layer_dicts.get(name)), file=file,
                                          default_type=default_type))
        for name in filter_names:
            lc.add_filter(layer_from_nav2(name, _dict(layer_dicts.get(name)), file=file))
        return lc

    def add_plugin(self, layer: Layer) -> Layer:
        self._check_name(layer.name)
        self.plugins.append(layer)
        layer.initialize(self)
        return layer

    def add_filter(self, layer: Layer) -> Layer:
        self._check_name(layer.name)
        self.filters.append(layer)
        layer.initialize(self)
        return layer

    def _check_name(self, name: str) -> None:
        if any(layer.name == name for layer in self.layers):
            raise ConfigError(f"a layer named '{name}' is already in this costmap",
                              key_path="plugins", suggestion="give each layer a unique name")

    @property
    def layers(self) -> list[Layer]:
        """Plugins followed by filters, in update order."""
        return [*self.plugins, *self.filters]

    def layer(self, name: str) -> Layer:
        for layer in self.layers:
            if layer.name == name:
                return layer
        raise UnknownNameError("costmap layer", name, [lay.name for lay in self.layers])

    # --- geometry ------------------------------------------------------------------------
    @property
    def inscribed_radius(self) -> float:
        return self.footprint.inscribed_radius

    @property
    def circumscribed_radius(self) -> float:
        return self.footprint.circumscribed_radius

    def set_footprint(self, footprint: Footprint) -> None:
        """Replace the (padded) footprint; layers recompute radius-dependent caches."""
        self.footprint = footprint
        for layer in self.layers:
            layer.on_footprint_changed()

    def resize_map(self, size_x: int, size_y: int, resolution: float, origin_x: float,
                   origin_y: float) -> None:
        """Resize the master and every layer (Nav2 ``resizeMap``), keeping the costs of
        the cells the old and new grids share (a SLAM map that grows)."""
        self.costmap.resize_map(size_x, size_y, resolution, origin_x, origin_y, keep=True)
        for layer in self.layers:
            layer.match_size()

    def set_pose_covariance(self, cov_xy: ArrayLike) -> None:
        """Pass the robot's 2x2 position covariance to uncertainty-aware inflation layers."""
        for layer in self.layers:
            if isinstance(layer, InflationLayer):
                layer.set_pose_covariance(cov_xy)

    # --- update ------------------------------------------------------------------------
    def update_map(self, robot_x: float, robot_y: float, robot_yaw: float,
                   now: float | None = None) -> CellWindow | None:
        """One Nav2 update cycle; returns the updated cell window (``None``: nothing)."""
        cm = self.costmap
        if self.rolling_window:
            cm.update_origin(robot_x - cm.size_x_m / 2.0, robot_y - cm.size_y_m / 2.0)
        bounds = Bounds()
        for layer in self.layers:
            layer.now = now
            if layer.enabled:
                bounds = layer.update_bounds(robot_x, robot_y, robot_yaw, bounds)
            elif self.rolling_window and isinstance(layer, CostmapLayer):
                lc = layer.costmap
                lc.update_origin(robot_x - lc.size_x_m / 2.0, robot_y - lc.size_y_m / 2.0)
        window = self._window(bounds)
        if window is None:
            return None
        cm.reset_map(*window)
        for layer in self.layers:
            if layer.enabled:
                layer.update_costs(cm, window)
        self.window = window
        self.initialized = True
        return window

    def _window(self, b: Bounds) -> CellWindow | None:
        if b.empty:
            return None
        cm = self.costmap

        def enforce(wx: float, wy: float) -> tuple[int, int]:
            fx = (wx - cm.origin_x) / cm.resolution
            fy = (wy - cm.origin_y) / cm.resolution
            mx = 0 if fx < 0 else (cm.size_x - 1 if fx >= cm.size_x else int(fx))
            my = 0 if fy < 0 else (cm.size_y - 1 if fy >= cm.size_y else int(fy))
            return mx, my

        x0, y0 = enforce(b.min_x, b.min_y)
        xn, yn = enforce(b.max_x, b.max_y)
        x0, y0 = max(0, x0), max(0, y0)
        xn, yn = min(cm.size_x, xn + 1), min(cm.size_y, yn + 1)
        if xn <= x0 or yn <= y0:
            return None
        return CellWindow(x0, y0, xn, yn)

    def is_current(self, now: float | None = None) -> bool:
        """Every enabled layer has fresh data (Nav2 ``isCurrent``)."""
        return all(layer.is_current(now) for layer in self.layers if layer.enabled)

    # --- clearing (Nav2 ClearCostmapService) ---------------------------------------------
    def clear_all(self) -> None:
        """ClearEntireCostmap: reset the master and every layer."""
        self.costmap.reset()
        for layer in self.layers:
            layer.reset()

    def clear_around(self, robot_xy: tuple[float, float], reset_distance: float) -> None:
        """ClearCostmapAroundRobot: clear clearable layers inside the square of side
        ``reset_distance`` [m] centred on ``robot_xy``."""
        self._clear_region(robot_xy, reset_distance, invert=False)

    def clear_except_region(self, robot_xy: tuple[float, float],
                            reset_distance: float) -> None:
        """ClearCostmapExceptRegion: clear clearable layers outside that square."""
        self._clear_region(robot_xy, reset_distance, invert=True)

    def _clear_region(self, robot_xy: tuple[float, float], reset_distance: float,
                      invert: bool) -> None:
        if reset_distance < 0.0:
            raise ValueError(f"reset_distance must be >= 0, got {reset_distance}")
        for layer in self.layers:
            if not (layer.clearable and isinstance(layer, CostmapLayer)):
                continue
            if self.clearable_layers is not None and layer.name not in self.clearable_layers:
                continue
            cm = layer.costmap
            sx = robot_xy[0] - reset_distance / 2.0
            sy = robot_xy[1] - reset_distance / 2.0
            # Nav2 worldToMapNoBounds truncates toward zero
            start_x = int((sx - cm.origin_x) / cm.resolution)
            start_y = int((sy - cm.origin_y) / cm.resolution)
            end_x = int((sx + reset_distance - cm.origin_x) / cm.resolution)
            end_y = int((sy + reset_distance - cm.origin_y) / cm.resolution)
            layer.clear_area(start_x, start_y, end_x, end_y, invert)


def _footprint(cp: Costmap2DParams, file: str) -> Footprint:
    try:
        return make_footprint(cp.footprint, cp.robot_radius, cp.footprint_padding)
    except ConfigError as exc:
        raise ConfigError(exc.reason, file=file, key_path=exc.key_path,
                          suggestion=exc.suggestion) from None


def _dict(m: Mapping[str, Any] | None) -> dict[str, Any] | None:
    return None if m is None else dict(m)
