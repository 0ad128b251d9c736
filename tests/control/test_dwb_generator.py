"""StandardTrajectoryGenerator: dynamic window, kinematic limits, rollout geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.dwb.params import TrajectoryGeneratorParams
from navstack.control.dwb.trajectory_generator import (
    LimitedAccelGenerator,
    StandardTrajectoryGenerator,
    axis_samples,
    project_velocity,
)
from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D, Twist2D


def test_project_velocity_clamps_at_target() -> None:
    assert project_velocity(0.0, 2.5, -2.5, 0.05, 1.0) == pytest.approx(0.125)
    assert project_velocity(0.1, 2.5, -2.5, 0.05, 0.15) == 0.15
    assert project_velocity(0.3, 2.5, -2.5, 0.05, 0.0) == pytest.approx(0.175)
    assert project_velocity(0.1, 2.5, -2.5, 0.05, 0.0) == 0.0


def test_axis_samples_window_and_zero_insertion() -> None:
    # window [-0.16, 0.16] with 20 evenly spaced samples misses zero -> inserted
    s = axis_samples(0.0, -1.0, 1.0, 3.2, -3.2, 0.05, 20)
    assert len(s) == 21 and s[0] == pytest.approx(-0.16) and s[-1] == pytest.approx(0.16)
    assert np.count_nonzero(s == 0.0) == 1 and np.all(np.diff(s) > 0)
    # a window that contains zero exactly keeps one zero
    s = axis_samples(0.0, -1.0, 1.0, 3.0, -3.0, 0.05, 3)
    np.testing.assert_allclose(s, [-0.15, 0.0, 0.15])
    # collapsed window -> one sample
    np.testing.assert_allclose(axis_samples(0.0, 0.0, 0.0, 2.5, -2.5, 0.05, 5), [0.0])


@pytest.mark.parametrize(("vx", "wz"), [(0.0, 0.0), (0.1, 0.3), (0.26, -0.9), (0.5, 2.0)])
def test_samples_stay_in_dynamic_window(vx: float, wz: float) -> None:
    p = TrajectoryGeneratorParams()
    gen = StandardTrajectoryGenerator(p)
    vel = gen.sample_velocities(Twist2D(vx, 0.0, wz))
    dt = p.sim_period
    cx = min(max(vx, p.min_vel_x), p.max_vel_x)
    cw = min(max(wz, -p.max_vel_theta), p.max_vel_theta)
    eps = 1e-12
    assert np.all(vel[:, 0] >= max(p.min_vel_x, cx + p.decel_lim_x * dt) - eps)
    assert np.all(vel[:, 0] <= min(p.max_vel_x, cx + p.acc_lim_x * dt) + eps)
    assert np.all(vel[:, 2] >= max(-p.max_vel_theta, cw + p.decel_lim_theta * dt) - eps)
    assert np.all(vel[:, 2] <= min(p.max_vel_theta, cw + p.acc_lim_theta * dt) + eps)
    assert np.all(vel[:, 1] == 0.0)
    assert np.all(np.hypot(vel[:, 0], vel[:, 1]) <= p.max_speed_xy + 1e-5)
    assert not np.any((vel[:, 0] == 0.0) & (vel[:, 2] == 0.0))  # zero twist excluded


def test_sample_count_at_rest() -> None:
    # vx: 20 samples in [0, 0.125]; wz: 20 in [-0.16, 0.16] + inserted 0 -> 21; minus (0, 0)
    vel = StandardTrajectoryGenerator().sample_velocities(Twist2D())
    assert len(vel) == 20 * 21 - 1


def test_min_speed_filter() -> None:
    p = TrajectoryGeneratorParams(min_speed_xy=0.1, min_speed_theta=0.1, sim_period=1.0)
    vel = StandardTrajectoryGenerator(p).sample_velocities(Twist2D())
    slow = (np.hypot(vel[:, 0], vel[:, 1]) < 0.1 - 1e-5) & (np.abs(vel[:, 2]) < 0.1 - 1e-5)
    assert not slow.any() and len(vel) > 0


def test_straight_rollout_geometry() -> None:
    p = TrajectoryGeneratorParams(acc_lim_x=100.0, decel_lim_x=-100.0)
    gen = LimitedAccelGenerator(p)
    batch = gen.generate(Pose2D(1.0, 2.0, math.pi / 2), Twist2D(0.2, 0.0, 0.0),
                         np.array([[0.2, 0.0, 0.0]]))
    # 0.2 m/s * 1.7 s = 0.34 m -> ceil(0.34 / 0.05) = 7 steps, + start + repeated last
    assert batch.lengths[0] == 9 and batch.num_steps == 9
    end = batch.final_poses()[0]
    np.testing.assert_allclose(end, [1.0, 2.34, math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(batch.poses[0, -1], batch.poses[0, -2])


def test_arc_rollout_matches_euler_closed_form() -> None:
    gen = LimitedAccelGenerator()
    v, w = 0.2, 0.5
    batch = gen.generate(Pose2D(), Twist2D(v, 0.0, w), np.array([[v, 0.0, w]]))
    n = math.ceil(max(v * 1.7 / 0.05, w * 1.7 / 0.025))  # 34 steps
    h = 1.7 / n
    th = np.arange(n) * w * h  # heading before each Euler step
    x, y = np.sum(v * np.cos(th) * h), np.sum(v * np.sin(th) * h)
    np.testing.assert_allclose(batch.final_poses()[0], [x, y, 1.7 * w], atol=1e-12)


def test_standard_generator_ramps_velocity() -> None:
    # from rest with acc 0.5 m/s^2, a 0.26 m/s command is reached only after 3 steps
    gen = StandardTrajectoryGenerator(TrajectoryGeneratorParams(sim_period=1.0, acc_lim_x=0.5))
    batch = gen.generate(Pose2D(), Twist2D(), np.array([[0.26, 0.0, 0.0]]))
    n = int(batch.lengths[0]) - 2
    h = 1.7 / n
    v = np.minimum(0.26, 0.5 * h * np.arange(1, n + 1))
    assert batch.final_poses()[0, 0] == pytest.approx(float(np.sum(v * h)), abs=1e-12)
    assert batch.final_poses()[0, 0] < 0.26 * 1.7


def test_discretize_by_time_steps() -> None:
    gen = StandardTrajectoryGenerator(TrajectoryGeneratorParams(discretize_by_time=True,
                                                                time_granularity=0.1))
    batch = gen.generate(Pose2D(), Twist2D())
    assert np.all(batch.lengths == 17 + 2)


def test_speed_limit_percentage_and_absolute() -> None:
    gen = StandardTrajectoryGenerator(TrajectoryGeneratorParams(sim_period=1.0))
    gen.set_speed_limit(50.0, True)
    vel = gen.sample_velocities(Twist2D())
    assert vel[:, 0].max() == pytest.approx(0.13)
    assert np.abs(vel[:, 2]).max() == pytest.approx(0.5)
    gen.set_speed_limit(0.1, False)
    vel = gen.sample_velocities(Twist2D())
    assert vel[:, 0].max() == pytest.approx(0.1)
    assert np.abs(vel[:, 2]).max() == pytest.approx(1.0 * 0.1 / 0.26)
    gen.set_speed_limit(1.0, False)  # above the robot's maximum: ignored
    assert gen.sample_velocities(Twist2D())[:, 0].max() == pytest.approx(0.1)
    gen.set_speed_limit(0.0, False)  # 0 = no limit
    assert gen.sample_velocities(Twist2D())[:, 0].max() == pytest.approx(0.26)


def test_positive_deceleration_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="decel_lim_x"):
        TrajectoryGeneratorParams.from_mapping({"decel_lim_x": 2.5})
