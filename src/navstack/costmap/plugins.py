"""Building costmap layers and filters from their Nav2 YAML sections.

Layers register themselves in :data:`~navstack.costmap.layer.COSTMAP_LAYERS` with
:func:`~navstack.costmap.layer.register_layer` (name plus Nav2 type, e.g.
``nav2_costmap_2d::InflationLayer``; the ROS 1 style ``nav2_costmap_2d/InflationLayer``
is accepted too).  ``nav2_costmap_2d::VoxelLayer`` maps to
:class:`~navstack.costmap.obstacle_layer.VoxelLayer`, a 2D obstacle layer that honours
the voxel column's height limits (see its docstring for what differs).
"""

from __future__ import annotations

from typing import Any

from navstack.core.errors import ConfigError, PluginError, UnknownNameError, did_you_mean
from navstack.costmap.layer import COSTMAP_LAYERS, Layer

NAV2_DEFAULT_PLUGINS = ["static_layer", "obstacle_layer", "inflation_layer"]
NAV2_DEFAULT_TYPES = {"static_layer": "nav2_costmap_2d::StaticLayer",
                      "obstacle_layer": "nav2_costmap_2d::ObstacleLayer",
                      "inflation_layer": "nav2_costmap_2d::InflationLayer"}

__all__ = ["COSTMAP_LAYERS", "NAV2_DEFAULT_PLUGINS", "NAV2_DEFAULT_TYPES",
           "known_plugin_strings", "layer_from_nav2"]


def known_plugin_strings() -> list[str]:
    """Every accepted ``plugin:`` value (names and Nav2 types, both spellings)."""
    return COSTMAP_LAYERS.all_names()


def layer_from_nav2(name: str, data: dict[str, Any] | None, *, file: str = "",
                    default_type: str | None = None) -> Layer:
    """Build the layer ``name`` from its Nav2 YAML dict (``plugin: ...`` plus parameters)."""
    data = dict(data or {})
    plugin = data.get("plugin", default_type)
    if plugin is None:
        raise ConfigError("required key is missing", file=file, key_path=f"{name}.plugin",
                          suggestion="e.g. plugin: \"nav2_costmap_2d::InflationLayer\"")
    plugin = str(plugin)
    try:
        cls = COSTMAP_LAYERS.get(plugin)
    except UnknownNameError:
        hint = did_you_mean(plugin, known_plugin_strings()).strip(" ()")
        hint += ("; " if hint else "") + "known: " + ", ".join(
            n for n in known_plugin_strings() if "::" in n)
        raise ConfigError(f"unknown costmap plugin '{plugin}'", file=file,
                          key_path=f"{name}.plugin", suggestion=hint) from None
    except PluginError as exc:
        raise ConfigError(str(exc), file=file, key_path=f"{name}.plugin") from None
    return cls.from_mapping(name, data, file=file, key_path=name)
