"""ControllerServer keeps the plan it hands the controller in step with ``odom <- map``."""

from __future__ import annotations

import numpy as np

from navstack.core.msgs import Path, Pose2D
from navstack.core.tf import tf_from_pose2d, tf_to_stamped
from navstack.navigation.controller_server import ControllerServer
from navstack.navigation.costmap_node import CostmapNode
from navstack.runtime.node import Runtime

LOCAL = {"global_frame": "odom", "rolling_window": True, "width": 4, "height": 4,
         "resolution": 0.05, "update_frequency": 5.0, "plugins": []}


def _server() -> tuple[Runtime, ControllerServer]:
    rt = Runtime()
    costmap = CostmapNode(rt, "local_costmap", LOCAL)
    server = ControllerServer(rt, {"controller_plugins": ["FollowPath"],
                                   "FollowPath": {"plugin": "dwb_core::DWBLocalPlanner"}},
                              costmap)
    return rt, server


def _map_to_odom(rt: Runtime, pose: Pose2D) -> None:
    rt.tf.set_transform(tf_to_stamped(tf_from_pose2d(pose), "map", "odom", rt.now))


def test_a_small_turn_far_from_the_map_origin_moves_the_plan() -> None:
    """0.003 rad of ``map -> odom`` correction moves a plan 50 m from the map origin by
    0.15 m: the plan is re-transformed, not left at the old correction."""
    rt, server = _server()
    xs = np.linspace(50.0, 52.0, 41)
    plan = Path.from_array(np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)]),
                           "map", 0.0)
    _map_to_odom(rt, Pose2D())
    first = server._plan_in(plan, "odom")
    np.testing.assert_allclose(first.as_array()[:, 0], xs)
    _map_to_odom(rt, Pose2D(0.0, 0.0, 0.003))
    second = server._plan_in(plan, "odom")
    assert second is not first
    # odom <- map turned by -0.003 rad: the plan's start moved 0.15 m in y
    assert abs(second.as_array()[0, 1] + 50.0 * np.sin(0.003)) < 1e-9
    # jitter that moves no pose by 1 cm keeps the same plan object (DWB's critics persist)
    _map_to_odom(rt, Pose2D(0.002, 0.0, 0.003 + 1e-4))
    assert server._plan_in(plan, "odom") is second
