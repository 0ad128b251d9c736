"""``KnownPoseMapper``: occupancy mapping with known poses (no scan matching).

For a robot whose localization is already good -- motion capture, a surveyed marker
field, the simulator's perfect localization -- mapping needs no SLAM: every scan is
integrated into a log-odds grid (:class:`~navstack.mapping.occupancy.LogOddsGrid`) at the
scan frame's pose in ``map_frame`` from TF (at the scan's stamp, through a TF message
filter), and ``/map`` is published (latched) every ``map_update_interval`` -- the
"mapping with known poses" of the occupancy-grid literature (Thrun et al., Probabilistic
Robotics, ch. 9).  Each scan is integrated once, so a map update costs one scan's rays
however large the map grows.

The exploration mission uses it to measure a strategy without SLAM error
(``navstack mission explore --localization perfect``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import Field

from navstack.core.msgs import LaserScan, OccupancyGrid, Pose2D
from navstack.core.params import Params
from navstack.mapping.occupancy import LogOddsGrid, ScanData
from navstack.nodes.slam import pad_to_extent
from navstack.runtime.bus import SENSOR_DATA
from navstack.runtime.node import Node, Runtime
from navstack.runtime.tf_filter import TfMessageFilter

__all__ = ["KnownPoseMapper", "KnownPoseMapperParams"]


class KnownPoseMapperParams(Params):
    """slam_toolbox-named keys where they mean the same."""

    map_frame: str = "map"
    scan_topic: str = "/scan"
    map_topic: str = "/map"
    resolution: float = Field(0.05, gt=0.0)
    max_laser_range: float = Field(20.0, gt=0.0)
    map_update_interval: float = Field(0.5, gt=0.0)
    transform_timeout: float = Field(0.2, ge=0.0)
    scan_queue_size: int = Field(5, ge=1)
    map_minimum_extent: list[float] | None = None
    """Publish at least ``[xmin, ymin, xmax, ymax]`` (unknown where unseen)."""


class KnownPoseMapper(Node):
    """Integrates ``/scan`` at TF's pose into ``/map`` (module docstring)."""

    def __init__(self, runtime: Runtime, params: KnownPoseMapperParams | None = None,
                 name: str = "known_pose_mapper") -> None:
        super().__init__(name, runtime)
        self.params = p = params or KnownPoseMapperParams()
        bounds: Any = tuple(p.map_minimum_extent) if p.map_minimum_extent else None
        self.grid = LogOddsGrid(p.resolution, bounds)
        self.scans = 0
        self._filter: TfMessageFilter[LaserScan, Pose2D] = TfMessageFilter(
            self, self._sensor_pose, self._integrate, queue_size=p.scan_queue_size,
            timeout=p.transform_timeout, what="scan")

    def on_configure(self) -> None:
        p = self.params
        self.pub = self.create_latched_publisher(p.map_topic, OccupancyGrid)
        self.create_subscription(p.scan_topic, LaserScan, self._filter.add, SENSOR_DATA)
        self.create_timer(p.map_update_interval, self.publish_map)

    def _sensor_pose(self, scan: LaserScan) -> Pose2D:
        return self.tf.lookup_pose2d(self.params.map_frame, scan.header.frame_id,
                                     scan.header.stamp)

    def _integrate(self, scan: LaserScan, pose: Pose2D) -> None:
        ranges = np.asarray(scan.ranges, dtype=np.float64)
        angles = scan.angle_min + scan.angle_increment * np.arange(ranges.size)
        usable = min(scan.range_max, self.params.max_laser_range)
        self.grid.integrate_scans(np.array([[pose.x, pose.y, pose.theta]]),
                                  [ScanData(ranges, angles, scan.range_min, scan.range_max)],
                                  usable if math.isfinite(usable) else math.inf)
        self.scans += 1

    def publish_map(self) -> None:
        if self.scans == 0:
            return
        p = self.params
        grid = self.grid.to_occupancy_grid(p.map_frame, self.now, crop=True)
        if p.map_minimum_extent is not None:
            grid = pad_to_extent(grid, p.map_minimum_extent)
        self.pub.publish(grid)
