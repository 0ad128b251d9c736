"""``PointCloudToLaserScanNode``: ``cloud_in`` (PointCloud2) -> ``scan`` (LaserScan).

Transforms each cloud into ``target_frame`` with the runtime's TF at the cloud's stamp (a
cloud whose transform is not available is dropped and counted in ``dropped_tf``; the
static ``base_link -> sensor`` mount of a lidar always is) and flattens it with
:func:`navstack.perception.pointcloud_to_laserscan.pointcloud_to_laserscan`.  Topic names
are the ROS node's (``cloud_in`` / ``scan``), absolute here.
"""

from __future__ import annotations

import math

import numpy as np

from navstack.core.errors import TransformError
from navstack.core.msgs import Header, LaserScan, PointCloud2
from navstack.perception.pointcloud_to_laserscan import (
    PointCloudToLaserScanParams,
    pointcloud_to_laserscan,
)
from navstack.runtime.bus import SENSOR_DATA
from navstack.runtime.node import Node, Runtime

__all__ = ["PointCloudToLaserScanNode"]


class PointCloudToLaserScanNode(Node):
    def __init__(self, runtime: Runtime, params: PointCloudToLaserScanParams,
                 cloud_topic: str = "/cloud_in", scan_topic: str = "/scan",
                 name: str = "pointcloud_to_laserscan") -> None:
        super().__init__(name, runtime)
        self.params = params
        self.cloud_topic, self.scan_topic = cloud_topic, scan_topic
        self.scans = 0
        self.dropped_tf = 0
        self.last_error = ""

    def on_configure(self) -> None:
        self.pub = self.create_publisher(self.scan_topic, LaserScan, SENSOR_DATA)
        self.create_subscription(self.cloud_topic, PointCloud2, self._on_cloud, SENSOR_DATA)

    def _on_cloud(self, cloud: PointCloud2) -> None:
        p = self.params
        xyz = cloud.xyz()
        frame = cloud.header.frame_id
        target = p.target_frame or frame
        if target != frame:
            try:
                tf = self.tf.lookup(target, frame, cloud.header.stamp)
            except TransformError as exc:
                self.dropped_tf += 1
                self.last_error = str(exc)
                return
            t, q = tf.transform.translation, tf.transform.rotation
            R = _rotation(q.x, q.y, q.z, q.w)
            xyz = xyz @ R.T + np.array([t.x, t.y, t.z])
        scan = pointcloud_to_laserscan(xyz, p, Header(cloud.header.stamp, target))
        self.scans += 1
        self.pub.publish(scan)


def _rotation(x: float, y: float, z: float, w: float) -> np.ndarray:
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
