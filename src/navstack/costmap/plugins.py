"""Registry of costmap layers and filters, with Nav2 plugin strings as aliases.

``COSTMAP_LAYERS.get("nav2_costmap_2d::InflationLayer")`` returns
:class:`~navstack.costmap.inflation_layer.InflationLayer`; the ROS 1 style
``nav2_costmap_2d/InflationLayer`` is accepted too.  ``nav2_costmap_2d::VoxelLayer``
maps to :class:`~navstack.costmap.obstacle_layer.VoxelLayer`, a 2D obstacle layer that
honours the voxel column's height limits (see its docstring for what differs).
"""

from __future__ import annotations

import difflib
from typing import Any

from navstack.core.errors import ConfigError
from navstack.core.registry import PluginRegistry
from navstack.costmap.inflation_layer import InflationLayer
from navstack.costmap.keepout_filter import KeepoutFilter
from navstack.costmap.layer import Layer
from navstack.costmap.obstacle_layer import ObstacleLayer, VoxelLayer
from navstack.costmap.speed_filter import SpeedFilter
from navstack.costmap.static_layer import StaticLayer

COSTMAP_LAYERS: PluginRegistry[type[Layer]] = PluginRegistry("costmap layer")

for _cls in (StaticLayer, ObstacleLayer, VoxelLayer, InflationLayer, KeepoutFilter,
             SpeedFilter):
    _name = _cls.__name__
    COSTMAP_LAYERS.register(_name, _cls, aliases=(f"nav2_costmap_2d::{_name}",
                                                  f"nav2_costmap_2d/{_name}"))

NAV2_DEFAULT_PLUGINS = ["static_layer", "obstacle_layer", "inflation_layer"]
NAV2_DEFAULT_TYPES = {"static_layer": "nav2_costmap_2d::StaticLayer",
                      "obstacle_layer": "nav2_costmap_2d::ObstacleLayer",
                      "inflation_layer": "nav2_costmap_2d::InflationLayer"}


def known_plugin_strings() -> list[str]:
    """Every accepted ``plugin:`` value (names and Nav2 aliases)."""
    names = COSTMAP_LAYERS.names()
    return sorted({*names, *(f"nav2_costmap_2d::{n}" for n in names),
                   *(f"nav2_costmap_2d/{n}" for n in names)})


def layer_from_nav2(name: str, data: dict[str, Any] | None, *, file: str = "",
                    default_type: str | None = None) -> Layer:
    """Build the layer ``name`` from its Nav2 YAML dict (``plugin: ...`` plus parameters)."""
    data = dict(data or {})
    plugin = data.get("plugin", default_type)
    if plugin is None:
        raise ConfigError("required key is missing", file=file, key_path=f"{name}.plugin",
                          suggestion="e.g. plugin: \"nav2_costmap_2d::InflationLayer\"")
    plugin = str(plugin)
    if plugin not in COSTMAP_LAYERS:
        known = known_plugin_strings()
        close = difflib.get_close_matches(plugin, known, n=1, cutoff=0.6)
        hint = f"did you mean '{close[0]}'?" if close else ""
        hint += ("; " if hint else "") + "known: " + ", ".join(
            f"nav2_costmap_2d::{n}" for n in COSTMAP_LAYERS.names())
        raise ConfigError(f"unknown costmap plugin '{plugin}'", file=file,
                          key_path=f"{name}.plugin", suggestion=hint)
    cls = COSTMAP_LAYERS.get(plugin)
    return cls.from_mapping(name, data, file=file, key_path=name)
