"""Costmap filters on the bus: filter info + mask servers -> costmap node -> controller.

A small stack on the runtime: the filter servers a Nav2 dict declares (masks written to
``tmp_path`` as map_server files), a rolling local costmap in ``odom`` with a keepout and
a speed filter, a controller server with DWB, MPPI and RPP, and a fake base that writes
``odom -> base_link`` (``map -> odom`` is a static 1 m shift, so masks must be placed
with TF).
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path as FsPath
from typing import Any

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.map_files import load_map, save_map
from navstack.core.msgs import (
    CostmapFilterInfo,
    Header,
    MapMetaData,
    OccupancyGrid,
    Point,
    Pose,
    Pose2D,
    SpeedLimit,
)
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.navigation.controller_server import ControllerServer
from navstack.navigation.costmap_filter_servers import create_filter_servers
from navstack.navigation.costmap_node import CostmapNode
from navstack.runtime.node import Runtime

from .fakes import FakeBase

RES = 0.5


def _mask(tmp: FsPath, name: str, rows: tuple[int, int], cols: tuple[int, int], value: int,
          size: tuple[int, int] = (20, 40)) -> str:
    """A raw-mode mask (pixel value = mask value) over map x 0..20 m, y 0..10 m with
    ``value`` in the cells ``rows`` x ``cols``."""
    data = np.zeros(size, np.int8)
    data[rows[0]:rows[1], cols[0]:cols[1]] = value
    grid = OccupancyGrid(Header(0.0, "map"),
                         MapMetaData(0.0, RES, size[1], size[0], Pose(Point(0.0, 0.0, 0.0))),
                         data)
    path = tmp / f"{name}.yaml"
    save_map(grid, path, mode="raw")
    return path.name


def _nav(tmp: FsPath, speed_type: int = 1, base: float = 100.0, multiplier: float = -1.0,
         speed_value: int = 70) -> dict[str, Any]:
    keep = _mask(tmp, "keep", (4, 8), (10, 14), 100)  # map x 5..7, y 2..4
    speed = _mask(tmp, "speed", (0, 20), (20, 30), speed_value)  # map x 10..15
    return {
        "keepout_filter_mask_server": {"ros__parameters": {
            "topic_name": "/keepout_filter_mask", "yaml_filename": keep}},
        "keepout_costmap_filter_info_server": {"ros__parameters": {
            "type": 0, "filter_info_topic": "/keepout_filter_info",
            "mask_topic": "/keepout_filter_mask"}},
        "speed_filter_mask_server": {"ros__parameters": {
            "topic_name": "speed_filter_mask", "yaml_filename": speed}},
        "speed_costmap_filter_info_server": {"ros__parameters": {
            "type": speed_type, "filter_info_topic": "/speed_filter_info",
            "mask_topic": "/speed_filter_mask", "base": base, "multiplier": multiplier}},
        "local_costmap": {"local_costmap": {"ros__parameters": {
            "global_frame": "odom", "rolling_window": True, "width": 10, "height": 10,
            "resolution": 0.1, "update_frequency": 10.0, "plugins": [],
            "filters": ["keepout_filter", "speed_filter"],
            "keepout_filter": {"plugin": "nav2_costmap_2d::KeepoutFilter",
                               "filter_info_topic": "/keepout_filter_info"},
            "speed_filter": {"plugin": "nav2_costmap_2d::SpeedFilter",
                             "filter_info_topic": "speed_filter_info"}}}},
        "controller_server": {"ros__parameters": {
            "controller_plugins": ["FollowPath", "MPPI", "RPP"],
            "FollowPath": {"plugin": "dwb_core::DWBLocalPlanner", "max_vel_x": 0.5,
                           "max_speed_xy": 0.5},
            "MPPI": {"plugin": "nav2_mppi_controller::MPPIController", "vx_max": 0.5},
            "RPP": {"plugin": "nav2_regulated_pure_pursuit_controller::"
                             "RegulatedPurePursuitController", "desired_linear_vel": 0.5}}},
    }


class Stack:
    """The servers, a local costmap node, a controller server and a fake base."""

    def __init__(self, nav: dict[str, Any], tmp: FsPath) -> None:
        self.rt = rt = Runtime()
        self.base = FakeBase(rt, Pose2D(1.0, 1.0, 0.0), map_to_odom=Pose2D(1.0, 0.0, 0.0))
        self.servers = create_filter_servers(rt, nav, "nav2.yaml", base_dir=tmp)
        local = nav["local_costmap"]["local_costmap"]["ros__parameters"]
        self.costmap = CostmapNode(rt, "local_costmap", local)
        self.controller = ControllerServer(rt, nav["controller_server"]["ros__parameters"],
                                           self.costmap)
        self.limits: list[SpeedLimit] = []
        rt.bus.subscribe("/speed_limit", SpeedLimit, self.limits.append)
        rt.bring_up()
        self.run(0.3)

    def run(self, seconds: float) -> None:
        self.rt.scheduler.run_for(seconds)

    def go(self, x_map: float, y_map: float) -> None:
        """Put base_link at a map-frame position (odom is map shifted by 1 m in x)."""
        self.base.teleport(Pose2D(x_map - 1.0, y_map, 0.0))
        self.run(0.25)

    def effective_limits(self) -> tuple[float, float, float]:
        """(DWB max_vel_x, MPPI vx_max, RPP desired speed) in use now."""
        c = self.controller.controllers
        return (c["FollowPath"].generator.limits.max_vel_x, c["MPPI"].optimizer.limits[1],
                c["RPP"]._desired_linear_vel)


def test_keepout_cells_are_lethal_in_the_costmap_node(tmp_path: FsPath) -> None:
    s = Stack(_nav(tmp_path), tmp_path)
    cm = s.costmap.costmap
    lethal = np.argwhere(cm.data == LETHAL_OBSTACLE)
    assert len(lethal) == 20 * 20  # the 2 m x 2 m zone at 0.1 m
    ys = cm.origin_y + (lethal[:, 0] + 0.5) * cm.resolution
    xs = cm.origin_x + (lethal[:, 1] + 0.5) * cm.resolution
    # map x 5..7 is odom x 4..6 (map -> odom is a 1 m shift)
    assert xs.min() == pytest.approx(4.05) and xs.max() == pytest.approx(5.95)
    assert ys.min() == pytest.approx(2.05) and ys.max() == pytest.approx(3.95)
    assert s.costmap.filter_feed.errors == 0


def test_speed_limit_percent_reaches_every_controller_and_is_removed(tmp_path: FsPath) -> None:
    s = Stack(_nav(tmp_path), tmp_path)
    assert s.limits == [] and s.effective_limits() == (0.5, 0.5, 0.5)
    s.go(12.0, 5.0)  # in the 30 % zone (mask 70, base 100, multiplier -1)
    assert [(m.speed_limit, m.percentage, m.header.frame_id) for m in s.limits] == [
        (30.0, True, "odom")]
    assert s.controller.speed_limit == (30.0, True)
    assert s.effective_limits() == pytest.approx((0.15, 0.15, 0.15))
    s.go(12.5, 5.0)  # still inside: announced once
    assert len(s.limits) == 1
    s.go(16.0, 5.0)  # out: "no limit" (0) restores the controllers' own maxima
    assert [(m.speed_limit, m.percentage) for m in s.limits[1:]] == [(0.0, True)]
    assert s.effective_limits() == (0.5, 0.5, 0.5)


def test_speed_limit_absolute_reaches_every_controller(tmp_path: FsPath) -> None:
    nav = _nav(tmp_path, speed_type=2, base=0.0, multiplier=0.01, speed_value=20)
    s = Stack(nav, tmp_path)
    s.go(12.0, 5.0)  # 0 + 0.01 * 20 = 0.2 m/s
    assert [(m.speed_limit, m.percentage) for m in s.limits] == [(0.2, False)]
    assert s.effective_limits() == pytest.approx((0.2, 0.2, 0.2))


def test_filter_info_the_filter_cannot_read_is_ignored(tmp_path: FsPath) -> None:
    s = Stack(_nav(tmp_path), tmp_path)
    s.rt.bus.publisher("/speed_filter_info", CostmapFilterInfo).publish(
        CostmapFilterInfo(type=0, filter_mask_topic="/keepout_filter_mask"))
    s.run(0.2)
    feed = s.costmap.filter_feed
    assert feed.errors == 1 and "got filter type 0" in feed.last_error
    s.go(12.0, 5.0)  # the speed filter still reads its own mask
    assert [m.speed_limit for m in s.limits] == [30.0]


def test_new_filter_info_switches_the_mask_topic(tmp_path: FsPath) -> None:
    s = Stack(_nav(tmp_path), tmp_path)
    other = load_map(tmp_path / "speed.yaml")
    data = np.where(other.data > 0, 90, 0).astype(np.int8)  # 100 - 90 = 10 %
    pub = s.rt.bus.publisher("/other_mask", OccupancyGrid)
    s.rt.bus.publisher("/speed_filter_info", CostmapFilterInfo).publish(CostmapFilterInfo(
        type=1, filter_mask_topic="/other_mask", base=100.0, multiplier=-1.0))
    s.run(0.2)
    pub.publish(OccupancyGrid(other.header, other.info, data))
    s.go(12.0, 5.0)
    assert [m.speed_limit for m in s.limits] == [10.0]


def test_controller_server_refuses_impossible_speed_limits(tmp_path: FsPath) -> None:
    s = Stack(_nav(tmp_path), tmp_path)
    pub = s.rt.bus.publisher("/speed_limit", SpeedLimit)
    for limit, pct in ((math.nan, True), (-1.0, False), (150.0, True)):
        pub.publish(SpeedLimit(Header(), pct, limit))
    s.run(0.1)
    assert s.controller.rejected_speed_limits == 3
    assert s.effective_limits() == (0.5, 0.5, 0.5)
    pub.publish(SpeedLimit(Header(), False, 0.25))
    s.run(0.1)
    assert s.effective_limits() == pytest.approx((0.25, 0.25, 0.25))


# --- configuration errors ------------------------------------------------------------------
def _error(nav: dict[str, Any], tmp: FsPath) -> str:
    with pytest.raises(ConfigError) as info:
        create_filter_servers(Runtime(), nav, "nav2.yaml", base_dir=tmp)
    return str(info.value)


def test_mask_server_without_yaml_filename(tmp_path: FsPath) -> None:
    nav = _nav(tmp_path)
    del nav["speed_filter_mask_server"]["ros__parameters"]["yaml_filename"]
    assert _error(nav, tmp_path) == (
        "nav2.yaml: speed_filter_mask_server.ros__parameters.yaml_filename: required key is "
        "missing (set it to the mask's map_server YAML (relative paths start at this "
        "parameter file's folder))")


def test_mask_file_problems_name_the_mask_file_and_its_key(tmp_path: FsPath) -> None:
    nav = _nav(tmp_path)
    text = (tmp_path / "keep.yaml").read_text()
    (tmp_path / "keep.yaml").write_text(text.replace("resolution:", "resolutio:"))
    msg = _error(nav, tmp_path)
    assert msg.startswith("nav2.yaml: keepout_filter_mask_server.ros__parameters."
                          "yaml_filename: cannot load the filter mask: ")
    assert f"{tmp_path / 'keep.yaml'}: required key 'resolution' is missing" in msg
    nav["keepout_filter_mask_server"]["ros__parameters"]["yaml_filename"] = "nope.yaml"
    assert "nope.yaml: map YAML file not found" in _error(nav, tmp_path)


def test_info_server_errors(tmp_path: FsPath) -> None:
    nav = _nav(tmp_path)
    info = nav["speed_costmap_filter_info_server"]["ros__parameters"]
    info["mask_topic"] = "/speed_mask"
    assert _error(nav, tmp_path).startswith(
        "nav2.yaml: speed_costmap_filter_info_server.ros__parameters.mask_topic: mask_topic "
        "'/speed_mask' is not served by any filter mask server (served: "
        "/keepout_filter_mask, /speed_filter_mask)")
    info["mask_topic"] = "/speed_filter_mask"
    info["type"] = 7
    assert "speed_costmap_filter_info_server.ros__parameters.type: Input should be less " \
           "than or equal to 3" in _error(nav, tmp_path)
    info["type"] = 1
    info["multiplier"] = math.inf
    assert "ros__parameters.multiplier" in _error(nav, tmp_path)


def test_speed_mask_values_nav2_would_misread(tmp_path: FsPath) -> None:
    nav = _nav(tmp_path, speed_value=100)  # 100 - 100 = 0 %: Nav2's "no limit"
    msg = _error(nav, tmp_path)
    assert "speed_costmap_filter_info_server.ros__parameters.base: speed mask " in msg
    assert "mask value 100 gives a limit of 100.0 + -1.0 * 100 = 0%, 0 means 'no limit'" in msg
    nav = _nav(tmp_path, speed_type=2, base=-1.0, multiplier=0.01, speed_value=50)
    assert "= -0.5 m/s, outside the valid range" in _error(nav, tmp_path)
    nav = _nav(tmp_path)
    grid = load_map(tmp_path / "speed.yaml")
    data = grid.data.copy()
    data[0, 0] = -1
    save_map(OccupancyGrid(grid.header, grid.info, data), tmp_path / "speed.yaml", mode="raw")
    assert "has 1 unknown (-1) cells, which a speed filter cannot read" in _error(nav, tmp_path)


def test_costmap_filters_must_match_an_info_server(tmp_path: FsPath) -> None:
    nav = _nav(tmp_path)
    local = nav["local_costmap"]["local_costmap"]["ros__parameters"]
    local["speed_filter"]["filter_info_topic"] = "/speed_info"
    assert _error(nav, tmp_path).startswith(
        "nav2.yaml: local_costmap.local_costmap.ros__parameters.speed_filter."
        "filter_info_topic: no costmap filter info server publishes '/speed_info'")
    local["speed_filter"]["filter_info_topic"] = "/keepout_filter_info"
    assert "speed filter 'speed_filter' got filter type 0" in _error(nav, tmp_path)
    local["speed_filter"]["filter_info_topic"] = ""
    assert "speed_filter.filter_info_topic: required key is missing" in _error(nav, tmp_path)


def test_two_servers_on_one_mask_topic(tmp_path: FsPath) -> None:
    nav = _nav(tmp_path)
    nav["speed_filter_mask_server"]["ros__parameters"]["topic_name"] = "/keepout_filter_mask"
    assert "mask topic '/keepout_filter_mask' is served by both" in _error(nav, tmp_path)


def test_shipped_campus_speed_mask_reads_30_percent_in_the_crosswalk() -> None:
    grid = load_map(str(resources.files("navstack") / "config" / "filters" /
                        "campus_speed.yaml"))
    values, counts = np.unique(grid.data, return_counts=True)
    assert dict(zip(values.tolist(), counts.tolist(), strict=True)) == {0: 39604, 70: 396}
    row, col = grid.world_to_cell(25.0, 8.0)
    assert grid.data[row, col] == 70  # 100 - 70 = 30 % with the campus filter info
