"""Simulated GNSS and magnetometer: exact geometry, noise statistics, outages, seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import MagneticField, NavSatFix, NavSatStatus, Odometry, Pose2D, Twist2D
from navstack.core.msgs import TwistWithCovarianceStamped as VelMsg
from navstack.geo.conversions import LocalCartesian
from navstack.localization.initial_pose import magnetometer_yaw
from navstack.sim.gnss import GnssModel, MagnetometerModel
from navstack.sim.kinematics import RobotState
from navstack.sim.open_loop import build_sim
from navstack.sim.robot import (
    GeoReferenceParams,
    GnssParams,
    MagnetometerParams,
    MountParams,
    load_robot,
)
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world

GEO = GeoReferenceParams(latitude=47.3769, longitude=8.5417, altitude=400.0, world_yaw=0.5)
IDEAL = GnssParams(enabled=True, horizontal_noise_std=0.0, vertical_noise_std=0.0,
                   velocity_noise_std=0.0, mount=MountParams(x=1.0, y=0.5, z=1.5))


def test_noise_free_fix_is_the_antenna_position_in_enu() -> None:
    model = GnssModel(IDEAL, GEO)
    state = RobotState(x=10.0, y=-4.0, yaw=0.3)
    fix, _ = model.measure(state, 0.0, np.random.default_rng(0))
    assert fix.status.status == NavSatStatus.STATUS_FIX
    assert fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    # antenna in the world: base + R(yaw) (1.0, 0.5); world rotated by 0.5 rad into ENU
    ax = 10.0 + math.cos(0.3) * 1.0 - math.sin(0.3) * 0.5
    ay = -4.0 + math.sin(0.3) * 1.0 + math.cos(0.3) * 0.5
    e = math.cos(0.5) * ax - math.sin(0.5) * ay
    n = math.sin(0.5) * ax + math.cos(0.5) * ay
    got = LocalCartesian(GEO.latitude, GEO.longitude, GEO.altitude).forward(
        fix.latitude, fix.longitude, fix.altitude)
    assert got == pytest.approx((e, n, 1.5), abs=1e-6)


def test_velocity_is_the_antenna_velocity_in_enu() -> None:
    model = GnssModel(IDEAL, GEO.updated(world_yaw=0.0))
    state = RobotState(yaw=0.0, vx=1.0, wz=0.5)
    _, vel = model.measure(state, 0.0, np.random.default_rng(0))
    assert isinstance(vel, VelMsg)
    v = vel.twist.twist.linear
    # w x r with r = (1.0, 0.5): (-0.5 * 0.5, 0.5 * 1.0)
    assert (v.x, v.y) == pytest.approx((1.0 - 0.25, 0.5), abs=1e-12)


def test_noise_statistics_and_reported_covariance() -> None:
    params = GnssParams(enabled=True, horizontal_noise_std=2.0, bias_std=1.0,
                        bias_time_constant=1e-6, vertical_noise_std=3.0)
    model = GnssModel(params, GEO)
    rng = np.random.default_rng(5)
    lc = LocalCartesian(GEO.latitude, GEO.longitude, GEO.altitude)
    enu = []
    for k in range(3000):
        fix, _ = model.measure(RobotState(), 0.2 * k, rng)
        enu.append(lc.forward(fix.latitude, fix.longitude, fix.altitude))
    a = np.asarray(enu)
    # bias decorrelates within a sample here, so the total per-axis std is sqrt(4 + 1)
    assert np.std(a[:, 0]) == pytest.approx(math.sqrt(5.0), rel=0.05)
    assert np.std(a[:, 1]) == pytest.approx(math.sqrt(5.0), rel=0.05)
    assert np.std(a[:, 2]) == pytest.approx(3.0, rel=0.05)
    assert np.allclose(fix.position_covariance, np.diag([5.0, 5.0, 9.0]))


def test_gauss_markov_bias_is_stationary_and_correlated() -> None:
    params = GnssParams(enabled=True, horizontal_noise_std=0.0, bias_std=1.5,
                        bias_time_constant=10.0)
    rng = np.random.default_rng(1)
    runs = []
    for _ in range(1500):
        model = GnssModel(params, GEO)
        b = []
        for k in range(3):
            model.measure(RobotState(), 10.0 * k, rng)  # samples one time constant apart
            b.append(model.bias[0])
        runs.append(b)
    r = np.asarray(runs)
    assert np.std(r[:, 0]) == pytest.approx(1.5, rel=0.1)
    assert np.std(r[:, 2]) == pytest.approx(1.5, rel=0.1)
    corr = np.corrcoef(r[:, 0], r[:, 1])[0, 1]
    assert corr == pytest.approx(math.exp(-1.0), abs=0.1)


def test_outage_reports_no_fix_without_velocity() -> None:
    params = IDEAL.updated(outages=((1.0, 2.0),))
    model = GnssModel(params, GEO)
    rng = np.random.default_rng(0)
    statuses = []
    for t in (0.8, 1.0, 1.5, 1.99, 2.0):
        fix, vel = model.measure(RobotState(), t, rng)
        statuses.append(fix.status.status)
        if fix.status.status == NavSatStatus.STATUS_NO_FIX:
            assert vel is None and math.isnan(fix.latitude)
            assert fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN
    assert statuses == [0, -1, -1, -1, 0]
    assert (model.fixes, model.no_fixes) == (2, 3)


def test_outage_interval_must_be_ordered() -> None:
    with pytest.raises(ConfigError, match=r"robot.sensors.gnss.outages: Value error, each "
                                          r"outage is \[start, end\) with end > start, got "
                                          r"\[5.0, 3.0\]"):
        load_robot("turtlebot", {"sensors": {"gnss": {"outages": [[5.0, 3.0]]}}})


def test_magnetometer_heading_is_recovered_and_offset_applies() -> None:
    params = MagnetometerParams(enabled=True, declination=0.2, heading_offset=0.25,
                                mount=MountParams(yaw=0.1))
    model = MagnetometerModel(params, GEO)
    msg = model.measure(RobotState(yaw=1.0), 0.0, np.random.default_rng(0))
    assert isinstance(msg, MagneticField)
    b = msg.magnetic_field
    assert math.hypot(b.x, b.y) == pytest.approx(2.2e-5, rel=1e-12)
    assert b.z == pytest.approx(-4.4e-5, rel=1e-12)
    # sensor yaw in ENU: robot 1.0 + world 0.5 + mount 0.1 + offset 0.25
    assert magnetometer_yaw(msg, 0.2) == pytest.approx(1.85, abs=1e-12)
    hard = MagnetometerModel(params.updated(hard_iron=(1e-6, -2e-6, 0.0)), GEO).measure(
        RobotState(yaw=1.0), 0.0, np.random.default_rng(0))
    assert hard.magnetic_field.x - b.x == pytest.approx(1e-6, abs=1e-18)
    assert hard.magnetic_field.y - b.y == pytest.approx(-2e-6, abs=1e-18)


def test_enabling_gnss_leaves_the_other_sensors_bit_identical() -> None:
    world = load_world("office")
    plain = load_robot("diff_drive")
    extra = load_robot("diff_drive", {"sensors": {"gnss": {"enabled": True},
                                                  "magnetometer": {"enabled": True,
                                                                   "noise_std": 1e-7}}})
    out = []
    for prof in (plain, extra):
        sim = Simulator(world, prof, seed=7, spawn=Pose2D(1.0, 7.5, 0.0))
        sim.set_command(Twist2D(0.3, 0.0, 0.2), 0.0)
        odo, ranges = [], []
        for k in range(1, 51):
            sim.step(0.02)
            if sim.gnss is not None:
                sim.gnss_sample(k * 0.02)
                sim.magnetic_field(k * 0.02)
            msg = sim.odom(k * 0.02)
            assert msg is not None
            odo.append(msg.pose.pose.position.x)
            scan = sim.scan(k * 0.02)
            assert scan is not None
            ranges.append(scan.ranges.copy())
        out.append((odo, np.asarray(ranges)))
    assert out[0][0] == out[1][0]
    assert np.array_equal(out[0][1], out[1][1])


def test_gnss_is_deterministic_per_seed() -> None:
    world = load_world("campus")
    prof = load_robot("golf_cart")
    fixes = []
    for seed in (3, 3, 4):
        sim = Simulator(world, prof, seed=seed)
        sample = sim.gnss_sample(0.0)
        assert sample is not None
        fixes.append((sample[0].latitude, sample[0].longitude))
    assert fixes[0] == fixes[1] != fixes[2]


def test_simulator_node_publishes_gnss_and_magnetometer() -> None:
    rt, _ = build_sim("campus", "golf_cart", 0)
    fixes: list[NavSatFix] = []
    vels: list[VelMsg] = []
    mags: list[MagneticField] = []
    rt.bus.subscribe("/gps/fix", NavSatFix, fixes.append)
    rt.bus.subscribe("/gps/vel", VelMsg, vels.append)
    rt.bus.subscribe("/imu/mag", MagneticField, mags.append)
    rt.bring_up()
    rt.scheduler.run_until(2.0)
    assert 9 <= len(fixes) <= 11 and len(vels) == len(fixes)
    assert 39 <= len(mags) <= 41
    assert rt.bus.topics["/ground_truth"].msg_type is Odometry
    gps = rt.tf.lookup_pose2d("base_link", "gps_link")
    assert (gps.x, gps.y) == pytest.approx((1.2, 0.0))
    assert fixes[0].header.frame_id == "gps_link"
