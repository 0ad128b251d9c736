"""Global and local costmaps with Nav2's default set-up.

Nav2 runs two costmaps (``nav2_bringup/params/nav2_params.yaml``, Humble):

**Global costmap** (planner server, ``global_costmap: global_costmap: ros__parameters:``)
 - frame ``map`` (``global_frame: map``), not rolling: it covers the whole static map;
   the static layer resizes it to the map's extent and resolution;
 - ``plugins: [static_layer, obstacle_layer, inflation_layer]``: the map, live obstacles
   from ``/scan`` (mark within 2.5 m, clear within 3.0 m), inflation with
   ``inflation_radius: 0.55``, ``cost_scaling_factor: 3.0``;
 - ``track_unknown_space: true`` so planners can tell unexplored space from free space;
   ``update_frequency: 1.0`` Hz, ``resolution: 0.05``, ``robot_radius: 0.22``.

**Local costmap** (controller server, ``local_costmap: local_costmap: ros__parameters:``)
 - frame ``odom`` (continuous, no map jumps), ``rolling_window: true``: a ``width`` x
   ``height`` = 3 m x 3 m window at ``resolution: 0.05`` that follows the robot;
 - ``plugins: [voxel_layer, inflation_layer]`` (navstack serves VoxelLayer with the 2D
   obstacle layer, see :class:`~navstack.costmap.obstacle_layer.VoxelLayer`);
 - ``update_frequency: 5.0`` Hz, the rate the controller needs fresh obstacles at.

The runtime drives them: each cycle it looks up the robot pose in the costmap's frame,
feeds sensor data (``ObstacleLayer.add_scan`` with the sensor pose in that frame) and calls
``update_map``.  Both builders take ``overrides`` in the same Nav2 layout, merged
recursively over the defaults (``{"inflation_layer": {"inflation_radius": 0.3}}``).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from navstack.core.msgs import OccupancyGrid
from navstack.core.polygon import Footprint
from navstack.costmap.layered_costmap import LayeredCostmap
from navstack.costmap.static_layer import StaticLayer

_SCAN_SOURCE: dict[str, Any] = {
    "topic": "/scan", "max_obstacle_height": 2.0, "clearing": True, "marking": True,
    "data_type": "LaserScan", "raytrace_max_range": 3.0, "raytrace_min_range": 0.0,
    "obstacle_max_range": 2.5, "obstacle_min_range": 0.0,
}

NAV2_GLOBAL_COSTMAP: dict[str, Any] = {
    "update_frequency": 1.0, "publish_frequency": 1.0, "global_frame": "map",
    "robot_base_frame": "base_link", "robot_radius": 0.22, "resolution": 0.05,
    "track_unknown_space": True, "always_send_full_costmap": True,
    "plugins": ["static_layer", "obstacle_layer", "inflation_layer"],
    "obstacle_layer": {"plugin": "nav2_costmap_2d::ObstacleLayer", "enabled": True,
                       "observation_sources": "scan", "scan": dict(_SCAN_SOURCE)},
    "static_layer": {"plugin": "nav2_costmap_2d::StaticLayer",
                     "map_subscribe_transient_local": True},
    "inflation_layer": {"plugin": "nav2_costmap_2d::InflationLayer",
                        "cost_scaling_factor": 3.0, "inflation_radius": 0.55},
}
"""Nav2 Humble ``global_costmap`` defaults from nav2_params.yaml."""

NAV2_LOCAL_COSTMAP: dict[str, Any] = {
    "update_frequency": 5.0, "publish_frequency": 2.0, "global_frame": "odom",
    "robot_base_frame": "base_link", "rolling_window": True, "width": 3, "height": 3,
    "resolution": 0.05, "robot_radius": 0.22, "always_send_full_costmap": True,
    "plugins": ["voxel_layer", "inflation_layer"],
    "inflation_layer": {"plugin": "nav2_costmap_2d::InflationLayer",
                        "cost_scaling_factor": 3.0, "inflation_radius": 0.55},
    "voxel_layer": {"plugin": "nav2_costmap_2d::VoxelLayer", "enabled": True,
                    "publish_voxel_map": True, "origin_z": 0.0, "z_resolution": 0.05,
                    "z_voxels": 16, "max_obstacle_height": 2.0, "mark_threshold": 0,
                    "observation_sources": "scan", "scan": dict(_SCAN_SOURCE)},
}
"""Nav2 Humble ``local_costmap`` defaults from nav2_params.yaml."""


def merge_params(base: Mapping[str, Any], overrides: Mapping[str, Any] | None
                 ) -> dict[str, Any]:
    """Recursive dict merge: ``overrides`` wins, nested dicts are merged key by key."""
    out = copy.deepcopy(dict(base))
    for key, value in (overrides or {}).items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge_params(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def make_global_costmap(footprint: Footprint | None = None,
                        static_map: OccupancyGrid | None = None,
                        overrides: Mapping[str, Any] | None = None) -> LayeredCostmap:
    """Nav2's default global costmap; with ``static_map`` it takes the map's extent."""
    lc = LayeredCostmap.from_nav2(merge_params(NAV2_GLOBAL_COSTMAP, overrides), footprint)
    if static_map is not None:
        for layer in lc.plugins:
            if isinstance(layer, StaticLayer):
                layer.set_map(static_map)
    return lc


def make_local_costmap(footprint: Footprint | None = None,
                       overrides: Mapping[str, Any] | None = None) -> LayeredCostmap:
    """Nav2's default rolling local costmap (3 m x 3 m in ``odom``)."""
    return LayeredCostmap.from_nav2(merge_params(NAV2_LOCAL_COSTMAP, overrides), footprint)
