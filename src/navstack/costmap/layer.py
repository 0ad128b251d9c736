"""Costmap layer plugin interface (Nav2 ``nav2_costmap_2d::Layer`` / ``CostmapLayer``).

Every update cycle :class:`~navstack.costmap.layered_costmap.LayeredCostmap` asks each
enabled layer, in order, to grow a world-frame :class:`Bounds` box with
``update_bounds(robot_x, robot_y, robot_yaw, bounds)`` (the region whose cost it may have
changed), converts the union to a :class:`CellWindow`, resets that window of the master
grid and then calls ``update_costs(master, window)`` on each layer in the same order.

:class:`CostmapLayer` is a layer that keeps its own grid (static, obstacle) and writes it
into the master with one of Nav2's combination methods:

* ``true_overwrite`` - copy every cell, ``NO_INFORMATION`` included (static layer default);
* ``overwrite`` - copy every known cell;
* ``max`` - ``max(master, layer)`` over known layer cells, an unknown master cell is
  always overwritten (obstacle layer default, ``combination_method: 1``);
* ``max_without_unknown_overwrite`` - as ``max`` but unknown master cells are left
  unknown (``combination_method: 2``);
* ``addition`` - ``master + layer`` capped at ``MAX_NON_OBSTACLE``.

:class:`Layer` is the costmap plugin interface (Nav2 keeps ``Layer`` in
``nav2_costmap_2d`` too, not in ``nav2_core``): a subclass sets ``params_model`` and
overrides the hooks, and :func:`register_layer` registers it in :data:`COSTMAP_LAYERS`
under its name and Nav2 type, so a costmap's ``plugins`` can name it::

    @register_layer("MyLayer", nav2="my_pkg::MyLayer")
    class MyLayer(Layer):
        params_model = MyLayerParams
        def update_costs(self, master, window): ...
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple, Self

import numpy as np
from numpy.typing import NDArray

from navstack.core.params import Params
from navstack.core.registry import ClassRegistry, builtin_table
from navstack.costmap.costmap_2d import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)

if TYPE_CHECKING:
    from navstack.costmap.layered_costmap import LayeredCostmap


@dataclass
class Bounds:
    """An axis-aligned world-frame box ``[min_x, max_x] x [min_y, max_y]``; empty by default."""

    min_x: float = math.inf
    min_y: float = math.inf
    max_x: float = -math.inf
    max_y: float = -math.inf

    @property
    def empty(self) -> bool:
        return self.min_x > self.max_x or self.min_y > self.max_y

    def touch(self, x: float, y: float) -> None:
        """Grow to include the point (Nav2 ``CostmapLayer::touch``)."""
        self.min_x = min(self.min_x, x)
        self.min_y = min(self.min_y, y)
        self.max_x = max(self.max_x, x)
        self.max_y = max(self.max_y, y)

    def touch_points(self, xy: NDArray[np.float64]) -> None:
        """Grow to include every row of an ``(N, 2)`` array."""
        if len(xy):
            self.touch(float(xy[:, 0].min()), float(xy[:, 1].min()))
            self.touch(float(xy[:, 0].max()), float(xy[:, 1].max()))

    def union(self, other: Bounds) -> None:
        if not other.empty:
            self.touch(other.min_x, other.min_y)
            self.touch(other.max_x, other.max_y)

    def copy(self) -> Bounds:
        return Bounds(self.min_x, self.min_y, self.max_x, self.max_y)

    @staticmethod
    def everything() -> Bounds:
        return Bounds(-math.inf, -math.inf, math.inf, math.inf)


class CellWindow(NamedTuple):
    """Half-open cell window ``[min_i, max_i) x [min_j, max_j)`` of the master grid."""

    min_i: int
    min_j: int
    max_i: int
    max_j: int

    @property
    def slices(self) -> tuple[slice, slice]:
        """Index ``data[window.slices]`` (rows are y)."""
        return slice(self.min_j, self.max_j), slice(self.min_i, self.max_i)

    @property
    def empty(self) -> bool:
        return self.max_i <= self.min_i or self.max_j <= self.min_j


class LayerParams(Params):
    """Parameters every layer has."""

    enabled: bool = True


class Layer:
    """Base class of costmap plugins (Nav2 ``nav2_costmap_2d::Layer``).

    Subclasses set ``params_model`` (a :class:`LayerParams` subclass: the layer's YAML
    section) and override the hooks; construction is ``cls(name, params)``.
    """

    params_model: ClassVar[type[LayerParams]] = LayerParams
    clearable: ClassVar[bool] = False
    """Whether Nav2's clear-costmap services reset this layer (obstacle-type layers)."""

    def __init__(self, name: str, params: LayerParams | None = None) -> None:
        self.name = name
        self.params = params if params is not None else self.params_model()
        self.enabled = self.params.enabled
        self.layered: LayeredCostmap | None = None
        self.current = False
        self.now: float | None = None
        """Time of the current update [s], set by ``LayeredCostmap.update_map(now=...)``."""

    @classmethod
    def from_mapping(cls, name: str, data: dict[str, Any] | None, *, file: str = "",
                     key_path: str = "") -> Self:
        """Build from a Nav2 YAML plugin dict (the ``plugin`` key is ignored here)."""
        mapping = {k: v for k, v in (data or {}).items() if k != "plugin"}
        return cls(name, cls.params_model.from_mapping(mapping, file=file,
                                                      key_path=key_path or name))

    # --- lifecycle ---------------------------------------------------------------------
    def initialize(self, layered: LayeredCostmap) -> None:
        """Attach to ``layered`` (Nav2 ``onInitialize``) and size any own grid."""
        self.layered = layered
        self.match_size()

    @property
    def master(self) -> Costmap2D:
        if self.layered is None:
            raise RuntimeError(f"layer '{self.name}' is not attached to a LayeredCostmap; "
                               "add it with LayeredCostmap.add_plugin()")
        return self.layered.costmap

    def match_size(self) -> None:
        """Called after the master grid was resized."""

    def on_footprint_changed(self) -> None:
        """Called after ``LayeredCostmap.set_footprint``."""

    def reset(self) -> None:
        """Forget accumulated state (Nav2 ``reset``; used by clear-entirely)."""
        self.current = False

    def is_current(self, now: float | None = None) -> bool:
        return self.current

    # --- update cycle ----------------------------------------------------------------
    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        return bounds

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        """Write this layer's contribution into ``master`` inside ``window``."""


COSTMAP_LAYERS: ClassRegistry[Layer] = ClassRegistry(
    "costmap layer", Layer, builtin_table({
        "navstack.costmap.static_layer": ("StaticLayer", "nav2_costmap_2d::StaticLayer"),
        "navstack.costmap.obstacle_layer": ("ObstacleLayer", "nav2_costmap_2d::ObstacleLayer",
                                            "VoxelLayer", "nav2_costmap_2d::VoxelLayer"),
        "navstack.costmap.inflation_layer": ("InflationLayer",
                                             "nav2_costmap_2d::InflationLayer"),
        "navstack.costmap.keepout_filter": ("KeepoutFilter", "nav2_costmap_2d::KeepoutFilter"),
        "navstack.costmap.speed_filter": ("SpeedFilter", "nav2_costmap_2d::SpeedFilter"),
    }))
"""Costmap layers and filters by name, with their Nav2 types (``nav2_costmap_2d::...``)
as aliases; built-in ones are imported on first lookup."""


def register_layer(name: str, nav2: str | Iterable[str] = (), aliases: Iterable[str] = ()
                   ) -> Callable[[type[Layer]], type[Layer]]:
    """Class decorator: register a costmap layer (or filter) as ``name`` and both
    spellings of its Nav2 type ``nav2`` (``"pkg::Class"``)."""
    return COSTMAP_LAYERS.plugin(name, nav2=nav2, aliases=aliases)


class CostmapLayer(Layer):
    """A layer with its own ``Costmap2D`` matching the master (Nav2 ``CostmapLayer``)."""

    def __init__(self, name: str, params: LayerParams | None = None) -> None:
        super().__init__(name, params)
        self.costmap: Costmap2D = Costmap2D(1, 1, 1.0)
        self.default_value = FREE_SPACE
        self._extra = Bounds()

    def match_size(self) -> None:
        m = self.master
        old = getattr(self, "costmap", None)
        self.costmap = Costmap2D(m.size_x, m.size_y, m.resolution, m.origin_x, m.origin_y,
                                 m.frame_id, self.default_value)
        if old is not None:  # keep what the layer knew where the grids overlap
            self.costmap.copy_overlap(old.data, old.origin_x, old.origin_y, old.resolution)

    def reset(self) -> None:
        super().reset()
        self.costmap.reset(self.default_value)

    # --- bounds helpers --------------------------------------------------------------
    def add_extra_bounds(self, min_x: float, min_y: float, max_x: float, max_y: float) -> None:
        """Force the next update to cover this box (Nav2 ``addExtraBounds``)."""
        self._extra.touch(min_x, min_y)
        self._extra.touch(max_x, max_y)

    def use_extra_bounds(self, bounds: Bounds) -> None:
        bounds.union(self._extra)
        self._extra = Bounds()

    def clear_area(self, start_x: int, start_y: int, end_x: int, end_y: int,
                   invert: bool) -> None:
        """Nav2 ``CostmapLayer::clearArea``: cells strictly inside ``(start, end)`` are the
        region; ``invert=False`` clears the region, ``invert=True`` everything else.
        Cleared cells become ``NO_INFORMATION`` (skipped by the max/overwrite combiners).
        """
        cm = self.costmap
        xs = np.arange(cm.size_x)
        ys = np.arange(cm.size_y)
        inside = (((ys > start_y) & (ys < end_y))[:, None]
                  & ((xs > start_x) & (xs < end_x))[None, :])
        cm.data[inside != invert] = NO_INFORMATION
        self.current = False
        self.add_extra_bounds(cm.origin_x, cm.origin_y, cm.origin_x + cm.size_x_m,
                              cm.origin_y + cm.size_y_m)

    # --- combination methods (vectorised over the window) ---------------------------
    def update_with_true_overwrite(self, master: Costmap2D, w: CellWindow) -> None:
        master.data[w.slices] = self.costmap.data[w.slices]

    def update_with_overwrite(self, master: Costmap2D, w: CellWindow) -> None:
        src = self.costmap.data[w.slices]
        dst = master.data[w.slices]
        known = src != NO_INFORMATION
        dst[known] = src[known]

    def update_with_max(self, master: Costmap2D, w: CellWindow) -> None:
        src = self.costmap.data[w.slices]
        dst = master.data[w.slices]
        take = (src != NO_INFORMATION) & ((dst == NO_INFORMATION) | (dst < src))
        dst[take] = src[take]

    def update_with_max_without_unknown_overwrite(self, master: Costmap2D,
                                                  w: CellWindow) -> None:
        src = self.costmap.data[w.slices]
        dst = master.data[w.slices]
        take = (src != NO_INFORMATION) & (dst != NO_INFORMATION) & (dst < src)
        dst[take] = src[take]

    def update_with_addition(self, master: Costmap2D, w: CellWindow) -> None:
        src = self.costmap.data[w.slices]
        dst = master.data[w.slices]
        known = src != NO_INFORMATION
        total = dst.astype(np.int32) + src
        summed = np.where(total >= INSCRIBED_INFLATED_OBSTACLE,
                          INSCRIBED_INFLATED_OBSTACLE - 1, total).astype(np.uint8)
        out = np.where(dst == NO_INFORMATION, src, summed)
        dst[known] = out[known]


def combine(layer: CostmapLayer, master: Costmap2D, window: CellWindow, method: int) -> None:
    """Nav2 ``combination_method`` enum: 0 overwrite, 1 max, 2 max without unknown overwrite."""
    if method == 0:
        layer.update_with_overwrite(master, window)
    elif method == 1:
        layer.update_with_max(master, window)
    elif method == 2:
        layer.update_with_max_without_unknown_overwrite(master, window)
