"""The simulator on the bus: topics, TF, determinism, bad commands, contact counting."""

import itertools
import math

import numpy as np

from navstack.core.msgs import LaserScan, Odometry, Twist
from navstack.sim.open_loop import build_sim, run_open_loop


def _drive(seed: int, duration: float = 5.0) -> tuple[list[tuple[float, float, float]],
                                                      list[float]]:
    rt, _ = build_sim("office", "diff_drive", seed)
    odom: list[tuple[float, float, float]] = []
    scans: list[float] = []
    rt.bus.subscribe("/odom", Odometry, lambda m: odom.append(
        (m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.orientation.yaw)))
    rt.bus.subscribe("/scan", LaserScan, lambda m: scans.append(float(np.nansum(
        np.where(np.isfinite(m.ranges), m.ranges, 0.0)))))
    pub = rt.bus.publisher("/cmd_vel", Twist)
    rt.scheduler.create_timer(0.05, lambda: pub.publish(Twist.planar(0.3, 0.0, 0.2)), 0.0)
    rt.bring_up()
    rt.scheduler.run_until(duration)
    return odom, scans


def test_same_seed_gives_bit_identical_run() -> None:
    a, b = _drive(3), _drive(3)
    assert a == b
    c = _drive(4)
    assert a[0] != c[0] or a[1] != c[1]  # noise differs with the seed


def test_topics_rates_and_tf_chain() -> None:
    rt, node = build_sim("office", "diff_drive", 0)
    rt.bring_up()
    rt.scheduler.run_until(2.0)
    topics = rt.bus.topics
    assert 9.0 <= topics["/scan"].rate_hz() <= 11.0
    assert 48.0 <= topics["/odom"].rate_hz() <= 52.0
    # map -> odom -> base_link -> lidar all resolve (perfect localization on); map->odom
    # comes at 10 Hz, so it lags the odometry noise of the last 0.1 s (well under 1 mm)
    lidar_frame = node.sim.robot.sensors.lidar.frame_id
    p = rt.tf.lookup_pose2d("map", lidar_frame)
    spawn = node.sim.world.spawn
    mount = node.sim.robot.sensors.lidar.mount
    assert math.isclose(p.x, spawn.x + mount.x, abs_tol=1e-3)
    assert math.isclose(p.y, spawn.y + mount.y, abs_tol=1e-3)


def test_nan_command_is_rejected_counted_and_sim_keeps_running() -> None:
    rt, node = build_sim("office", "diff_drive", 0)
    pub = rt.bus.publisher("/cmd_vel", Twist)
    rt.bring_up()
    pub.publish(Twist.planar(0.2, 0.0, 0.0))
    rt.scheduler.run_until(1.0)
    pub.publish(Twist.planar(float("nan"), 0.0, float("inf")))
    rt.scheduler.run_until(1.5)
    pub.publish(Twist.planar(0.2, 0.0, 0.0))
    rt.scheduler.run_until(2.0)
    node.advance()
    sim = node.sim
    assert sim.rejected_commands == 1
    assert "non-finite" in sim.last_rejection
    assert math.isfinite(sim.pose.x) and sim.pose.x > sim.world.spawn.x + 0.15


def test_driving_into_a_wall_counts_one_collision_and_stalls() -> None:
    # spawn faces east along the corridor: turn north and drive into the corridor wall
    report = run_open_loop("office", "diff_drive", 12.0, 0.4, 0.0, seed=0)
    assert report["collisions"] == 0
    rt, node = build_sim("office", "diff_drive", 0)
    pub = rt.bus.publisher("/cmd_vel", Twist)
    turn = rt.scheduler.create_timer(0.05, lambda: pub.publish(Twist.planar(0.0, 0.0, 1.0)), 0.0)
    rt.bring_up()
    rt.scheduler.run_until(1.5708)
    turn.cancel()
    rt.scheduler.create_timer(0.05, lambda: pub.publish(Twist.planar(0.3, 0.0, 0.0)), 1.6)
    rt.scheduler.run_until(12.0)
    node.advance()
    sim = node.sim
    assert sim.collisions == 1
    assert sim.in_contact
    assert sim.pose.y < 9.0  # stopped at the wall, did not pass through


def test_gyro_odometry_takes_the_yaw_rate_from_the_imu_samples_of_its_period() -> None:
    """``odometry.yaw_rate_source: imu`` (the golf cart): each /odom's yaw rate is the
    mean gyro z of the IMU samples since the previous one (the sample at the same
    instant included, as the cart's Mega reads its IMU before writing the line), the
    speed is the wheels', and the pose is dead-reckoned with them -- the cart driver's
    odometry (drivers/odometry.py) on the same samples."""
    from navstack.core.msgs import Imu
    from navstack.drivers.odometry import DeadReckoning

    rt, node = build_sim("campus", "golf_cart", 5)
    assert node.sim.gyro_odometry
    gyro: list[tuple[float, float]] = []
    odom: list[Odometry] = []
    rt.bus.subscribe("/imu", Imu, lambda m: gyro.append((m.header.stamp, m.angular_velocity.z)))
    rt.bus.subscribe("/odom", Odometry, odom.append)
    pub = rt.bus.publisher("/cmd_vel", Twist)
    rt.scheduler.create_timer(0.05, lambda: pub.publish(Twist.planar(1.5, 0.0, 0.3)), 0.0)
    rt.bring_up()
    rt.scheduler.run_until(4.0)
    assert len(odom) >= 195 and len(gyro) >= 2 * len(odom) - 5
    dr = DeadReckoning(odom[0].pose.pose.position.x, odom[0].pose.pose.position.y,
                       odom[0].pose.pose.orientation.yaw)
    for prev, msg in itertools.pairwise(odom):
        t0, t1 = prev.header.stamp, msg.header.stamp
        window = [w for t, w in gyro if t0 < t <= t1 + 1e-9]
        assert len(window) == 2
        w = msg.twist.twist.angular.z
        assert w == sum(window) / 2
        dr.update(msg.twist.twist.linear.x, w, t1 - t0)
    last = odom[-1].pose.pose
    assert math.isclose(last.position.x, dr.x, abs_tol=1e-9)
    assert math.isclose(last.position.y, dr.y, abs_tol=1e-9)
    assert math.isclose(last.orientation.yaw, dr.yaw, abs_tol=1e-9)
    assert 0.25 < abs(dr.yaw - odom[0].pose.pose.orientation.yaw) < 1.5  # it turned


def test_gyro_odometry_needs_the_imu() -> None:
    import pytest

    from navstack.core.errors import ConfigError
    from navstack.sim.robot import load_robot
    from navstack.sim.simulator import Simulator
    from navstack.sim.worlds import load_world

    robot = load_robot("golf_cart")
    sensors = robot.sensors.model_copy(update={
        "imu": robot.sensors.imu.model_copy(update={"enabled": False})})
    with pytest.raises(ConfigError, match="yaw_rate_source 'imu' needs the IMU"):
        Simulator(load_world("campus"), robot.model_copy(update={"sensors": sensors}))
