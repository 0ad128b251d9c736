"""The rover's GPS legs in the simulator: heading calibration, the PI chase and the
gps_goal_fix loop reach lat/lon goals (true distance) in a world rotated against
east-north with the rover's noisy GNSS; the oscillation guard stops a chase."""

from __future__ import annotations

import math
from importlib import resources

import pytest

from navstack.core.msgs import Pose2D, Twist
from navstack.geo.conversions import GeoError
from navstack.interfaces.stack import NavStack
from navstack.missions.gps_legs import (
    CalibrationParams,
    GpsChaseLeg,
    GpsChaseLegParams,
    GpsGoalFixLeg,
    GpsGoalFixParams,
    HeadingCalibration,
    LegStatus,
)
from navstack.sim.course import world_to_ll
from navstack.sim.robot import GeoReferenceParams, load_robot
from navstack.sim.world_io import world_from_mapping

GEO = GeoReferenceParams(world_yaw=0.35)


def _stack(seed: int = 2) -> NavStack:
    world = world_from_mapping({
        "name": "gps_pad", "resolution": 0.1, "size": [30.0, 30.0],
        "circles": [{"center": [12.0, 14.0], "radius": 0.8}],
        "spawn": {"x": 5.0, "y": 5.0, "yaw": 0.3}})
    robot = load_robot("rover", {"sensors": {"georeference": GEO.model_dump()}})
    params = str(resources.files("navstack") / "config" / "rover_nav2_params.yaml")
    return NavStack(world, robot, params, seed=seed).start()


def _calibrate(stack: NavStack) -> HeadingCalibration:
    cal = HeadingCalibration(stack.runtime)
    cal.start()
    while cal.status is LegStatus.RUNNING:
        assert stack.now < 10.0
        stack.run_for(0.1)
    return cal


def _run(stack: NavStack, leg: GpsChaseLeg | GpsGoalFixLeg, x: float, y: float) -> float:
    leg.start(*world_to_ll(GEO, x, y))
    while leg.status is LegStatus.RUNNING:
        stack.run_for(0.5)
    stack.run_for(1.0)
    p = stack.sim.sim.pose
    return math.hypot(p.x - x, p.y - y)


def test_calibration_then_pi_chase_then_gps_goal_fix_reach_the_goals() -> None:
    stack = _stack()
    cal = _calibrate(stack)
    assert cal.status is LegStatus.SUCCEEDED, cal.reason
    # the bearing of odom's x axis: the spawn heading in ENU (0.3 + 0.35 rad from east)
    true_axis = math.degrees(math.pi / 2 - 0.65)
    assert abs(math.remainder(cal.course_deg - true_axis, 360.0)) < 2.0
    assert cal.origin is not None and cal.origin.course_deg == cal.course_deg
    # the rover drove ~3 m straight ahead
    p = stack.sim.sim.pose
    assert math.hypot(p.x - 5.0, p.y - 5.0) == pytest.approx(3.0, abs=0.8)
    antenna = (-0.4, 0.0)
    chase = GpsChaseLeg(stack.runtime, cal.course_deg, GpsChaseLegParams(antenna=antenna))
    dist = _run(stack, chase, 18.0, 10.0)
    assert chase.status is LegStatus.SUCCEEDED, chase.reason
    assert "within 0.88 m of the GPS goal" in chase.reason
    assert dist <= 3.0 and chase.goals_sent >= 3
    fix = GpsGoalFixLeg(stack.runtime, cal.course_deg, GpsGoalFixParams(antenna=antenna))
    dist = _run(stack, fix, 20.0, 22.0)
    assert fix.status is LegStatus.SUCCEEDED, fix.reason
    assert "accepting 10 m" in fix.reason
    assert dist <= 3.0
    assert stack.sim.sim.collisions == 0


def test_gps_goal_fix_resends_more_often_as_the_rover_nears() -> None:
    stack = _stack()
    leg = GpsGoalFixLeg(stack.runtime, 0.0)
    periods = [leg.resend_period(d) for d in (60.0, 30.0, 12.0, 6.0, 2.0)]
    assert periods == [10.0, 7.5, 3.0, 1.5, 1.0]


def test_oscillating_commands_stop_the_chase() -> None:
    stack = _stack()
    # no fixes are enough to start chasing: only the constructed commands move the rover
    leg = GpsChaseLeg(stack.runtime, 0.0, GpsChaseLegParams(min_fixes=10_000))
    leg.start(*world_to_ll(GEO, 20.0, 20.0))
    cmd = stack.runtime.bus.publisher("/cmd_vel", Twist)
    for k in range(120):  # left-right turns every 0.5 s for 12 s
        cmd.publish(Twist.planar(0.0, 0.0, 0.6 if (k // 5) % 2 == 0 else -0.6))
        stack.run_for(0.1)
        if leg.status is not LegStatus.RUNNING:
            break
    assert leg.status is LegStatus.FAILED
    assert leg.reason.startswith("oscillating: ")
    assert "angular" in leg.reason and leg.goals_sent == 0


def test_calibration_without_speed_fails_clearly() -> None:
    stack = _stack()
    cal = HeadingCalibration(stack.runtime, CalibrationParams(speed=0.2, min_speed=0.75))
    cal.start()
    while cal.status is LegStatus.RUNNING and stack.now < 10.0:
        stack.run_for(0.1)
    assert cal.status is LegStatus.FAILED
    assert "reached 0.75 m/s; drive straight faster or longer" in cal.reason


def test_bad_goal_coordinates_name_the_field() -> None:
    stack = _stack()
    leg = GpsChaseLeg(stack.runtime, 0.0)
    with pytest.raises(GeoError, match=r"goal\.longitude: '-110;47' is not a longitude"):
        leg.start("38,24,23", "-110;47")
    assert leg.status is LegStatus.IDLE
    assert stack.sim.sim.pose == Pose2D(5.0, 5.0, 0.3)
