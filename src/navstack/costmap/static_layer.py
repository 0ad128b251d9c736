"""Static layer (Nav2 ``nav2_costmap_2d::StaticLayer``): the occupancy map as costs.

Map values are translated with the costmap-level parameters (Nav2 ``interpretValue``):

* ``value == unknown_cost_value`` (255, i.e. the map's ``-1`` read as an unsigned byte)
  -> NO_INFORMATION if ``track_unknown_space`` else FREE_SPACE;
* ``value >= lethal_cost_threshold`` (100) -> LETHAL_OBSTACLE;
* otherwise FREE_SPACE when ``trinary_costmap``, else ``int(value / threshold * 254)``.

Geometry: on a non-rolling costmap, a map whose size/resolution/origin differ from the
master resizes the master to the map (Nav2 ``processMap``; the global costmap takes the
map's extent).  On a rolling costmap, or when the map is rotated or lives in another
frame (``map_in_costmap``, the pose of the map frame in the costmap frame, passed
explicitly), every master cell of the update window takes the map cell under its centre
(nearest neighbour).  ``use_maximum`` (costmap level) switches from Nav2's
"true overwrite" to max-combination.  ``footprint_clearing_enabled`` frees the cells under
the robot footprint in the output; ``restore_cleared_footprint: false`` also erases them
from the stored map.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from navstack.core.msgs import MapMetaData, OccupancyGrid, Pose2D
from navstack.costmap.costmap_2d import (
    FREE_SPACE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)
from navstack.costmap.footprint import polygon_cells, transform_footprint
from navstack.costmap.grid_sampling import points_to_cells, sample_window
from navstack.costmap.layer import Bounds, CellWindow, Layer, LayerParams, register_layer

if TYPE_CHECKING:
    from navstack.costmap.layered_costmap import LayeredCostmap


class StaticLayerParams(LayerParams):
    """Nav2 StaticLayer parameters (names and defaults)."""

    subscribe_to_updates: bool = False
    map_subscribe_transient_local: bool = True
    transform_tolerance: float = Field(0.0, ge=0.0)
    map_topic: str = ""
    footprint_clearing_enabled: bool = False
    restore_cleared_footprint: bool = True


def translate_occupancy(data: ArrayLike, lethal_cost_threshold: int = 100,
                        unknown_cost_value: int = 255, trinary_costmap: bool = True,
                        track_unknown_space: bool = False) -> NDArray[np.uint8]:
    """Vectorised Nav2 ``StaticLayer::interpretValue`` of int8 occupancy values."""
    v = np.asarray(data).astype(np.int16) & 0xFF  # -1 -> 255, as Nav2's unsigned char
    threshold = max(0, min(int(lethal_cost_threshold), 100))
    unknown_code = int(unknown_cost_value) & 0xFF
    if trinary_costmap:
        rest = np.full(v.shape, FREE_SPACE, np.int16)
    else:
        rest = np.floor(v / max(threshold, 1) * LETHAL_OBSTACLE).astype(np.int16)
    out = np.where(v >= threshold, LETHAL_OBSTACLE, rest)
    out = np.where(v == unknown_code, NO_INFORMATION if track_unknown_space else FREE_SPACE,
                   out)
    return out.astype(np.uint8)


@register_layer("StaticLayer", nav2="nav2_costmap_2d::StaticLayer")
class StaticLayer(Layer):
    """Copies the translated map into the master grid."""

    params_model = StaticLayerParams
    params: StaticLayerParams

    def __init__(self, name: str = "static_layer",
                 params: StaticLayerParams | None = None) -> None:
        super().__init__(name, params)
        self.map_costs: NDArray[np.uint8] | None = None
        self.map_info: MapMetaData | None = None
        self.map_frame = ""
        self.map_in_costmap: Pose2D | None = None
        self._has_updated_data = False
        self._extra = Bounds()
        self._footprint_world: NDArray[np.float64] | None = None
        self._grid: OccupancyGrid | None = None

    def initialize(self, layered: LayeredCostmap) -> None:
        super().initialize(layered)
        if self._grid is not None:  # a map set before attaching: translate with its params
            self.set_map(self._grid, self.map_in_costmap)

    # --- map input ---------------------------------------------------------------------
    def set_map(self, grid: OccupancyGrid, map_in_costmap: Pose2D | None = None) -> None:
        """Load ``grid`` (Nav2 ``incomingMap``); ``map_in_costmap`` = pose of the map frame
        in the costmap frame when they differ (``None``: same frame)."""
        self._grid = grid
        data = np.asarray(grid.data)
        info = grid.info
        if data.shape != (info.height, info.width):
            data = data.reshape(info.height, info.width)
        lay = self.layered
        self.map_costs = translate_occupancy(
            data, lay.lethal_cost_threshold if lay else 100,
            lay.unknown_cost_value if lay else 255, lay.trinary_costmap if lay else True,
            lay.track_unknown_space if lay else False)
        self.map_info = info
        self.map_frame = grid.header.frame_id
        self.map_in_costmap = map_in_costmap
        self._has_updated_data = True
        self.current = True
        if lay is not None and not lay.rolling_window and self._axis_aligned():
            m = lay.costmap
            o = info.origin.position
            if (m.size_x, m.size_y, m.resolution, m.origin_x, m.origin_y) != (
                    info.width, info.height, info.resolution, o.x, o.y):
                lay.resize_map(info.width, info.height, info.resolution, o.x, o.y)

    def update_region(self, x: int, y: int, data: ArrayLike) -> None:
        """Apply a map update patch (Nav2 ``incomingUpdate``, ``subscribe_to_updates``):
        int8 ``data`` of shape (h, w) replaces cells starting at column ``x``, row ``y``."""
        if self.map_costs is None or self.map_info is None:
            raise RuntimeError(f"layer '{self.name}': update_region before set_map")
        patch = np.asarray(data)
        h, w = patch.shape
        if x < 0 or y < 0 or x + w > self.map_info.width or y + h > self.map_info.height:
            raise ValueError(f"update patch {w}x{h} at ({x}, {y}) exceeds the map "
                             f"{self.map_info.width}x{self.map_info.height}")
        lay = self.layered
        self.map_costs[y:y + h, x:x + w] = translate_occupancy(
            patch, lay.lethal_cost_threshold if lay else 100,
            lay.unknown_cost_value if lay else 255, lay.trinary_costmap if lay else True,
            lay.track_unknown_space if lay else False)
        res = self.map_info.resolution
        o = self.map_info.origin.position
        self._extra.touch(o.x + x * res, o.y + y * res)
        self._extra.touch(o.x + (x + w) * res, o.y + (y + h) * res)

    def _axis_aligned(self) -> bool:
        t = self.map_in_costmap
        yaw = self.map_info.origin.orientation.yaw if self.map_info else 0.0
        identity = t is None or (t.x == 0.0 and t.y == 0.0 and t.theta == 0.0)
        return identity and abs(yaw) < 1e-12

    def _map_corners(self) -> NDArray[np.float64]:
        assert self.map_info is not None
        info = self.map_info
        o = info.origin.to_pose2d()
        w, h = info.width * info.resolution, info.height * info.resolution
        local = np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])
        pts = o.transform_points(local)
        return self.map_in_costmap.transform_points(pts) if self.map_in_costmap else pts

    # --- Layer hooks -----------------------------------------------------------------
    def reset(self) -> None:
        super().reset()
        self._has_updated_data = True
        self.current = self.map_costs is not None

    def is_current(self, now: float | None = None) -> bool:
        return self.map_costs is not None

    def add_extra_bounds(self, min_x: float, min_y: float, max_x: float, max_y: float) -> None:
        self._extra.touch(min_x, min_y)
        self._extra.touch(max_x, max_y)

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        if self.map_costs is None:
            return bounds
        rolling = self.layered is not None and self.layered.rolling_window
        if not rolling and not (self._has_updated_data or not self._extra.empty):
            return bounds
        bounds.union(self._extra)
        self._extra = Bounds()
        if self._has_updated_data or rolling:
            bounds.touch_points(self._map_corners())
        self._has_updated_data = False
        if self.params.footprint_clearing_enabled and self.layered is not None:
            self._footprint_world = transform_footprint(self.layered.footprint,
                                                        (robot_x, robot_y, robot_yaw))
            bounds.touch_points(self._footprint_world)
        return bounds

    def _window_values(self, master: Costmap2D, w: CellWindow
                       ) -> tuple[NDArray[np.uint8], NDArray[np.bool_]]:
        assert self.map_costs is not None and self.map_info is not None
        info = self.map_info
        res_ok = abs(info.resolution - master.resolution) < 1e-12
        if res_ok and self._axis_aligned():
            fx = (info.origin.position.x - master.origin_x) / master.resolution
            fy = (info.origin.position.y - master.origin_y) / master.resolution
            if abs(fx - round(fx)) < 1e-6 and abs(fy - round(fy)) < 1e-6:
                ox, oy = round(fx), round(fy)  # map cell (c, r) == master (c + ox, r + oy)
                vals = np.zeros((w.max_j - w.min_j, w.max_i - w.min_i), np.uint8)
                inside = np.zeros(vals.shape, bool)
                c0, c1 = max(w.min_i, ox), min(w.max_i, ox + info.width)
                r0, r1 = max(w.min_j, oy), min(w.max_j, oy + info.height)
                if c0 < c1 and r0 < r1:
                    sub = (slice(r0 - w.min_j, r1 - w.min_j), slice(c0 - w.min_i, c1 - w.min_i))
                    vals[sub] = self.map_costs[r0 - oy:r1 - oy, c0 - ox:c1 - ox]
                    inside[sub] = True
                return vals, inside
        vals_g, inside = sample_window(self.map_costs, info, master.origin_x, master.origin_y,
                                       master.resolution,
                                       (w.min_i, w.min_j, w.max_i, w.max_j),
                                       self.map_in_costmap)
        return vals_g.astype(np.uint8), inside

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        if not self.enabled or self.map_costs is None or window.empty:
            return
        vals, inside = self._window_values(master, window)
        if self.params.footprint_clearing_enabled and self._footprint_world is not None:
            xs, ys = polygon_cells(master, self._footprint_world)
            keep = ((xs >= window.min_i) & (xs < window.max_i) & (ys >= window.min_j)
                    & (ys < window.max_j))
            vals[ys[keep] - window.min_j, xs[keep] - window.min_i] = FREE_SPACE
            if not self.params.restore_cleared_footprint:
                self._erase_from_map(master, xs, ys)
        dst = master.data[window.slices]
        use_max = self.layered.use_maximum if self.layered is not None else False
        if use_max:
            take = inside & (vals != NO_INFORMATION) & ((dst == NO_INFORMATION) | (dst < vals))
        else:
            take = inside
        dst[take] = vals[take]
        self.current = True

    def _erase_from_map(self, master: Costmap2D, xs: NDArray[np.int64],
                        ys: NDArray[np.int64]) -> None:
        assert self.map_costs is not None and self.map_info is not None
        centres = np.column_stack((master.origin_x + (xs + 0.5) * master.resolution,
                                   master.origin_y + (ys + 0.5) * master.resolution))
        col, row, inside = points_to_cells(centres, self.map_info, self.map_in_costmap)
        self.map_costs[row[inside], col[inside]] = FREE_SPACE
