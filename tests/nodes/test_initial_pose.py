"""``InitialPoseNode`` in the simulator: /initialpose from GNSS, magnetometer and the scan."""

from __future__ import annotations

import math

from navstack.core.msgs import OccupancyGrid, Pose2D, PoseWithCovarianceStamped
from navstack.localization.initial_pose import InitialPoseParams
from navstack.nodes.initial_pose import InitialPoseNode
from navstack.runtime.bus import LATCHED
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world

DATUM = (47.3769, 8.5417, 400.0)


def test_node_publishes_initialpose_in_the_simulator() -> None:
    over = {"sensors": {"gnss": {"enabled": True, "mount": {"x": 0.1, "z": 0.3}},
                        "magnetometer": {"enabled": True, "declination": 0.2,
                                         "heading_offset": math.radians(10.0)},
                        "georeference": {"latitude": DATUM[0], "longitude": DATUM[1],
                                         "altitude": DATUM[2], "world_yaw": 0.4}}}
    world = load_world("office")
    rt = Runtime()
    SimulatorNode(rt, Simulator(world, load_robot("turtlebot", over), seed=2,
                                spawn=Pose2D(12.0, 3.0, 2.0)))
    params = InitialPoseParams(datum=DATUM, map_from_enu=(0.0, 0.0, -0.4),
                               magnetic_declination=0.2)
    node = InitialPoseNode(rt, params)
    rt.bus.publisher("/map", OccupancyGrid, LATCHED).publish(world.to_occupancy_grid())
    got: list[PoseWithCovarianceStamped] = []
    rt.bus.subscribe("/initialpose", PoseWithCovarianceStamped, got.append)
    rt.bring_up()
    rt.scheduler.run_until(1.0)
    assert len(got) == 1 and node.estimate is not None and node.estimate.refined
    pose = got[0].pose.pose.to_pose2d()
    assert pose.distance_to(Pose2D(12.0, 3.0, 2.0)) < 0.05
    assert abs(pose.theta - 2.0) < math.radians(1.0)
    assert node.estimate.guess.distance_to(pose) > 0.1  # the scan match did the work
