"""LayeredCostmap: from_nav2, plugin registry, builders, update windows, combination."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap import (
    COSTMAP_LAYERS,
    Costmap2D,
    InflationLayer,
    KeepoutFilter,
    LayeredCostmap,
    ObstacleLayer,
    StaticLayer,
    VoxelLayer,
    make_global_costmap,
    make_local_costmap,
)
from navstack.costmap.layer import Bounds, CellWindow, CostmapLayer, combine

from .helpers import grid, scan

NAV2_GLOBAL = {
    "update_frequency": 1.0, "publish_frequency": 1.0, "global_frame": "map",
    "robot_base_frame": "base_link", "use_sim_time": True, "robot_radius": 0.22,
    "resolution": 0.05, "track_unknown_space": True,
    "plugins": ["static_layer", "obstacle_layer", "inflation_layer"],
    "filters": ["keepout_filter"],
    "obstacle_layer": {"plugin": "nav2_costmap_2d::ObstacleLayer", "enabled": True,
                       "observation_sources": "scan",
                       "scan": {"topic": "/scan", "max_obstacle_height": 2.0,
                                "clearing": True, "marking": True, "data_type": "LaserScan",
                                "raytrace_max_range": 3.0, "obstacle_max_range": 2.5}},
    "static_layer": {"plugin": "nav2_costmap_2d::StaticLayer",
                     "map_subscribe_transient_local": True},
    "inflation_layer": {"plugin": "nav2_costmap_2d::InflationLayer",
                        "cost_scaling_factor": 3.0, "inflation_radius": 0.55},
    "keepout_filter": {"plugin": "nav2_costmap_2d::KeepoutFilter", "enabled": True,
                       "filter_info_topic": "/costmap_filter_info"},
    "voxel_layer": {"plugin": "nav2_costmap_2d::VoxelLayer"},  # configured, not listed
    "always_send_full_costmap": True,
}


def test_from_nav2_builds_the_stack() -> None:
    lc = LayeredCostmap.from_nav2({"ros__parameters": NAV2_GLOBAL})
    assert [type(p) for p in lc.plugins] == [StaticLayer, ObstacleLayer, InflationLayer]
    assert [type(f) for f in lc.filters] == [KeepoutFilter]
    assert [p.name for p in lc.layers] == ["static_layer", "obstacle_layer",
                                           "inflation_layer", "keepout_filter"]
    assert (lc.costmap.size_x, lc.costmap.size_y, lc.costmap.resolution) == (100, 100, 0.05)
    assert lc.costmap.default_value == 255 and lc.track_unknown_space
    assert lc.footprint.radius == pytest.approx(0.23)  # robot_radius + footprint_padding 0.01
    obstacle = lc.layer("obstacle_layer")
    assert isinstance(obstacle, ObstacleLayer)
    src = obstacle.buffers["scan"].params
    assert (src.topic, src.max_obstacle_height, src.clearing, src.obstacle_max_range,
            src.raytrace_max_range, src.min_obstacle_height) == ("/scan", 2.0, True, 2.5, 3.0,
                                                                 0.0)
    inflation = lc.layer("inflation_layer")
    assert isinstance(inflation, InflationLayer)
    assert inflation.params.inflation_radius == 0.55 and inflation.radius_cells == 11


def test_from_nav2_unknown_plugin_did_you_mean() -> None:
    bad = {**NAV2_GLOBAL, "obstacle_layer": {"plugin": "nav2_costmap_2d::ObstacleLayr"}}
    with pytest.raises(ConfigError) as err:
        LayeredCostmap.from_nav2(bad, file="nav2_params.yaml")
    assert str(err.value) == (
        "nav2_params.yaml: obstacle_layer.plugin: unknown costmap plugin "
        "'nav2_costmap_2d::ObstacleLayr' (did you mean 'nav2_costmap_2d::ObstacleLayer'?; "
        "known: nav2_costmap_2d::InflationLayer, nav2_costmap_2d::KeepoutFilter, "
        "nav2_costmap_2d::ObstacleLayer, nav2_costmap_2d::SpeedFilter, "
        "nav2_costmap_2d::StaticLayer, nav2_costmap_2d::VoxelLayer)")


def test_from_nav2_config_errors() -> None:
    with pytest.raises(ConfigError, match=r"^my_layer\.plugin: required key is missing"):
        LayeredCostmap.from_nav2({"plugins": ["my_layer"], "my_layer": {"enabled": True}})
    with pytest.raises(ConfigError, match=r"resolutoin: unknown key \(did you mean "
                                          r"'resolution'\?\)"):
        LayeredCostmap.from_nav2({"resolutoin": 0.05, "plugins": []})
    with pytest.raises(ConfigError, match=r"inflation_layer\.inflation_radius"):
        LayeredCostmap.from_nav2({"plugins": ["inflation_layer"], "inflation_layer": {
            "plugin": "nav2_costmap_2d::InflationLayer", "inflation_radius": -1.0}})
    with pytest.raises(ConfigError, match=r"obstacle_layer\.scan\.marking"):
        LayeredCostmap.from_nav2({"plugins": ["obstacle_layer"], "obstacle_layer": {
            "plugin": "nav2_costmap_2d::ObstacleLayer", "observation_sources": "scan",
            "scan": {"marking": "sometimes"}}})


def test_registry_aliases() -> None:
    assert COSTMAP_LAYERS.get("nav2_costmap_2d::InflationLayer") is InflationLayer
    assert COSTMAP_LAYERS.get("nav2_costmap_2d/StaticLayer") is StaticLayer
    assert COSTMAP_LAYERS.get("nav2_costmap_2d::VoxelLayer") is VoxelLayer


def test_builders_use_nav2_defaults() -> None:
    local = make_local_costmap()
    assert local.rolling_window and local.costmap.frame_id == "odom"
    assert (local.costmap.size_x, local.costmap.size_y) == (60, 60)
    assert [type(p) for p in local.plugins] == [VoxelLayer, InflationLayer]
    m = np.zeros((40, 60), np.int8)
    m[20, 30] = 100
    glob = make_global_costmap(static_map=grid(m, 0.05, origin=(-1.0, -1.0)),
                               overrides={"inflation_layer": {"inflation_radius": 0.3}})
    assert (glob.costmap.size_x, glob.costmap.size_y, glob.costmap.origin_x) == (60, 40, -1.0)
    glob.update_map(0.0, 0.0, 0.0)
    assert glob.costmap.data[20, 30] == 254 and glob.costmap.data[20, 34] == 253
    assert glob.costmap.data[20, 37] == 0  # 0.35 m > overridden inflation_radius 0.3 m


def test_update_window_and_reset() -> None:
    lc = LayeredCostmap(100, 100, 0.1, footprint=Footprint.from_radius(0.1))
    assert lc.update_map(5.0, 5.0, 0.0) is None  # no layers, nothing to update
    obstacle = ObstacleLayer("obstacle_layer", sources=None)
    lc.add_plugin(obstacle)
    window = lc.update_map(5.0, 5.0, 0.0)  # footprint clearing touches the footprint
    assert window == CellWindow(48, 48, 52, 52)
    assert lc.is_current() and lc.initialized


class _Const(CostmapLayer):
    """A test layer with a fixed grid and a chosen combination method."""

    def __init__(self, name: str, values: list[int], method: int) -> None:
        super().__init__(name)
        self.values, self.method = values, method

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float,
                      bounds: Bounds) -> Bounds:
        self.costmap.data[0, :] = self.values
        bounds.touch(0.0, 0.0)
        bounds.touch(3.5, 0.5)
        return bounds

    def update_costs(self, master: Costmap2D, window: CellWindow) -> None:
        if self.method == 3:
            self.update_with_true_overwrite(master, window)
        elif self.method == 4:
            self.update_with_addition(master, window)
        else:
            combine(self, master, window, self.method)


@pytest.mark.parametrize(("method", "expected"), [
    (0, [200, 10, 255, 100]),  # overwrite: known layer cells replace
    (1, [200, 50, 255, 100]),  # max; unknown master cells are overwritten
    (2, [200, 50, 255, 255]),  # max without overwriting unknown master cells
    (3, [200, 10, 255, 100]),  # true overwrite: unknown layer cells too
    (4, [252, 60, 255, 100]),  # addition capped at 252
])
def test_combination_methods(method: int, expected: list[int]) -> None:
    lc = LayeredCostmap(4, 1, 1.0)
    lc.add_plugin(_Const("base", [100, 50, 255, 255], 3))
    lc.add_plugin(_Const("top", [200, 10, 255, 100], method))
    lc.update_map(0.0, 0.0, 0.0)
    assert lc.costmap.data[0].tolist() == expected


def test_voxel_layer_column_limits() -> None:
    lc = LayeredCostmap.from_nav2({"plugins": ["voxel_layer"], "width": 4, "height": 4,
                                   "voxel_layer": {
                                       "plugin": "nav2_costmap_2d::VoxelLayer",
                                       "origin_z": 0.1, "z_resolution": 0.1, "z_voxels": 5,
                                       "observation_sources": "scan",
                                       "scan": {"max_obstacle_height": 2.0,
                                                "marking": True}}})
    layer = lc.layer("voxel_layer")
    assert isinstance(layer, VoxelLayer)
    pts = np.array([[1.05, 1.05, 0.05], [2.05, 1.05, 0.3], [3.05, 1.05, 0.7]])
    layer.add_points(pts, (0.05, 1.05, 0.3), "scan")
    lc.update_map(0.5, 3.5, 0.0)
    assert np.argwhere(lc.costmap.data == 254).tolist() == [[10, 20]]  # only z in [0.1, 0.6)


def test_add_scan_uses_sensor_pose() -> None:
    lc = LayeredCostmap.from_nav2({"plugins": ["obstacle_layer"], "width": 4, "height": 4,
                                   "obstacle_layer": {
                                       "plugin": "nav2_costmap_2d::ObstacleLayer",
                                       "footprint_clearing_enabled": False,
                                       "observation_sources": "scan",
                                       "scan": {"max_obstacle_height": 2.0}}})
    layer = lc.layer("obstacle_layer")
    assert isinstance(layer, ObstacleLayer)
    layer.add_scan(scan([1.0]), Pose2D(1.05, 1.05, np.pi / 2), 0.3)  # single source: default
    lc.update_map(1.0, 1.0, 0.0)
    assert np.argwhere(lc.costmap.data == 254).tolist() == [[20, 10]]
