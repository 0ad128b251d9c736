"""``NavsatTransformNode`` on the bus: start-up delay, transform broadcast, simulator run."""

from __future__ import annotations

import math

import pytest

from navstack.core.msgs import (
    Header,
    Imu,
    NavSatFix,
    Odometry,
    Pose2D,
    Quaternion,
    TFMessage,
    Twist,
)
from navstack.nodes.navsat import NavsatTransformNode
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world
from tests.localization.navsat_helpers import fix_at, local_params, odom_at


def test_node_publishes_after_delay_and_broadcasts_the_transform() -> None:
    rt = Runtime()
    params = local_params(delay=0.5, frequency=10.0, broadcast_cartesian_transform=True)
    node = NavsatTransformNode(rt, params)
    out: list[Odometry] = []
    rt.bus.subscribe("/odometry/gps", Odometry, out.append)
    pub_fix = rt.bus.publisher("/gps/fix", NavSatFix)
    pub_odom = rt.bus.publisher("/odometry/filtered", Odometry)
    pub_imu = rt.bus.publisher("/imu", Imu)
    rt.bring_up()
    sched = rt.scheduler

    def feed() -> None:
        t = sched.now
        pub_odom.publish(odom_at(1.0 + t, 2.0, 0.0, t=t))
        pub_imu.publish(Imu(Header(t, "base_link"), Quaternion.from_yaw(0.0)))
        pub_fix.publish(fix_at(t, 0.0, t=t, frame="base_link"))

    sched.create_timer(0.1, feed, 0.0)
    sched.run_until(0.45)
    assert not node.core.transform_good  # delay
    sched.run_until(2.0)
    assert node.core.transform_good and out
    last = out[-1].pose.pose.position
    assert (last.x, last.y) == pytest.approx((1.0 + out[-1].header.stamp, 2.0), abs=1e-6)
    assert rt.tf.lookup_pose2d("map", "local_enu").x == pytest.approx(
        node.core.transform.x if node.core.transform else 0.0)
    assert rt.bus.topics["/tf_static"].msg_type is TFMessage


def test_node_in_the_simulator_reproduces_the_true_pose() -> None:
    """golf_cart in the campus with ideal GNSS/IMU: /odometry/gps equals the ground truth
    (antenna 1.2 m ahead of base_link, world rotated 0.6 rad in ENU)."""
    over = {"sensors": {"gnss": {"horizontal_noise_std": 0.0, "vertical_noise_std": 0.0,
                                 "bias_std": 0.0},
                        "imu": {"orientation_noise_std": 0.0},
                        "georeference": {"world_yaw": 0.6}}}
    rt = Runtime()
    SimulatorNode(rt, Simulator(load_world("campus"), load_robot("golf_cart", over), seed=1))
    node = NavsatTransformNode(rt, local_params(yaw_offset=0.6))
    truth: dict[float, Pose2D] = {}
    relay_pub = rt.bus.publisher("/odometry/filtered", Odometry)

    def relay(m: Odometry) -> None:  # perfect /odometry/filtered: the true pose in map
        truth[round(m.header.stamp, 6)] = m.pose.pose.to_pose2d()
        relay_pub.publish(m)

    rt.bus.subscribe("/ground_truth", Odometry, relay)
    out: list[Odometry] = []
    rt.bus.subscribe("/odometry/gps", Odometry, out.append)
    cmd = rt.bus.publisher("/cmd_vel", Twist)
    rt.scheduler.create_timer(0.05, lambda: cmd.publish(Twist.planar(1.5, 0.0, 0.0)), 0.0)
    rt.bring_up()
    rt.scheduler.run_until(6.0)
    assert node.core.transform_good and len(out) >= 20
    errs = [math.hypot(o.pose.pose.position.x - truth[round(o.header.stamp, 6)].x,
                       o.pose.pose.position.y - truth[round(o.header.stamp, 6)].y)
            for o in out if round(o.header.stamp, 6) in truth]
    assert len(errs) >= 20 and max(errs) < 0.02
