"""The chaos suite's fault injection, one fault at a time, on a real stack."""

from __future__ import annotations

import math

import pytest

from navstack.benchmarks.chaos import (
    FAULT_KINDS,
    Fault,
    _route,
    attach_fault,
    chaos_trips,
    navigator_give_up_s,
    parse_faults,
    robot_with_fault,
    trip_timeout_s,
    world_with_fault,
)
from navstack.core.errors import ConfigError
from navstack.core.msgs import LaserScan, Pose2D, TFMessage
from navstack.interfaces.stack import NavStack
from navstack.sim.robot import load_robot
from navstack.sim.worlds import load_world


def test_trips_are_deterministic_and_cycle_through_the_faults() -> None:
    a = chaos_trips(24, 3, FAULT_KINDS)
    b = chaos_trips(24, 3, FAULT_KINDS)
    assert a == b
    kinds = [t[4].kind if t[4] else "nominal" for t in a]
    assert kinds[:3] == ["nominal"] * 3
    assert set(kinds) == {"nominal", *FAULT_KINDS}
    assert all(t[0].startswith(f"chaos_{i:04d}_{t[1]}_") for i, t in enumerate(a))
    assert chaos_trips(24, 4, FAULT_KINDS) != a


def test_time_limit_leaves_the_navigator_time_to_fail_a_stuck_goal_itself() -> None:
    """7 rounds of FollowPath + its retry (10 s progress dwell each) and 6 recoveries
    of at most 10 s: a stuck goal ends FAILED with the navigator's reason by 200 s."""
    assert navigator_give_up_s() == 7 * 2 * 10.0 + 6 * 10.0
    trips = chaos_trips(6, 7, FAULT_KINDS)
    for _name, _world, start, goal, _fault, timeout in trips:
        dist = math.hypot(goal.x - start.x, goal.y - start.y)
        assert timeout == trip_timeout_s(dist) == 220.0 + 10.0 * dist


def test_benchmark_time_limit_says_what_the_robot_was_doing() -> None:
    from dataclasses import replace

    from navstack.benchmarks.navigation import chaos_suite, failure_category, run_scenario

    sc = replace(chaos_suite(1, 7, "none")[0], timeout_s=3.0)
    out = run_scenario(sc, seed=0)
    assert out.status == "TIMEOUT"
    assert out.reason.startswith("timed out after 3 s: navigating (FollowPath), 0 of 6 "
                                 "recoveries used; ")
    assert out.reason.endswith(f"{out.final_dist_m:.2f} m from the goal")
    assert failure_category(out) == "timeout: navigating (FollowPath)"


def test_parse_faults_names_the_bad_one() -> None:
    assert parse_faults("all") == FAULT_KINDS
    assert parse_faults("none") == ()
    assert parse_faults("kidnap, crowd") == ("kidnap", "crowd")
    with pytest.raises(ConfigError, match="unknown fault 'kidnapping'"):
        parse_faults("kidnap,kidnapping")
    with pytest.raises(ConfigError, match="unknown fault 'x'"):
        Fault("x")


def test_sensor_faults_change_the_robot_profile_only() -> None:
    robot = load_robot("diff_drive")
    lidar = robot_with_fault(robot, Fault("lidar_dropout", 0.1)).sensors.lidar
    assert (lidar.dropout_prob, lidar.scan_dropout_prob) == (0.1, 0.1)
    assert robot_with_fault(robot, Fault("odom_slip", 0.05)).sensors.odometry.slip_prob == 0.05
    assert robot.sensors.lidar.scan_dropout_prob == 0.0  # the profile itself is unchanged
    assert robot_with_fault(robot, Fault("kidnap", 1.0)) is robot


def test_blocked_box_sits_on_the_route_and_leaves_a_detour() -> None:
    trips = [t for t in chaos_trips(40, 7, ("blocked",)) if t[4] is not None]
    assert trips
    for _name, wname, start, goal, fault, _ in trips:
        assert fault is not None and fault.box is not None
        world = load_world(wname)
        blocked = world_with_fault(world, fault)
        x0, y0, x1, y1 = fault.box
        r, c = blocked.world_to_cell((x0 + x1) / 2, (y0 + y1) / 2)
        assert blocked.occupied[r, c] and not world.occupied[r, c]
        free = blocked.distance_field() >= 0.55
        assert _route(free, blocked.world_to_cell(start.x, start.y),
                      blocked.world_to_cell(goal.x, goal.y)) is not None


def test_crowd_adds_walkers_clear_of_start_and_goal() -> None:
    trips = [t for t in chaos_trips(40, 7, ("crowd",)) if t[4] is not None]
    for _name, wname, start, goal, fault, _ in trips:
        assert fault is not None and fault.level == len(fault.walkers) >= 1
        world = load_world(wname)
        crowd = world_with_fault(world, fault)
        assert len(crowd.moving_obstacles) == len(world.moving_obstacles) + len(fault.walkers)
        for x0, y0, x1, y1, _speed in fault.walkers:
            for px, py in ((x0, y0), (x1, y1)):
                assert math.hypot(px - start.x, py - start.y) >= 1.2
                assert math.hypot(px - goal.x, py - goal.y) >= 1.2


def _stamps(stack: NavStack, topic: str) -> list[tuple[float, float]]:
    seen: list[tuple[float, float]] = []

    def tap(name: str, msg: object, now: float) -> None:
        if name == topic and isinstance(msg, LaserScan):
            seen.append((msg.header.stamp, now))
        elif name == topic and isinstance(msg, TFMessage) and msg.transforms:
            seen.append((msg.transforms[0].header.stamp, now))

    stack.runtime.bus.add_tap(tap)
    return seen


@pytest.mark.parametrize(("kind", "topic", "delay"), [("scan_latency", "/scan", 0.2),
                                                      ("tf_delay", "/tf", 0.05)])
def test_latency_faults_deliver_late_with_the_measurement_stamp(kind: str, topic: str,
                                                                delay: float) -> None:
    stack = NavStack("office", seed=0).start()
    attach_fault(stack, Fault(kind, delay))
    seen = _stamps(stack, topic)
    stack.run_for(1.0)
    assert len(seen) >= 5
    for stamp, arrived in seen:
        assert arrived - stamp == pytest.approx(delay, abs=1e-9)


def test_kidnap_moves_the_robot_at_the_given_time() -> None:
    stack = NavStack("office", seed=0).start()
    p0 = stack.sim.sim.pose
    events = attach_fault(stack, Fault("kidnap", 1.0, at_s=0.5))
    stack.run_for(0.4)
    assert stack.sim.sim.pose == p0 and events == []
    stack.run_for(0.2)
    p1 = stack.sim.sim.pose
    assert math.hypot(p1.x - p0.x, p1.y - p0.y) == pytest.approx(1.0, abs=1e-9)
    assert events == [f"kidnapped 1.00 m at t=0.5 s from (1.00, 7.50) to "
                      f"({p1.x:.2f}, {p1.y:.2f})"]
    assert stack.sim.sim.collisions == 0
    assert isinstance(p1, Pose2D)


def test_no_trip_starts_on_a_walker_or_the_forklift() -> None:
    """The seed-7 draw once placed four starts under a walker or the forklift at t = 0:
    collisions no navigation could avoid."""
    from navstack.benchmarks.chaos import CLEARANCE_M, world_with_fault
    from navstack.sim.worlds import load_world

    trips = chaos_trips(400, 7, FAULT_KINDS)
    worlds = {name: load_world(name) for name in {t[1] for t in trips}}
    movers_seen = 0
    for _, wname, start, _, fault, _ in trips:
        for mover in world_with_fault(worlds[wname], fault).moving_obstacles:
            movers_seen += 1
            x, y, _ = mover.pose_at(0.0)
            extent = mover.radius if mover.shape == "circle" else 0.5 * math.hypot(*mover.size)
            assert math.hypot(x - start.x, y - start.y) >= extent + CLEARANCE_M, (wname, mover.name)
    assert movers_seen > 0
