"""``CollisionMonitorNode``: ``/cmd_vel_nav`` -> approach check on raw ``/scan`` -> ``/cmd_vel``.

The last stage before the base (ARCHITECTURE.md §2): scan points are brought into
``base_link`` with TF at the scan's stamp; every incoming command is filtered by
:class:`navstack.control.collision_monitor.ApproachMonitor` and republished.
"""

from __future__ import annotations

import numpy as np

from navstack.control.collision_monitor import ApproachMonitor, ApproachParams
from navstack.core.errors import TransformError
from navstack.core.geometry import se2_apply
from navstack.core.msgs import LaserScan, Twist
from navstack.core.polygon import Footprint
from navstack.runtime.bus import SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime


class CollisionMonitorNode(Node):
    """Filters velocity commands against the latest scan (Nav2 collision_monitor)."""

    def __init__(self, runtime: Runtime, footprint: Footprint,
                 params: ApproachParams | None = None, cmd_in: str = "/cmd_vel_nav",
                 cmd_out: str = "/cmd_vel", scan_topic: str = "/scan",
                 base_frame: str = "base_link", name: str = "collision_monitor") -> None:
        super().__init__(name, runtime)
        self.monitor = ApproachMonitor(footprint.polygon, params)
        self.cmd_in, self.cmd_out, self.scan_topic = cmd_in, cmd_out, scan_topic
        self.base_frame = base_frame
        self.points = np.zeros((0, 2))
        self.slowed = 0

    def on_configure(self) -> None:
        self.pub = self.create_publisher(self.cmd_out, Twist, QoS(depth=1))
        self.create_subscription(self.scan_topic, LaserScan, self._on_scan, SENSOR_DATA)
        self.create_subscription(self.cmd_in, Twist, self._on_cmd, QoS(depth=1))

    def _on_scan(self, scan: LaserScan) -> None:
        try:
            mount = self.tf.lookup_pose2d(self.base_frame, scan.header.frame_id)
        except TransformError:
            return
        self.points = se2_apply(mount.as_array(), scan.points())

    def _on_cmd(self, msg: Twist) -> None:
        cmd = msg.to_twist2d()
        out = self.monitor.filter(cmd, self.points)
        if out != cmd:
            self.slowed += 1
        self.pub.publish(out.to_twist())
