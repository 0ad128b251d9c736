"""CostmapNode: a scan waits for the odometry of its own instant (Nav2's obstacle layer
tf2 MessageFilter, ``tf_filter_tolerance``).

The simulator publishes a scan and the odometry of the same instant in either order.  A
scan looked up before its odometry arrived was dropped: in the flagship demo the local
costmap then got no scan for minutes and drove on stale obstacle marks (the robot
stopped beside a wall that was 0.2 m away from where the costmap had it).
"""

from __future__ import annotations

import math

import numpy as np

from navstack.core.msgs import (
    Header,
    LaserScan,
    Pose2D,
    TFMessage,
    Transform,
    TransformStamped,
)
from navstack.navigation.costmap_node import CostmapNode
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime

PARAMS = {"global_frame": "odom", "robot_base_frame": "base_link", "rolling_window": True,
          "width": 4, "height": 4, "resolution": 0.05, "update_frequency": 10.0,
          "robot_radius": 0.2, "plugins": ["obstacle_layer"],
          "obstacle_layer": {"plugin": "nav2_costmap_2d::ObstacleLayer",
                             "observation_sources": "scan",
                             "scan": {"topic": "/scan", "data_type": "LaserScan",
                                      "marking": True, "clearing": True}}}


def _rig() -> tuple[Runtime, CostmapNode, object, object]:
    rt = Runtime()
    node = CostmapNode(rt, "local_costmap", PARAMS)
    rt.bring_up()
    tf_pub = rt.bus.publisher("/tf", TFMessage, QoS(depth=100))
    scan_pub = rt.bus.publisher("/scan", LaserScan)
    return rt, node, tf_pub, scan_pub


def _odom(tf_pub: object, t: float) -> None:
    tf_pub.publish(TFMessage((  # type: ignore[attr-defined]
        TransformStamped(Header(t, "odom"), "base_link",
                         Transform.from_pose2d(Pose2D(0.0, 0.0, 0.0))),)))


def _scan(scan_pub: object, t: float) -> None:
    ranges = np.full(360, 1.0, np.float32)  # a round wall 1 m away
    scan_pub.publish(LaserScan(Header(t, "base_link"), -math.pi,  # type: ignore[attr-defined]
                               math.pi - 2 * math.pi / 360, 2 * math.pi / 360, 0.0, 0.1, 0.05,
                               10.0, ranges, np.zeros(0, np.float32)))


def test_a_scan_published_before_its_odometry_is_used() -> None:
    rt, node, tf_pub, scan_pub = _rig()
    _odom(tf_pub, 0.0)
    rt.scheduler.run_until(0.1)
    _scan(scan_pub, 0.1)  # the odometry of t=0.1 is not in the buffer yet ...
    _odom(tf_pub, 0.1)  # ... it comes right after
    rt.scheduler.run_until(0.2)
    layer = node.layered.layers[0]
    buf = next(iter(layer.buffers.values()))  # type: ignore[attr-defined]
    assert buf.last_updated == 0.1
    assert node.tf_failures == 0
    cm = node.costmap
    cell = cm.world_to_map(1.0 + 1e-3, 0.0)
    assert cell is not None and cm.data[cell[1], cell[0]] == 254


def test_a_scan_whose_odometry_never_comes_is_dropped_after_the_tolerance() -> None:
    rt, node, tf_pub, scan_pub = _rig()
    _odom(tf_pub, 0.0)
    rt.scheduler.run_until(0.1)
    _scan(scan_pub, 0.1)
    assert node.tf_failures == 0  # waiting (tf_filter_tolerance 0.05 s)
    rt.scheduler.run_until(0.3)
    assert node.tf_failures == 1
    assert node.last_tf_error.startswith("scan on /scan at t=0.100 dropped: ")
    buf = next(iter(node.layered.layers[0].buffers.values()))  # type: ignore[attr-defined]
    assert buf.last_updated is None
