"""Sensor models: exactness without noise, drift factors, noise statistics, dropout, seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import InvalidMessage
from navstack.core.msgs import Pose2D, Twist2D
from navstack.sim.kinematics import DiffDrive, Omni, RobotState
from navstack.sim.robot import GroundTruthParams, ImuParams, LidarParams, OdometryParams
from navstack.sim.sensors import (
    GRAVITY,
    GroundTruthModel,
    ImuModel,
    LidarModel,
    SensorSchedule,
    WheelOdometryModel,
)


def drive(model, cmds: list[Twist2D], dt: float, steps_each: int) -> list[RobotState]:
    states = [RobotState()]
    for cmd in cmds:
        for _ in range(steps_each):
            states.append(model.step(states[-1], cmd, dt))
    return states


# --- schedule ---------------------------------------------------------------------------
def test_schedule_is_phase_stable_over_accumulated_time() -> None:
    sched = SensorSchedule(10.0)
    now, fired = 0.0, []
    for i in range(100_001):  # 1000 s at 100 Hz with float-accumulated time
        if sched.due(now):
            fired.append(i)
        now += 0.01
    assert fired == list(range(0, 100_001, 10))


def test_schedule_resyncs_after_a_long_step() -> None:
    sched = SensorSchedule(10.0, start=2.0)
    assert not sched.due(1.99)
    assert sched.due(2.0) and not sched.due(2.05)
    assert sched.due(3.05)  # 2.1 .. 3.0 skipped: one sample, not a burst
    assert not sched.due(3.09)
    assert sched.next_time == pytest.approx(3.1)
    assert sched.due(3.1)


# --- odometry ---------------------------------------------------------------------------
CMDS = [Twist2D(0.4, 0.0, 0.0), Twist2D(0.5, 0.0, 0.8), Twist2D(-0.2, 0.0, -1.2),
        Twist2D(0.3, 0.0, 0.1)]


def test_noise_free_odometry_equals_ground_truth_exactly() -> None:
    rng = np.random.default_rng(1)
    dt = 0.01
    states = drive(DiffDrive(0.5, -0.5, 1.5, 1.0, 2.0), CMDS, dt, 250)
    odom = WheelOdometryModel(OdometryParams(rate_hz=50.0))
    sched, gt = SensorSchedule(50.0), GroundTruthModel()
    n_msgs = 0
    for k, s in enumerate(states[1:], start=1):
        odom.integrate(s, dt, rng)
        if sched.due(k * dt):
            msg, truth = odom.message(k * dt), gt.measure(s, k * dt)
            assert msg.pose.pose == truth.pose.pose
            assert msg.header.frame_id == "odom" and msg.child_frame_id == "base_link"
            assert truth.header.frame_id == "map"
            n_msgs += 1
    assert n_msgs == 501  # samples at 0.00 (taken at 0.01), 0.02, ..., 10.00
    assert odom.pose == states[-1].pose  # bitwise: same exact-arc integration


def test_noise_free_omni_odometry_equals_truth() -> None:
    rng = np.random.default_rng(1)
    model = Omni(0.5, -0.5, 0.5, 1.5, 1.0, 1.0, 2.0)
    states = drive(model, [Twist2D(0.3, -0.2, 0.4), Twist2D(0.1, 0.4, -0.6)], 0.02, 200)
    odom = WheelOdometryModel(OdometryParams(), holonomic=True)
    for s in states[1:]:
        odom.integrate(s, 0.02, rng)
    assert odom.pose == states[-1].pose


def test_scale_drift_diverges_by_expected_factor() -> None:
    rng = np.random.default_rng(2)
    odom = WheelOdometryModel(OdometryParams(linear_scale_error=0.05, angular_scale_error=-0.1))
    straight = RobotState(vx=0.5)
    for _ in range(2000):  # 20 s straight at 0.5 m/s -> 10 m true
        odom.integrate(straight, 0.01, rng)
    assert odom.pose.x == pytest.approx(10.0 * 1.05, abs=1e-9)
    assert odom.pose.y == 0.0
    odom.reset()
    spin = RobotState(wz=0.1)
    for _ in range(2000):  # 2 rad true rotation in place
        odom.integrate(spin, 0.01, rng)
    assert odom.pose.theta == pytest.approx(2.0 * 0.9, abs=1e-9)
    assert odom.message(20.0).twist.twist.angular.z == pytest.approx(0.09, abs=1e-12)


def test_velocity_noise_is_rate_invariant_and_covariance_matches() -> None:
    rng = np.random.default_rng(3)
    sv, sw, dt, rate = 0.02, 0.05, 0.002, 50.0
    odom = WheelOdometryModel(OdometryParams(rate_hz=rate, linear_velocity_noise_std=sv,
                                             angular_velocity_noise_std=sw))
    truth = RobotState(vx=0.5)
    vx, wz = [], []
    for m in range(3000):  # 10 physics steps per 50 Hz message, 60 s
        for _ in range(10):
            odom.integrate(truth, dt, rng)
        msg = odom.message((m + 1) * 0.02)
        vx.append(msg.twist.twist.linear.x)
        wz.append(msg.twist.twist.angular.z)
    assert np.mean(vx) == pytest.approx(0.5, abs=4 * sv / math.sqrt(3000))
    assert np.std(vx) == pytest.approx(sv, rel=0.05)
    assert np.std(wz) == pytest.approx(sw, rel=0.05)
    tcov = msg.twist.covariance
    assert (tcov[0, 0], tcov[5, 5], tcov[2, 2]) == pytest.approx((sv**2, sw**2, 1e6))
    T, period = 60.0, 1.0 / rate
    pcov = msg.pose.covariance
    assert pcov[5, 5] == pytest.approx(sw**2 * period * T, rel=1e-9)
    assert np.allclose(pcov, pcov.T)
    assert np.all(np.linalg.eigvalsh(pcov) > 0.0)


@pytest.mark.parametrize(("sv", "sw"), [(0.02, 0.0), (0.0, 0.05)])
def test_pose_covariance_known_answers(sv: float, sw: float) -> None:
    """Straight run at 0.5 m/s for T s: var_x = sv^2 p T; var_y = v^2 sw^2 p T^3 / 3."""
    rng = np.random.default_rng(8)
    T, period, dt = 60.0, 0.02, 0.002
    odom = WheelOdometryModel(OdometryParams(rate_hz=1 / period, linear_velocity_noise_std=sv,
                                             angular_velocity_noise_std=sw))
    for _ in range(30_000):
        odom.integrate(RobotState(vx=0.5), dt, rng)
    pcov = odom.message(T).pose.covariance
    if sw == 0.0:
        assert pcov[0, 0] == pytest.approx(sv**2 * period * T, rel=1e-9)
        assert pcov[1, 1] == 1e-9  # the variance floor: no lateral uncertainty without yaw noise
    else:
        # the odometry's own heading wanders (~0.05 rad), hence the 1 % tolerance
        assert pcov[1, 1] == pytest.approx(0.25 * sw**2 * period * T**3 / 3.0, rel=1e-2)
        assert pcov[1, 5] == pytest.approx(0.5 * sw**2 * period * T**2 / 2.0, rel=1e-2)


def test_slip_loses_the_expected_fraction_of_motion() -> None:
    rng = np.random.default_rng(4)
    odom = WheelOdometryModel(OdometryParams(rate_hz=50.0, slip_prob=0.2))
    for _ in range(20_000):
        odom.integrate(RobotState(vx=1.0), 0.02, rng)
    assert odom.pose.x / 400.0 == pytest.approx(0.8, abs=0.01)


def test_odometry_same_seed_same_output() -> None:
    params = OdometryParams(linear_velocity_noise_std=0.05, angular_velocity_noise_std=0.05,
                            slip_prob=0.1)
    states = drive(DiffDrive(0.5, -0.5, 1.5, 1.0, 2.0), CMDS, 0.02, 50)
    poses = []
    for _ in range(2):
        rng, odom = np.random.default_rng(7), WheelOdometryModel(params)
        for s in states[1:]:
            odom.integrate(s, 0.02, rng)
        poses.append(odom.pose)
    assert poses[0] == poses[1]
    assert poses[0] != states[-1].pose


# --- IMU ----------------------------------------------------------------------------------
def test_imu_gyro_bias_and_noise_statistics() -> None:
    rng = np.random.default_rng(5)
    imu = ImuModel(ImuParams(gyro_noise_std=0.01, gyro_bias=(0.0, 0.0, 0.02),
                             accel_noise_std=0.05))
    s = RobotState(wz=0.3)
    wz = np.array([imu.measure(s, s, 0.01, 0.0, rng).angular_velocity.z  # type: ignore[union-attr]
                   for _ in range(20_000)])
    assert wz.mean() - 0.3 == pytest.approx(0.02, abs=4 * 0.01 / math.sqrt(20_000))
    assert wz.std() == pytest.approx(0.01, rel=0.03)


def test_imu_noise_free_kinematics() -> None:
    rng = np.random.default_rng(0)
    imu = ImuModel(ImuParams(mount={"x": 0.0, "y": 0.0, "z": 0.1, "yaw": 0.5}))
    rest = imu.measure(RobotState(yaw=1.0), RobotState(yaw=1.0), 0.01, 3.0, rng)
    assert rest is not None
    la = rest.linear_acceleration
    assert (la.x, la.y, la.z) == (0.0, 0.0, GRAVITY)
    assert rest.orientation.yaw == pytest.approx(1.5)
    assert rest.header.stamp == 3.0 and rest.header.frame_id == "imu_link"
    # constant turn at v=1, w=0.5: centripetal v*w toward +y of the body
    dt = 0.01
    model = DiffDrive(2.0, -2.0, 2.0, 1e9, 1e9)
    prev = RobotState(vx=1.0, wz=0.5)
    cur = model.step(prev, Twist2D(1.0, 0.0, 0.5), dt)
    centred = ImuModel(ImuParams())
    turn = centred.measure(cur, prev, dt, 0.0, rng)
    assert turn is not None
    assert turn.linear_acceleration.x == pytest.approx(0.0, abs=1e-12)
    assert turn.linear_acceleration.y == pytest.approx(2.0 * math.sin(0.5 * 0.5 * dt) / dt)
    assert turn.linear_acceleration.y == pytest.approx(0.5, rel=1e-5)
    # an IMU 0.2 m ahead of base_link also feels -w^2 r along x
    ahead = ImuModel(ImuParams(mount={"x": 0.2})).measure(cur, prev, dt, 0.0, rng)
    assert ahead is not None
    assert ahead.linear_acceleration.x == pytest.approx(-0.25 * 0.2, abs=1e-12)
    # forward acceleration 1 m/s^2 seen by an IMU yawed +90 deg appears on its -y axis
    acc = ImuModel(ImuParams(mount={"yaw": math.pi / 2})).measure(
        RobotState(vx=0.01), RobotState(), dt, 0.0, rng)
    assert acc is not None
    assert (acc.linear_acceleration.x, acc.linear_acceleration.y) == pytest.approx(
        (0.0, -1.0), abs=1e-12)


def test_imu_dropout_rate_and_seed() -> None:
    params = ImuParams(dropout_prob=0.1, gyro_noise_std=0.01)
    out = [ImuModel(params).measure(RobotState(), None, 0.01, 0.0, rng)
           for rng in [np.random.default_rng(9)] for _ in range(10_000)]
    assert sum(m is None for m in out) / 10_000 == pytest.approx(0.1, abs=0.01)
    runs = []
    for _ in range(2):
        rng, imu = np.random.default_rng(3), ImuModel(params)
        runs.append([None if m is None else (m.angular_velocity, m.linear_acceleration)
                     for m in (imu.measure(RobotState(wz=0.2), None, 0.01, 0.0, rng)
                               for _ in range(50))])
    assert runs[0] == runs[1]
    assert any(m is None for m in runs[0]) and any(m is not None for m in runs[0])


def test_ground_truth_is_exact() -> None:
    s = RobotState(1.5, -2.0, 0.7, 0.3, 0.1, -0.2)
    msg = GroundTruthModel(GroundTruthParams(frame_id="world")).measure(s, 4.0)
    assert msg.pose.pose.to_pose2d() == pytest.approx(Pose2D(1.5, -2.0, 0.7))
    tw = msg.twist.twist
    assert (tw.linear.x, tw.linear.y, tw.angular.z) == (0.3, 0.1, -0.2)
    assert msg.header.frame_id == "world" and msg.header.stamp == 4.0


# --- lidar --------------------------------------------------------------------------------
def test_lidar_beam_layout() -> None:
    full = LidarModel(LidarParams(angle_min=-math.pi, angle_max=math.pi, beams=360))
    assert full.angle_increment == pytest.approx(2 * math.pi / 360)
    assert full.beam_angles[-1] == pytest.approx(math.pi - 2 * math.pi / 360)
    part = LidarModel(LidarParams(angle_min=-0.75 * math.pi, angle_max=0.75 * math.pi,
                                  beams=1081))
    assert part.angle_increment == pytest.approx(1.5 * math.pi / 1080)
    assert part.beam_angles[0] == -0.75 * math.pi
    assert part.beam_angles[-1] == pytest.approx(0.75 * math.pi)
    mounted = LidarModel(LidarParams(mount={"x": 0.2, "y": 0.1, "yaw": math.pi / 2}))
    assert (mounted.mount.x, mounted.mount.y, mounted.mount.yaw) == (0.2, 0.1, math.pi / 2)
    sp = mounted.sensor_pose(Pose2D(1.0, 1.0, math.pi / 2))
    assert (sp.x, sp.y, sp.theta) == pytest.approx((0.9, 1.2, math.pi))
    world = mounted.world_beam_angles(Pose2D(0.0, 0.0, math.pi / 2))
    # beam 180 looks along the sensor's +x: robot pi/2 + mount pi/2 -> pi (range (-pi, pi])
    assert world[180] == pytest.approx(math.pi, abs=1e-12)
    assert world[0] == pytest.approx(0.0, abs=1e-12)


def test_lidar_clipping_semantics() -> None:
    lidar = LidarModel(LidarParams(beams=4, range_min=0.12, range_max=12.0))
    scan = lidar.measure(np.array([0.05, 5.0, 50.0, np.inf]), 1.5, np.random.default_rng(0))
    assert scan is not None
    assert scan.ranges.dtype == np.float32
    assert list(scan.ranges) == [-np.inf, 5.0, np.inf, np.inf]
    assert (scan.header.stamp, scan.header.frame_id, scan.scan_time) == (1.5, "base_scan", 0.1)
    assert (scan.range_min, scan.range_max, scan.time_increment) == (0.12, 12.0, 0.0)
    assert scan.angle_max == pytest.approx(lidar.beam_angles[-1])
    with pytest.raises(InvalidMessage, match="expects 4 true ranges, got shape"):
        lidar.measure(np.ones(5), 0.0, np.random.default_rng(0))
    with pytest.raises(InvalidMessage, match="NaN"):
        lidar.measure(np.array([1.0, np.nan, 1.0, 1.0]), 0.0, np.random.default_rng(0))


def test_lidar_noise_bias_and_dropout_statistics() -> None:
    rng = np.random.default_rng(11)
    lidar = LidarModel(LidarParams(noise_std=0.02, bias=0.03, dropout_prob=0.1,
                                   scan_dropout_prob=0.2))
    true = np.full(360, 5.0)
    scans = [lidar.measure(true, 0.1 * i, rng) for i in range(2000)]
    got = [s for s in scans if s is not None]
    assert (2000 - len(got)) / 2000 == pytest.approx(0.2, abs=0.03)
    r = np.concatenate([s.ranges for s in got]).astype(np.float64)
    dropped = np.isinf(r)
    assert dropped.mean() == pytest.approx(0.1, abs=0.005)
    valid = r[~dropped]
    assert valid.mean() == pytest.approx(5.03, abs=4 * 0.02 / math.sqrt(valid.size))
    assert valid.std() == pytest.approx(0.02, rel=0.02)
    assert valid.min() >= 0.12 and valid.max() <= 12.0


def test_lidar_range_proportional_noise() -> None:
    """``noise_std + noise_std_per_m * r`` (the LDS-01 is specified in % of the range)."""
    rng = np.random.default_rng(5)
    lidar = LidarModel(LidarParams(noise_std=0.005, noise_std_per_m=0.01, range_max=20.0))
    true = np.where(np.arange(360) % 2 == 0, 1.0, 3.0)
    r = np.stack([s.ranges for s in (lidar.measure(true, 0.0, rng) for _ in range(3000))
                  if s is not None]).astype(np.float64)
    assert r[:, 0::2].std() == pytest.approx(0.015, rel=0.03)
    assert r[:, 1::2].std() == pytest.approx(0.035, rel=0.03)
    assert r[:, 1::2].mean() == pytest.approx(3.0, abs=1e-3)


def test_lidar_same_seed_same_scan() -> None:
    lidar = LidarModel(LidarParams(noise_std=0.01, dropout_prob=0.01))
    true = np.linspace(0.05, 15.0, 360)
    a = lidar.measure(true, 0.0, np.random.default_rng(42))
    b = lidar.measure(true, 0.0, np.random.default_rng(42))
    assert a is not None and b is not None
    np.testing.assert_array_equal(a.ranges, b.ranges)
