"""``EkfNode`` on the bus: inputs, frames, rejections, sensor timeouts, TF output."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.geometry import rpy_to_quaternion
from navstack.core.msgs import (
    Header,
    Imu,
    Odometry,
    Point,
    Pose,
    Pose2D,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    TFMessage,
    Transform,
    TransformStamped,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from navstack.localization.ekf import EkfParams, MeasurementBuilder
from navstack.localization.ekf.model import AX, AY, AZ, VX, VY, VYAW, YAW
from navstack.nodes.ekf import EkfNode
from navstack.runtime.node import Runtime

F, T = False, True
TWIST_CFG = [F] * 6 + [T, T, F, F, F, T] + [F] * 3
POSE_CFG = [T, T, F, F, F, T] + [F] * 9


def _odom(t: float, x: float, y: float, yaw: float, vx: float, wz: float = 0.0,
          var: float = 1e-4) -> Odometry:
    cov = np.eye(6) * var
    return Odometry(Header(t, "odom"), "base_link",
                    PoseWithCovariance(Pose2D(x, y, yaw).to_pose(), cov),
                    TwistWithCovariance(Twist.planar(vx, 0.0, wz), cov.copy()))


def _pose_msg(t: float, x: float, y: float, yaw: float, var: float = 0.01,
              frame: str = "odom") -> PoseWithCovarianceStamped:
    return PoseWithCovarianceStamped(Header(t, frame),
                                     PoseWithCovariance(Pose2D(x, y, yaw).to_pose(),
                                                        np.eye(6) * var))


def _node(config: dict[str, object]) -> tuple[Runtime, EkfNode]:
    rt = Runtime()
    node = EkfNode(rt, EkfParams.from_mapping(config))
    rt.bring_up()
    return rt, node


def test_straight_line_odometry_gives_the_exact_pose_and_tf() -> None:
    rt, node = _node({"two_d_mode": True, "odom0": "odom",
                      "odom0_config": [T, T, F, F, F, T, T, T, F, F, F, T, F, F, F]})
    pub = rt.bus.publisher("/odom", Odometry)
    out: list[Odometry] = []
    rt.bus.subscribe("/odometry/filtered", Odometry, out.append)
    heading, v = math.radians(-40.0), 0.4

    def send() -> None:
        t = rt.now
        d = v * t
        if t <= 10.0 + 1e-9:
            pub.publish(_odom(t, d * math.cos(heading), d * math.sin(heading), heading, v))

    rt.scheduler.create_timer(0.02, send, first_at=0.0)
    rt.scheduler.run_until(10.05)  # one more filter tick (at 10.033 s) fuses the last one
    x, t_f = node.estimate, node.filter.last_measurement_time
    assert t_f == pytest.approx(10.0)  # the filter time is the newest fused stamp
    d = v * t_f
    assert x[0] == pytest.approx(d * math.cos(heading), abs=1e-9)
    assert x[1] == pytest.approx(d * math.sin(heading), abs=1e-9)
    assert x[YAW] == pytest.approx(heading, abs=1e-12) and x[VX] == pytest.approx(v)
    last = out[-1]
    assert last.header.frame_id == "odom" and last.child_frame_id == "base_link"
    assert last.header.stamp == t_f
    assert last.pose.pose.to_pose2d().distance_to(Pose2D(x[0], x[1])) == 0.0
    assert len(out) == 301  # one output per 30 Hz tick, each with new data
    tf = rt.tf.lookup_pose2d("odom", "base_link", t_f)
    assert tf.x == pytest.approx(x[0], abs=1e-12) and tf.theta == pytest.approx(heading)
    assert len(node.update_ms) == 2 * 501 and node.rejected == {}  # pose + twist parts


def test_outlier_pose_is_gated_and_counted() -> None:
    rt, node = _node({"two_d_mode": True, "pose0": "pose", "pose0_config": POSE_CFG,
                      "pose0_rejection_threshold": 3.0})
    pub = rt.bus.publisher("/pose", PoseWithCovarianceStamped)
    for k in range(10):
        rt.scheduler.call_at(0.1 * k, pub.publish, _pose_msg(0.1 * k, 2.0, 1.0, 0.5))
    rt.scheduler.run_until(1.0)
    before = node.estimate.copy()
    pub.publish(_pose_msg(1.0, 2.0, 4.0, 0.5))  # 3 m off with 0.1 m std
    rt.scheduler.run_until(1.5)
    np.testing.assert_array_equal(node.estimate, before)
    assert node.rejected == {"pose0": 1}
    assert node.rejection_reasons == {("pose0", "mahalanobis"): 1}
    reason = node.filter.last_rejection["pose0"]
    assert reason.startswith("pose0 at t=1.000000 s: Mahalanobis distance ")
    assert reason.endswith(">= rejection threshold 3")


def test_non_finite_odometry_is_rejected_with_reason_and_state_kept() -> None:
    rt, node = _node({"two_d_mode": True, "odom0": "odom", "odom0_config": TWIST_CFG})
    pub = rt.bus.publisher("/odom", Odometry)
    for k in range(5):
        rt.scheduler.call_at(0.1 * k, pub.publish, _odom(0.1 * k, 0.0, 0.0, 0.0, 0.3))
    rt.scheduler.run_until(0.45)
    before = node.estimate.copy()
    pub.publish(_odom(0.45, 0.0, 0.0, 0.0, math.nan))
    rt.scheduler.run_until(0.46)
    assert node.rejected == {"odom0": 1}
    assert node.filter.last_rejection["odom0"] == "odom0: non-finite value in twist.twist"
    assert node.rejection_reasons == {("odom0", "non-finite"): 1}
    np.testing.assert_array_equal(node.estimate, before)
    pub.publish(_odom(0.5, 0.0, 0.0, 0.0, 0.3))  # the filter goes on
    rt.scheduler.run_until(0.6)
    assert node.filter.accepted["odom0"] == 6 and np.isfinite(node.estimate).all()


def test_sensor_timeout_drops_and_readmits_a_sensor() -> None:
    rt, node = _node({"frequency": 50.0, "sensor_timeout": 0.2, "two_d_mode": True,
                      "odom0": "odom", "odom0_config": TWIST_CFG,
                      "pose0": "pose", "pose0_config": POSE_CFG})
    odom = rt.bus.publisher("/odom", Odometry)
    pose = rt.bus.publisher("/pose", PoseWithCovarianceStamped)

    def send() -> None:
        t = rt.now
        if not 1.0 <= t < 2.0:  # odometry goes quiet for a second
            odom.publish(_odom(t, 0.0, 0.0, 0.0, 0.2))
        pose.publish(_pose_msg(t, 0.2 * t, 0.0, 0.0, var=1.0))

    rt.scheduler.create_timer(0.05, send, first_at=0.0)
    rt.scheduler.run_until(0.9)
    assert node.active_sensors == {"odom0", "pose0"}
    rt.scheduler.run_until(1.5)
    assert node.active_sensors == {"pose0"}
    assert node.sensor_timeouts == {"odom0": 1} and node.sensor_readmissions == {}
    rt.scheduler.run_until(2.5)
    assert node.active_sensors == {"odom0", "pose0"}
    assert node.sensor_timeouts == {"odom0": 1} and node.sensor_readmissions == {"odom0": 1}


def test_differential_pose_becomes_the_exact_velocity() -> None:
    params = EkfParams.from_mapping({"pose0": "pose", "pose0_differential": True,
                                     "pose0_config": [T] * 6 + [F] * 9})
    builder = MeasurementBuilder(params, lambda target, source, t: None)
    s = params.sensor("pose0")
    state = np.zeros(15)
    # body velocity (0.4, 0.1) m/s at a constant yaw of 0.3 rad, sampled every 0.1 s
    yaw, v_body = 0.3, np.array([0.4, 0.1])
    c, sn = math.cos(yaw), math.sin(yaw)
    v_world = np.array([c * v_body[0] - sn * v_body[1], sn * v_body[0] + c * v_body[1]])
    assert builder.pose(s, _pose_msg(5.0, 1.0, 2.0, yaw), state) == []  # first: no delta
    p = np.array([1.0, 2.0]) + 0.1 * v_world
    (m,) = builder.pose(s, _pose_msg(5.1, p[0], p[1], yaw), state)
    assert m.topic == "pose0" and list(m.indices) == [6, 7, 8, 9, 10, 11]
    np.testing.assert_allclose(m.z[6:12], [0.4, 0.1, 0.0, 0.0, 0.0, 0.0], atol=1e-12)
    # a pure rotation of 0.05 rad in 0.1 s is 0.5 rad/s
    (m,) = builder.pose(s, _pose_msg(5.2, p[0], p[1], yaw + 0.05), state)
    np.testing.assert_allclose(m.z[6:12], [0.0, 0.0, 0.0, 0.0, 0.0, 0.5], atol=1e-12)
    # through the node, the filter's velocity converges to the same value
    rt, node = _node({"two_d_mode": True, "pose0": "pose", "pose0_differential": True,
                      "pose0_config": [T, T, F, F, F, T] + [F] * 9})
    pub = rt.bus.publisher("/pose", PoseWithCovarianceStamped)
    for k in range(60):
        q = np.array([1.0, 2.0]) + 0.05 * k * v_world
        rt.scheduler.call_at(0.05 * k, pub.publish, _pose_msg(0.05 * k, q[0], q[1], yaw))
    rt.scheduler.run_until(3.0)
    assert node.estimate[VX] == pytest.approx(0.4, abs=1e-6)
    assert node.estimate[VY] == pytest.approx(0.1, abs=1e-6)


def test_map_world_frame_publishes_map_to_odom() -> None:
    rt, node = _node({"two_d_mode": True, "world_frame": "map", "pose0": "amcl_pose",
                      "pose0_config": POSE_CFG})
    tf_pub = rt.bus.publisher("/tf", TFMessage)
    pose_pub = rt.bus.publisher("/amcl_pose", PoseWithCovarianceStamped)
    odom_base = Pose2D(1.0, 0.5, 0.4)
    map_base = Pose2D(3.0, -1.0, 1.2)

    def send() -> None:
        t = rt.now
        tf_pub.publish(TFMessage((TransformStamped(Header(t, "odom"), "base_link",
                                                   Transform.from_pose2d(odom_base)),)))
        pose_pub.publish(_pose_msg(t, map_base.x, map_base.y, map_base.theta, frame="map"))

    rt.scheduler.create_timer(0.1, send, first_at=0.0)
    rt.scheduler.run_until(2.0)
    map_odom = rt.tf.lookup_pose2d("map", "odom", 1.9)
    expected = map_base.compose(odom_base.inverse())
    assert map_odom.distance_to(expected) < 1e-9
    assert map_odom.theta == pytest.approx(expected.theta, abs=1e-9)
    assert node.tf_published > 0 and node.tf_failures == 0


def test_imu_mounting_and_gravity_are_removed() -> None:
    """An IMU mounted yawed +90 degrees and 0.1 m forward: its orientation, rates and
    accelerations come out in base_link; gravity is subtracted."""
    params = EkfParams.from_mapping({
        "imu0": "imu", "imu0_remove_gravitational_acceleration": True,
        "imu0_config": [F, F, F, F, F, T, F, F, F, F, F, T, T, T, T]})
    mount = (0.1, 0.0, 0.0, *rpy_to_quaternion(0.0, 0.0, math.pi / 2))
    builder = MeasurementBuilder(params, lambda target, source, t: mount
                                 if (target, source) == ("base_link", "imu_link") else None)
    base_yaw, wz = 0.7, 0.5
    cov = np.eye(3) * 1e-4
    # at rest in translation, turning at wz: the mount point accelerates centripetally
    a_mount_base = np.array([-wz * wz * 0.1, 0.0, 0.0])
    a_imu = np.array([a_mount_base[1], -a_mount_base[0], 9.80665])  # base -> imu: rotate -90
    msg = Imu(Header(1.0, "imu_link"),
              Quaternion(*rpy_to_quaternion(0.0, 0.0, base_yaw + math.pi / 2)), cov,
              Vector3(0.0, 0.0, wz), cov, Vector3(*a_imu), cov)
    state = np.zeros(15)
    state[VYAW] = wz
    parts = builder.imu(params.sensor("imu0"), msg, state, np.zeros(3))
    assert [m.topic for m in parts] == ["imu0_pose", "imu0_twist", "imu0_acceleration"]
    assert parts[0].z[YAW] == pytest.approx(base_yaw, abs=1e-12)
    assert parts[1].z[VYAW] == pytest.approx(wz, abs=1e-12)
    np.testing.assert_allclose(parts[2].z[12:15], [0.0, 0.0, 0.0], atol=1e-12)
    assert list(parts[2].indices) == [AX, AY, AZ]


def test_set_pose_resets_the_filter() -> None:
    rt, node = _node({"two_d_mode": True, "odom0": "odom", "odom0_config": TWIST_CFG})
    odom = rt.bus.publisher("/odom", Odometry)
    rt.scheduler.create_timer(0.02, lambda: odom.publish(_odom(rt.now, 0, 0, 0, 0.5)),
                              first_at=0.0)
    rt.scheduler.run_until(1.0)
    rt.bus.publisher("/set_pose", PoseWithCovarianceStamped).publish(
        PoseWithCovarianceStamped(Header(1.0, "odom"), PoseWithCovariance(
            Pose(Point(5.0, 5.0, 0.0), Quaternion.from_yaw(1.0)), np.eye(6) * 0.01)))
    rt.scheduler.run_until(2.0)
    x = node.estimate
    assert x[YAW] == pytest.approx(1.0, abs=1e-9)
    assert x[0] == pytest.approx(5.0 + 0.5 * math.cos(1.0), abs=0.02)
    assert x[1] == pytest.approx(5.0 + 0.5 * math.sin(1.0), abs=0.02)
