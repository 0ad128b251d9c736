"""Several robots in one world: mutual lidar, robot-robot contact, shared walkers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D, Twist2D
from navstack.sim.fleet import FleetMember, FleetSimulator
from navstack.sim.robot import load_robot
from navstack.sim.worlds import load_world


@pytest.fixture(scope="module")
def warehouse():
    return load_world("warehouse")


@pytest.fixture(scope="module")
def robot():
    return load_robot("diff_drive")


def pair(world, robot, gap_centres: float) -> FleetSimulator:
    """Two robots facing each other in the open loading area, ``gap_centres`` apart."""
    return FleetSimulator(world, [FleetMember("a", robot, Pose2D(24.0, 4.0, 0.0)),
                                  FleetMember("b", robot, Pose2D(24.0 + gap_centres, 4.0,
                                                                 math.pi))], seed=3)


def test_lidar_sees_the_other_robot_body(warehouse, robot):
    fleet = pair(warehouse, robot, 2.0)
    a = fleet.sim("a")
    ranges = a.true_ranges()
    ahead = int(np.argmin(np.abs(a.lidar.beam_angles)))
    # the peer's 0.22 m body: its near face is 2.0 - 0.22 m ahead (polygon, within 5 mm)
    assert ranges[ahead] == pytest.approx(2.0 - 0.22, abs=0.005)
    alone = FleetSimulator(warehouse, [FleetMember("a", robot, Pose2D(24.0, 4.0, 0.0))])
    assert alone.sim("a").true_ranges()[ahead] > 5.0  # nothing there without the peer


def test_driving_into_another_robot_is_blocked_and_counted(warehouse, robot):
    fleet = pair(warehouse, robot, 1.0)
    a, b = fleet.sim("a"), fleet.sim("b")
    for k in range(150):  # 3 s at 0.5 m/s: would drive 1.5 m through b
        a.set_command(Twist2D(0.5, 0.0, 0.0), fleet.time)
        fleet.advance_to((k + 1) * 0.02)
    assert a.collisions == 1 and a.robot_collisions == 1
    assert b.collisions == 0 and b.robot_collisions == 0  # b stood still: not its fault
    assert fleet.min_separation < 0.02  # stopped at contact, not through
    assert a.pose.x < b.pose.x - 0.43   # bodies (0.22 m radius each) never overlap
    assert b.pose.x == pytest.approx(25.0)
    assert fleet.collisions == 1 and fleet.robot_collisions == 1


def test_separation_is_the_body_gap(warehouse, robot):
    fleet = pair(warehouse, robot, 3.0)
    # 16-gon bodies of radius 0.22: the gap is 3.0 - 2 * 0.22 within the polygon sag
    assert fleet.min_separation == pytest.approx(3.0 - 0.44, abs=0.01)
    assert fleet.min_separation_at is not None and fleet.min_separation_at[1:] == ("a", "b")


def test_walkers_are_shared_and_yield_to_every_robot(warehouse, robot):
    # the worker's loop passes (36, 4); robot b stands right in its way, robot a far off
    fleet = FleetSimulator(warehouse, [FleetMember("a", robot, Pose2D(2.0, 20.0, 0.0)),
                                       FleetMember("b", robot, Pose2D(35.0, 4.0, 0.0))])
    a, b = fleet.sim("a"), fleet.sim("b")
    fleet.advance_to(60.0)
    assert a.obstacle_clocks == b.obstacle_clocks  # one world, one walker
    assert a.collisions == b.collisions == 0       # the worker stopped for b
    clock = a.obstacle_clocks[1]
    circles, _ = warehouse.moving_shapes_at(a.obstacle_clocks)
    worker = circles[0]
    assert math.hypot(worker[0] - 35.0, worker[1] - 4.0) > 0.22 + 0.3
    assert clock < 60.0  # it was held (a walker alone walks 60 s of clock in 60 s)


def test_bad_fleets_are_refused_naming_the_robot(warehouse, robot):
    with pytest.raises(ConfigError, match=r"robot 'b' spawned at .* overlaps robot 'a'"):
        pair(warehouse, robot, 0.3)
    with pytest.raises(ConfigError, match=r"fleet.robots\[0\].spawn.*overlaps an obstacle"):
        FleetSimulator(warehouse, [FleetMember("a", robot, Pose2D(6.5, 14.0, 0.0))])
    with pytest.raises(ConfigError, match=r"\['a'\] repeat"):
        FleetSimulator(warehouse, [FleetMember("a", robot, Pose2D(24.0, 4.0, 0.0)),
                                   FleetMember("a", robot, Pose2D(28.0, 4.0, 0.0))])
    with pytest.raises(ConfigError, match="no robot 'c' in the fleet; robots: a, b"):
        pair(warehouse, robot, 2.0).sim("c")
