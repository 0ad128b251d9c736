"""``CostmapNode``: a LayeredCostmap on the bus (Nav2 ``Costmap2DROS``).

Subscribes the static map (``map_topic``, latched) and every observation source's topic
(LaserScan, or PointCloud2 for ``data_type: PointCloud2``), looks up the sensor pose in
the costmap's ``global_frame`` at the scan's stamp through TF -- with the obstacle
layer's ``tf_message_filter`` a scan waits in a TF message filter until the odometry of
its instant is in the buffer, at most ``tf_filter_tolerance`` (Nav2's
``tf2_ros::MessageFilter``); without it a scan stamped at the same instant as an odometry
sample not delivered yet is dropped, up to every scan for seconds at a time -- updates
the layers at
``update_frequency`` around the robot pose (``global_frame`` <- ``robot_base_frame``),
publishes the master grid as an
OccupancyGrid on ``/<name>/costmap`` at ``publish_frequency`` and offers the Nav2 clear
services ``/<name>/clear_entirely_<name>`` and ``/<name>/clear_around_<name>``.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from typing import Any

import numpy as np

from navstack.core.errors import ConfigError, ExtrapolationError, TransformError
from navstack.core.msgs import (
    Header,
    LaserScan,
    MapMetaData,
    OccupancyGrid,
    Point,
    Pose,
    Pose2D,
)
from navstack.core.msgs.sensor_msgs import PointCloud2
from navstack.core.polygon import Footprint
from navstack.core.rotations import transform_to_matrix
from navstack.costmap.costmap_2d import NO_INFORMATION, Costmap2D
from navstack.costmap.layered_costmap import LayeredCostmap
from navstack.costmap.obstacle_layer import ObstacleLayer
from navstack.costmap.static_layer import StaticLayer
from navstack.navigation.costmap_filter_feed import CostmapFilterFeed
from navstack.runtime.bus import SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime
from navstack.runtime.tf_filter import TfMessageFilter


def costmap_to_grid(cm: Costmap2D, stamp: float) -> OccupancyGrid:
    """Costmap costs as an OccupancyGrid (0..100, -1 unknown), as Nav2 publishes them."""
    data = np.where(cm.data == NO_INFORMATION, -1,
                    (cm.data.astype(np.int16) * 100 + 126) // 253).astype(np.int8)
    info = MapMetaData(stamp, cm.resolution, cm.size_x, cm.size_y,
                       Pose(Point(cm.origin_x, cm.origin_y, 0.0)))
    return OccupancyGrid(Header(stamp, cm.frame_id), info, data)


class CostmapNode(Node):
    """Owns one LayeredCostmap built from Nav2 parameters (the ``ros__parameters`` dict)."""

    def __init__(self, runtime: Runtime, name: str, params: Mapping[str, Any],
                 footprint: Footprint | None = None, file: str = "") -> None:
        super().__init__(name, runtime)
        self.layered = LayeredCostmap.from_nav2(params, footprint, file=file)
        p = self.layered.params
        assert p is not None
        self.global_frame = p.global_frame
        self.robot_base_frame = p.robot_base_frame
        self.update_period = 1.0 / p.update_frequency if p.update_frequency > 0 else 0.2
        self.publish_period = 1.0 / p.publish_frequency if p.publish_frequency > 0 else 0.0
        self.map_topic = "/" + p.map_topic.lstrip("/")
        self.updates = 0
        #: stamp of the newest sensor observation the last update marked (``None``: none)
        self.newest_observation: float | None = None
        self.tf_failures = 0
        self.last_tf_error = ""
        # Nav2's obstacle layer puts a tf2 MessageFilter (tf_filter_tolerance) in front of
        # each scan source: a scan waits for the odometry of its own instant
        self._scan_filters: list[TfMessageFilter[LaserScan, tuple[Pose2D, float]]] = []
        try:
            self.filter_feed = CostmapFilterFeed(self)
        except ConfigError as exc:
            raise ConfigError(exc.reason, file=file, key_path=exc.key_path,
                              suggestion=exc.suggestion) from None

    @property
    def costmap(self) -> Costmap2D:
        return self.layered.costmap

    def on_configure(self) -> None:
        self.costmap.frame_id = self.global_frame
        for layer in self.layered.layers:
            if isinstance(layer, StaticLayer):
                self.create_subscription(self.map_topic, OccupancyGrid,
                                         partial(self._on_map, layer),
                                         QoS(depth=1, latched=True))
            elif isinstance(layer, ObstacleLayer):
                for src, buf in layer.buffers.items():
                    topic = "/" + buf.params.topic.lstrip("/")
                    if buf.params.data_type == "PointCloud2":
                        self.create_subscription(topic, PointCloud2,
                                                 partial(self._on_cloud, layer, src), SENSOR_DATA)
                        continue
                    if not layer.params.tf_message_filter:
                        self.create_subscription(topic, LaserScan,
                                                 partial(self._on_scan, layer, src),
                                                 SENSOR_DATA)
                        continue
                    scans: TfMessageFilter[LaserScan, tuple[Pose2D, float]] = TfMessageFilter(
                        self, self._scan_pose, partial(self._add_scan, layer, src),
                        queue_size=10, timeout=layer.params.tf_filter_tolerance,
                        what=f"'{src}' scan", on_drop=self._scan_dropped)
                    self._scan_filters.append(scans)
                    self.create_subscription(topic, LaserScan, scans.add, SENSOR_DATA)
        self.filter_feed.configure()
        self.pub = self.create_publisher(f"/{self.name}/costmap", OccupancyGrid, QoS(depth=1))
        self.bus.advertise_service(f"/{self.name}/clear_entirely_{self.name}",
                                   lambda _req: self.clear_all())
        self.bus.advertise_service(f"/{self.name}/clear_around_{self.name}",
                                   self._clear_around_request)
        self.create_timer(self.update_period, self.update)
        if self.publish_period > 0:
            self.create_timer(self.publish_period, self.publish)

    def on_cleanup(self) -> None:
        for scans in self._scan_filters:
            scans.clear()
        self._scan_filters.clear()
        self.bus.remove_service(f"/{self.name}/clear_entirely_{self.name}")
        self.bus.remove_service(f"/{self.name}/clear_around_{self.name}")

    # --- inputs -------------------------------------------------------------------------
    def _on_map(self, layer: StaticLayer, grid: OccupancyGrid) -> None:
        map_in_costmap: Pose2D | None = None
        if grid.header.frame_id and grid.header.frame_id != self.global_frame:
            try:
                map_in_costmap = self.tf.lookup_pose2d(self.global_frame, grid.header.frame_id)
            except TransformError as exc:
                self.tf_failed(exc)
                return
        layer.set_map(grid, map_in_costmap)

    def _track_static_maps(self) -> None:
        """Keep static layers whose map is in another frame (a static layer in the ``odom``
        local costmap) aligned with the latest ``global_frame <- map`` transform."""
        for layer in self.layered.layers:
            if (isinstance(layer, StaticLayer) and layer.map_frame
                    and layer.map_frame != self.global_frame):
                try:
                    layer.map_in_costmap = self.tf.lookup_pose2d(self.global_frame,
                                                                 layer.map_frame)
                except TransformError as exc:
                    self.tf_failed(exc)
                    continue
                layer.add_extra_bounds(*self._window_bounds())

    def _window_bounds(self) -> tuple[float, float, float, float]:
        cm = self.costmap
        return (cm.origin_x, cm.origin_y, cm.origin_x + cm.size_x_m, cm.origin_y + cm.size_y_m)

    def _on_scan(self, layer: ObstacleLayer, source: str, scan: LaserScan) -> None:
        """A scan without the TF filter: dropped (counted) when TF cannot place it now."""
        try:
            pose = self._scan_pose(scan)
        except TransformError as exc:
            self.tf_failed(exc)
            return
        self._add_scan(layer, source, scan, pose)

    def _scan_pose(self, scan: LaserScan) -> tuple[Pose2D, float]:
        """The sensor pose in ``global_frame`` at the scan's stamp and its height
        (``TransformError`` while TF cannot tell yet: the scan waits in its filter)."""
        t = self.tf.lookup(self.global_frame, scan.header.frame_id,
                           scan.header.stamp).transform
        return Pose2D(t.translation.x, t.translation.y, t.rotation.yaw), t.translation.z

    def _add_scan(self, layer: ObstacleLayer, source: str, scan: LaserScan,
                  pose: tuple[Pose2D, float]) -> None:
        layer.add_scan(scan, pose[0], pose[1], source)

    def _scan_dropped(self, _scan: LaserScan, reason: str) -> None:
        self.tf_failures += 1
        self.last_tf_error = reason

    def _on_cloud(self, layer: ObstacleLayer, source: str, cloud: PointCloud2) -> None:
        """A PointCloud2 source: points into ``global_frame``; the sensor origin is
        ``sensor_frame``'s (Nav2), else the cloud frame's.  A cloud stamped between two
        samples of a dynamic transform that has no newer one yet (a map-frame cloud of
        virtual obstacles, published at any time) uses the latest transforms."""
        frame, stamp = cloud.header.frame_id, cloud.header.stamp
        sensor = layer.buffers[source].params.sensor_frame or frame
        try:
            try:
                tf_cloud = self.tf.lookup(self.global_frame, frame, stamp)
                at_origin = self.tf.lookup(self.global_frame, sensor, stamp)
            except ExtrapolationError:
                tf_cloud = self.tf.lookup(self.global_frame, frame)
                at_origin = self.tf.lookup(self.global_frame, sensor)
        except TransformError as exc:
            self.tf_failed(exc)
            return
        origin = at_origin.transform.translation
        matrix = transform_to_matrix(tf_cloud.transform)
        xyz = cloud.xyz() if cloud.width * cloud.height else np.zeros((0, 3))
        points = xyz @ matrix[:3, :3].T + matrix[:3, 3]
        layer.add_points(points, (origin.x, origin.y, origin.z), source, stamp)

    def tf_failed(self, exc: Exception) -> None:
        """Count a failed TF lookup and keep its message (``last_tf_error``)."""
        self.tf_failures += 1
        self.last_tf_error = str(exc)

    # --- cycle --------------------------------------------------------------------------
    def robot_pose(self) -> Pose2D | None:
        """Robot pose in the costmap frame, or ``None`` if TF cannot tell yet."""
        try:
            return self.tf.lookup_pose2d(self.global_frame, self.robot_base_frame)
        except TransformError as exc:
            self.tf_failed(exc)
            return None

    def update(self) -> None:
        pose = self.robot_pose()
        if pose is None:
            return
        self._track_static_maps()
        self.filter_feed.before_update()
        self.layered.update_map(pose.x, pose.y, pose.theta, self.now)
        self.filter_feed.after_update()
        self.updates += 1
        stamps = [s for layer in self.layered.layers if isinstance(layer, ObstacleLayer)
                  for b in layer.buffers.values() if (s := b.newest_stamp) is not None]
        if stamps:
            self.newest_observation = max(stamps)

    def publish(self) -> None:
        if self.layered.initialized:
            self.pub.publish(costmap_to_grid(self.costmap, self.now))

    def clear_all(self) -> bool:
        """ClearEntireCostmap, then rebuild at once so callers see the cleared map."""
        self.layered.clear_all()
        self.update()
        return True

    def _clear_around_request(self, reset_distance: float | None) -> bool:
        return self.clear_around(1.0 if reset_distance is None else float(reset_distance))

    def clear_around(self, reset_distance: float) -> bool:
        pose = self.robot_pose()
        if pose is None:
            return False
        self.layered.clear_around((pose.x, pose.y), reset_distance)
        self.update()
        return True
