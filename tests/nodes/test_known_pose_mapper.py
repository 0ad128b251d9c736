"""Mapping with known poses: scans integrated at TF's pose give the world's walls."""

from __future__ import annotations

import numpy as np

from navstack.interfaces.stack import NavStack
from navstack.mapping.map_metrics import occupancy_iou
from navstack.nodes.known_pose_mapper import KnownPoseMapper, KnownPoseMapperParams


def test_known_pose_map_matches_the_world_and_pads_to_the_extent() -> None:
    stack = NavStack("arena", "turtlebot3_waffle_pi", seed=1).start()
    params = KnownPoseMapperParams(max_laser_range=3.5, map_update_interval=0.5,
                                   map_minimum_extent=list(stack.world.bounds))
    mapper = KnownPoseMapper(stack.runtime, params)
    mapper.configure()
    mapper.activate()
    stack.run_for(3.0)
    assert mapper.scans >= 14  # 5 Hz lidar, every scan placed by the TF filter
    latched = stack.runtime.bus.topics["/map"].latched
    assert latched
    grid = latched[-1]  # the mapper's newest map (the map server's true map came first)
    assert grid.header.frame_id == "map" and grid.header.stamp > 2.0
    x0, y0, x1, _y1 = stack.world.bounds
    assert grid.info.origin.position.x <= x0 + 1e-9 and grid.info.origin.position.y <= y0
    assert grid.info.width * grid.info.resolution >= x1 - x0 - 1e-9
    data = np.asarray(grid.data)
    assert (data == 0).sum() > 1000 and (data == 100).sum() > 100 and (data == -1).any()
    score = occupancy_iou(grid, stack.world.to_occupancy_grid())
    assert score.iou >= 0.9  # the poses are exact: only the lidar noise blurs the walls
