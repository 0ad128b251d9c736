"""Pulse + IMU dead reckoning, GNSS odometry and the heading calibration: exact answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import InvalidMessage
from navstack.core.msgs import Header, Pose2D, Twist, Twist2D, TwistWithCovariance, Vector3
from navstack.core.msgs import TwistWithCovarianceStamped as VelMsg
from navstack.localization.odometry_sources import (
    CalibrationState,
    GnssOdometry,
    HeadingCalibration,
    WheelEncoderParams,
    WheelImuDeadReckoning,
    arc_step,
    course_over_ground,
    speed_over_ground,
)
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world

STEP = 2.0 * math.pi * 0.225 / 4.0  # 0.35342917352885173 m per pulse


def test_distance_per_pulse_of_the_seed_wheel() -> None:
    assert WheelEncoderParams().distance_per_pulse == STEP
    assert abs(STEP - 0.35342917352885173) < 1e-16


def test_straight_forward_and_backward_counting() -> None:
    dr = WheelImuDeadReckoning()
    dr.update(0.0, 100, imu_yaw=2.0, command_vx=1.0)  # latches counter and IMU zero
    dr.update(1.0, 110, imu_yaw=2.0, command_vx=1.0)
    assert (dr.pose.x, dr.pose.y, dr.pose.theta) == (10 * STEP, 0.0, 0.0)
    assert dr.velocity == pytest.approx(10 * STEP)
    dr.update(2.0, 114, imu_yaw=2.0, command_vx=-0.5)  # reverse: 4 pulses backwards
    assert dr.pose.x == pytest.approx(6 * STEP, abs=1e-15)
    dr.update(3.0, 116, imu_yaw=2.0, command_vx=0.0)  # coasting keeps the last direction
    assert dr.pose.x == pytest.approx(4 * STEP, abs=1e-15)
    assert dr.distance == pytest.approx(16 * STEP) and dr.pulses == 16


def test_counter_wrap_and_backwards_counter() -> None:
    dr = WheelImuDeadReckoning(WheelEncoderParams(counter_modulus=65536))
    dr.update(0.0, 65534, 0.0, 1.0)
    dr.update(0.1, 2, 0.0, 1.0)
    assert dr.pulses == 4 and dr.pose.x == pytest.approx(4 * STEP)
    plain = WheelImuDeadReckoning()
    plain.update(0.0, 10, 0.0, 1.0)
    with pytest.raises(InvalidMessage, match="pulse count went backwards by 3; a "
                                             "single-channel counter only counts up"):
        plain.update(0.1, 7, 0.0, 1.0)


def test_arc_integration_is_exact_for_a_circle() -> None:
    # a quarter circle of radius R from the origin heading east ends at (R, R) heading north
    radius = 2.0
    pose = Pose2D()
    n = 7
    for k in range(1, n + 1):
        pose = arc_step(pose, 0.5 * math.pi * radius / n, 0.5 * math.pi * k / n)
    assert (pose.x, pose.y, pose.theta) == pytest.approx((radius, radius, math.pi / 2),
                                                         abs=1e-12)
    # pulses around a full circle with the IMU yaw turning uniformly return home
    dr = WheelImuDeadReckoning(initial_pose=Pose2D(1.0, 2.0, 0.5))
    dr.update(0.0, 0, imu_yaw=-1.0, command_vx=1.0)
    for k in range(1, 41):
        dr.update(0.1 * k, 3 * k, imu_yaw=-1.0 + 2 * math.pi * k / 40, command_vx=1.0)
    assert (dr.pose.x, dr.pose.y) == pytest.approx((1.0, 2.0), abs=1e-12)
    assert dr.pose.theta == pytest.approx(0.5, abs=1e-12)
    assert dr.odometry(4.0).pose.covariance[0, 0] == pytest.approx(STEP ** 2)


def test_speed_and_course_over_ground() -> None:
    vel = VelMsg(Header(0.0, "gps"), TwistWithCovariance(Twist(Vector3(3.0, 4.0, 0.0))))
    assert speed_over_ground(vel) == 5.0
    assert course_over_ground(vel) == math.atan2(4.0, 3.0)


def test_gnss_odometry_integrates_sog_along_the_calibrated_heading() -> None:
    odo = GnssOdometry(yaw_offset=0.3, initial_position=(10.0, -5.0))
    for k in range(21):  # 2 s at 10 Hz, 1.5 m/s, IMU yaw 0.2 -> ENU heading 0.5
        odo.update(0.1 * k, 1.5, 0.2, command_vx=1.5, course=0.6)
    assert (odo.pose.x, odo.pose.y) == pytest.approx(
        (10.0 + 3.0 * math.cos(0.5), -5.0 + 3.0 * math.sin(0.5)), abs=1e-12)
    assert odo.pose.theta == pytest.approx(0.5) and odo.distance == pytest.approx(3.0)
    assert odo.course_error == pytest.approx(0.1, abs=1e-12)
    # reverse: SOG is unsigned, the command gives the sign; the course points backwards
    for k in range(21, 31):
        odo.update(0.1 * k, 1.0, 0.2, command_vx=-1.0, course=0.5 - math.pi)
    # trapezoid: +1.5 -> -1.0 over the first 0.1 s (+0.025 m), then 9 x -0.1 m
    assert odo.pose.x == pytest.approx(10.0 + 2.125 * math.cos(0.5), abs=1e-12)
    assert odo.course_error == pytest.approx(0.0, abs=1e-12)
    assert odo.yaw_change(0.7) == pytest.approx(0.5)  # relative to the initial IMU yaw


def test_calibration_averages_course_minus_imu_yaw() -> None:
    cal = HeadingCalibration()
    assert cal.command(0.0) == Twist2D()  # nothing before start
    cal.start(1.0)
    assert cal.state is CalibrationState.CALIBRATING
    used = []
    for k in range(13):  # GNSS at 5 Hz for 2.4 s
        t = 1.0 + 0.2 * k
        assert cal.command(t) == Twist2D(1.5, 0.0, 0.0)
        speed = min(1.5, 0.3 + 0.5 * k)  # accelerating: the first two samples are too slow
        course = 0.5 + (0.02 if k % 2 else -0.02)
        used.append(cal.add_sample(t, speed, course, imu_yaw=0.2 + (0.01 if k % 2 else -0.01)))
    assert used[:2] == [False, False] and all(used[2:])
    assert cal.command(3.5) == Twist2D()
    assert cal.state is CalibrationState.READY and cal.odometry_ready
    assert cal.yaw_offset == pytest.approx(0.3, abs=1e-3)


def test_calibration_with_exact_samples_gives_the_exact_offset() -> None:
    cal = HeadingCalibration()
    cal.start(0.0)
    for k in range(10):
        cal.add_sample(0.25 * k, 1.5, course=-3.0, imu_yaw=3.0)  # across the +-pi seam
    cal.command(2.5)
    assert cal.yaw_offset == pytest.approx(2.0 * math.pi - 6.0, abs=1e-12)


def test_calibration_failures_say_why() -> None:
    cal = HeadingCalibration()
    cal.start(0.0)
    cal.add_sample(1.0, 0.2, 0.0, 0.0)
    assert cal.command(2.5) == Twist2D()
    assert cal.state is CalibrationState.FAILED
    assert cal.reason == ("only 0 GNSS velocity samples at >= 1.0 m/s in 2.5 s (need 3); "
                          "check that the vehicle drove and the receiver has a fix")
    cal.start(10.0)
    for k in range(5):
        cal.add_sample(10.0 + 0.5 * k, 1.5, 0.1 * k, 0.1 * k)
    cal.command(12.5)
    assert cal.state is CalibrationState.FAILED
    assert cal.reason.startswith("the IMU yaw varied by 0.200 rad (> max_yaw_change 0.1)")


def test_calibration_in_the_simulator_finds_the_world_rotation() -> None:
    """golf_cart with its noisy GNSS velocity and IMU, world rotated 0.5 rad in ENU: the
    IMU reports world yaw, so the IMU -> ENU offset is 0.5."""
    prof = load_robot("golf_cart", {"sensors": {"georeference": {"world_yaw": 0.5}}})
    sim = Simulator(load_world("campus"), prof, seed=4)
    cal = HeadingCalibration()
    cal.start(0.0)
    t, dt = 0.0, 0.02
    imu_yaw = 0.0
    while cal.state is CalibrationState.CALIBRATING:
        sim.set_command(cal.command(t), t)
        sim.step(dt)
        t = round(t + dt, 9)
        imu = sim.imu_sample(dt, t)
        if imu is not None:
            imu_yaw = imu.orientation.yaw
        if round(t / 0.2, 6).is_integer():
            sample = sim.gnss_sample(t)
            assert sample is not None and sample[1] is not None
            cal.add_sample(t, speed_over_ground(sample[1]), course_over_ground(sample[1]),
                           imu_yaw)
    assert cal.state is CalibrationState.READY
    assert cal.yaw_offset == pytest.approx(0.5, abs=0.02)
    assert np.isfinite(cal.yaw_offset)
