"""Costmap filter info servers and filter mask servers (Nav2 ``nav2_map_server``).

Nav2 feeds a costmap filter from two nodes: a ``costmap_filter_info_server`` publishes a
latched ``nav2_msgs/CostmapFilterInfo`` (``type``, ``filter_mask_topic``, ``base``,
``multiplier``) on ``filter_info_topic``, and a ``map_server`` instance publishes the mask
(an OccupancyGrid read from a map_server YAML + image) latched on ``topic_name``.  The
costmap filter subscribes to the info topic, then to the mask topic the info names
(:class:`~navstack.navigation.costmap_node.CostmapNode`).

Nav2 parameter file layout (the node names Nav2's bringup uses; any
``<prefix>_costmap_filter_info_server`` / ``<prefix>_filter_mask_server`` pair works)::

    keepout_filter_mask_server:
      ros__parameters:
        topic_name: /keepout_filter_mask
        frame_id: map
        yaml_filename: filters/keepout_mask.yaml   # relative to this parameter file
    keepout_costmap_filter_info_server:
      ros__parameters:
        type: 0                       # 0 keepout, 1 speed %, 2 speed m/s, 3 binary
        filter_info_topic: /keepout_filter_info
        mask_topic: /keepout_filter_mask
        base: 0.0
        multiplier: 1.0

:func:`create_filter_servers` builds the servers a parameter file declares, loads and
checks every mask, and checks each costmap's ``filters:`` against them, so a mistake is
a :class:`~navstack.core.errors.ConfigError` naming the file and key at start-up rather
than a filter that silently never activates.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from navstack.core.config_files import ROS_PARAMETERS, ros_parameters
from navstack.core.errors import ConfigError, MapFileError
from navstack.core.map_files import load_map
from navstack.core.msgs import CostmapFilterInfo, Header, OccupancyGrid
from navstack.core.params import Params
from navstack.costmap.costmap_filter import (
    FILTER_TYPES,
    KEEPOUT_FILTER,
    SPEED_FILTER_ABSOLUTE,
    SPEED_FILTER_PERCENT,
    CostmapFilter,
    filter_values,
)
from navstack.costmap.plugins import layer_from_nav2
from navstack.navigation.map_server import MapServer
from navstack.runtime.node import Node, Runtime

INFO_SERVER = "costmap_filter_info_server"
MASK_SERVER = "filter_mask_server"
COSTMAP_SECTIONS = ("global_costmap", "local_costmap")


def is_info_server_section(name: str) -> bool:
    """``costmap_filter_info_server`` or ``<prefix>_costmap_filter_info_server``."""
    return name == INFO_SERVER or name.endswith("_" + INFO_SERVER)


def is_mask_server_section(name: str) -> bool:
    """``filter_mask_server`` or ``<prefix>_filter_mask_server``."""
    return name == MASK_SERVER or name.endswith("_" + MASK_SERVER)


def topic_name(name: str) -> str:
    """Absolute topic name (the bus and Nav2's root namespace treat ``a`` as ``/a``)."""
    return "/" + name.lstrip("/")


class CostmapFilterInfoServerParams(Params):
    """nav2_map_server ``costmap_filter_info_server`` parameters (names, defaults)."""

    type: int = Field(KEEPOUT_FILTER, ge=0, le=3,
                      description="0 keepout, 1 speed %, 2 speed m/s, 3 binary")
    filter_info_topic: str = Field("costmap_filter_info", min_length=1)
    mask_topic: str = Field("filter_mask", min_length=1)
    base: float = Field(0.0, allow_inf_nan=False)
    multiplier: float = Field(1.0, allow_inf_nan=False)
    use_sim_time: bool = False


class FilterMaskServerParams(Params):
    """nav2_map_server ``map_server`` parameters for a filter mask."""

    yaml_filename: str = ""
    topic_name: str = Field("map", min_length=1)
    frame_id: str = Field("map", min_length=1)
    use_sim_time: bool = False


class CostmapFilterInfoServer(Node):
    """Publishes one latched CostmapFilterInfo (Nav2 ``CostmapFilterInfoServer``)."""

    def __init__(self, runtime: Runtime, params: CostmapFilterInfoServerParams,
                 name: str = INFO_SERVER) -> None:
        super().__init__(name, runtime)
        self.params = params
        self.topic = topic_name(params.filter_info_topic)

    @property
    def info(self) -> CostmapFilterInfo:
        p = self.params
        return CostmapFilterInfo(Header(self.now, ""), p.type, topic_name(p.mask_topic),
                                 p.base, p.multiplier)

    def on_configure(self) -> None:
        self.pub = self.create_latched_publisher(self.topic, CostmapFilterInfo)

    def on_activate(self) -> None:
        self.pub.publish(self.info)


@dataclass
class FilterServers:
    """The filter info and mask servers of one stack, by node name."""

    info_servers: dict[str, CostmapFilterInfoServer] = field(default_factory=dict)
    mask_servers: dict[str, MapServer] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return bool(self.info_servers or self.mask_servers)

    def mask_for(self, info_server: str) -> OccupancyGrid:
        """The mask the named info server points to."""
        topic = topic_name(self.info_servers[info_server].params.mask_topic)
        for server in self.mask_servers.values():
            if server.topic == topic:
                return server.grid
        raise KeyError(topic)


@dataclass(frozen=True)
class _Declared:
    """Validated parameters of the servers a file declares, before any node exists."""

    infos: dict[str, CostmapFilterInfoServerParams]
    masks: dict[str, tuple[FilterMaskServerParams, OccupancyGrid]]


def declared_filter_servers(nav: Mapping[str, Any], file: str = "",
                            base_dir: Path | None = None) -> _Declared:
    """Parse and check every filter info / mask server section of a Nav2 parameter file;
    masks are loaded (``yaml_filename`` relative to ``base_dir``, default the file's
    folder) and checked against the filter info that points to them."""
    base = base_dir if base_dir is not None else _base_dir(file)
    infos: dict[str, CostmapFilterInfoServerParams] = {}
    masks: dict[str, tuple[FilterMaskServerParams, OccupancyGrid]] = {}
    for section in nav:
        if not isinstance(section, str):
            continue
        if is_info_server_section(section):
            infos[section] = CostmapFilterInfoServerParams.from_mapping(
                ros_parameters(nav, section, file=file), file=file,
                key_path=f"{section}.{ROS_PARAMETERS}")
        elif is_mask_server_section(section):
            p = FilterMaskServerParams.from_mapping(
                ros_parameters(nav, section, file=file), file=file,
                key_path=f"{section}.{ROS_PARAMETERS}")
            masks[section] = (p, _load_mask(p, section, file, base))
    by_topic: dict[str, str] = {}
    for section, (p, _) in masks.items():
        topic = topic_name(p.topic_name)
        if topic in by_topic:
            raise ConfigError(f"mask topic '{topic}' is served by both '{by_topic[topic]}' "
                              f"and '{section}'", file=file,
                              key_path=f"{section}.{ROS_PARAMETERS}.topic_name",
                              suggestion="give each filter mask server its own topic_name")
        by_topic[topic] = section
    seen_info: dict[str, str] = {}
    for section, info in infos.items():
        key = f"{section}.{ROS_PARAMETERS}"
        topic = topic_name(info.filter_info_topic)
        if topic in seen_info:
            raise ConfigError(f"filter info topic '{topic}' is published by both "
                              f"'{seen_info[topic]}' and '{section}'", file=file,
                              key_path=f"{key}.filter_info_topic",
                              suggestion="give each filter info server its own topic")
        seen_info[topic] = section
        mask_topic = topic_name(info.mask_topic)
        if mask_topic not in by_topic:
            served = ", ".join(sorted(by_topic)) or "none"
            raise ConfigError(
                f"mask_topic '{mask_topic}' is not served by any filter mask server "
                f"(served: {served})", file=file, key_path=f"{key}.mask_topic",
                suggestion=f"add a '<name>_{MASK_SERVER}' section with topic_name: "
                           f"{mask_topic} and yaml_filename: <mask YAML>")
        mask_section = by_topic[mask_topic]
        mp, grid = masks[mask_section]
        check_mask_values(grid, info, mask_file=_mask_path(mp, base), file=file,
                          key_path=key)
    return _Declared(infos, masks)


def check_mask_values(grid: OccupancyGrid, info: CostmapFilterInfoServerParams, *,
                      mask_file: str, file: str = "", key_path: str = "") -> None:
    """Refuse a speed mask Nav2 would misread: unknown cells (Nav2 logs an error and keeps
    the previous limit there), values whose ``base + multiplier * v`` falls outside the
    valid range (read as "no limit"), or that give exactly 0 (also "no limit")."""
    if info.type not in (SPEED_FILTER_PERCENT, SPEED_FILTER_ABSOLUTE):
        return
    values = np.unique(np.asarray(grid.data))
    unknown = int(np.count_nonzero(np.asarray(grid.data) < 0))
    if unknown:
        raise ConfigError(
            f"speed mask {mask_file} has {unknown} unknown (-1) cells, which a speed filter "
            "cannot read", file=file, key_path=f"{key_path}.mask_topic",
            suggestion="draw no-limit areas white (mask value 0); with mode: scale keep "
                       "the image fully opaque")
    zoned = values[values > 0]
    limits = filter_values(zoned, _info_msg(info))
    top = 100.0 if info.type == SPEED_FILTER_PERCENT else math.inf
    for v, limit in zip(zoned.tolist(), limits.tolist(), strict=True):
        unit = "%" if info.type == SPEED_FILTER_PERCENT else " m/s"
        if not 0.0 < limit <= top:
            why = ("0 means 'no limit' to Nav2 controllers" if limit == 0.0
                   else "outside the valid range, read as 'no limit'")
            rng = "(0, 100] %" if info.type == SPEED_FILTER_PERCENT else "> 0 m/s"
            raise ConfigError(
                f"speed mask {mask_file}: mask value {v} gives a limit of "
                f"{info.base} + {info.multiplier} * {v} = {limit:g}{unit}, {why}",
                file=file, key_path=f"{key_path}.base",
                suggestion=f"choose base and multiplier so every mask value 1..100 in use "
                           f"maps into {rng}, or stop the robot with a keepout zone")


def _info_msg(p: CostmapFilterInfoServerParams) -> CostmapFilterInfo:
    return CostmapFilterInfo(Header(), p.type, topic_name(p.mask_topic), p.base, p.multiplier)


def _base_dir(file: str) -> Path:
    path = Path(file) if file else None
    return path.parent if path is not None and path.is_file() else Path.cwd()


def _mask_path(p: FilterMaskServerParams, base: Path) -> str:
    path = Path(p.yaml_filename).expanduser()
    return str(path if path.is_absolute() else base / path)


def _load_mask(p: FilterMaskServerParams, section: str, file: str,
               base: Path) -> OccupancyGrid:
    key = f"{section}.{ROS_PARAMETERS}.yaml_filename"
    if not p.yaml_filename.strip():
        raise ConfigError("required key is missing", file=file, key_path=key,
                          suggestion="set it to the mask's map_server YAML (relative paths "
                                     "start at this parameter file's folder)")
    try:
        grid = load_map(_mask_path(p, base), frame_id=p.frame_id)
    except MapFileError as exc:
        raise ConfigError(f"cannot load the filter mask: {exc}", file=file,
                          key_path=key) from None
    return grid


def check_costmap_filters(nav: Mapping[str, Any], declared: _Declared, file: str = "") -> None:
    """Every costmap filter listed in ``global_costmap`` / ``local_costmap`` must name a
    ``filter_info_topic`` some info server publishes, with a type it can read."""
    by_topic = {topic_name(p.filter_info_topic): (s, p) for s, p in declared.infos.items()}
    for costmap in COSTMAP_SECTIONS:
        params = ros_parameters(nav, costmap, file=file)
        for name in [str(n) for n in params.get("filters", []) or []]:
            data = params.get(name)
            layer = layer_from_nav2(name, dict(data) if isinstance(data, Mapping) else None,
                                    file=file)
            if not isinstance(layer, CostmapFilter):
                continue  # e.g. an InflationLayer listed after a keepout filter
            key = f"{costmap}.{costmap}.{ROS_PARAMETERS}.{name}.filter_info_topic"
            wanted = layer.params.filter_info_topic
            if not wanted:
                raise ConfigError("required key is missing", file=file, key_path=key,
                                  suggestion="name the topic of the filter's "
                                             f"'<name>_{INFO_SERVER}' (filter_info_topic)")
            topic = topic_name(wanted)
            if topic not in by_topic:
                known = ", ".join(sorted(by_topic)) or "none"
                raise ConfigError(
                    f"no costmap filter info server publishes '{topic}' (published: "
                    f"{known})", file=file, key_path=key,
                    suggestion=f"add a '<name>_{INFO_SERVER}' section with "
                               f"filter_info_topic: {topic}, or fix the topic")
            section, info = by_topic[topic]
            layer.check_filter_info(_info_msg(info), file=file,
                                    key_path=f"{section}.{ROS_PARAMETERS}")


def create_filter_servers(runtime: Runtime, nav: Mapping[str, Any], file: str = "",
                          base_dir: Path | None = None) -> FilterServers:
    """Build the filter info and mask servers a Nav2 parameter file declares, after
    checking them and the costmaps' ``filters:`` (see the module docstring)."""
    declared = declared_filter_servers(nav, file, base_dir)
    check_costmap_filters(nav, declared, file)
    servers = FilterServers()
    for section, (p, grid) in declared.masks.items():
        servers.mask_servers[section] = MapServer(
            runtime, grid=grid, topic=topic_name(p.topic_name), frame_id=p.frame_id, name=section)
    for section, info in declared.infos.items():
        servers.info_servers[section] = CostmapFilterInfoServer(runtime, info, name=section)
    return servers


__all__ = ["FILTER_TYPES", "CostmapFilterInfoServer", "CostmapFilterInfoServerParams",
           "FilterMaskServerParams", "FilterServers", "check_costmap_filters",
           "check_mask_values", "create_filter_servers", "declared_filter_servers",
           "is_info_server_section", "is_mask_server_section", "topic_name"]
