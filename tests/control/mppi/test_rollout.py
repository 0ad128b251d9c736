"""The rollout kernel against closed-form kinematics, acceleration limits and the
control cost."""

from __future__ import annotations

import math

import numpy as np

from navstack.control.mppi.rollout import D_SIZE, rollout


def _dyn(dt: float, gamma: tuple[float, float, float] = (0.0, 0.0, 0.0),
         accel: tuple[float, float, float, float, float] = (3.0, -3.0, 3.0, -3.0, 3.5)
         ) -> np.ndarray:
    d = np.zeros(D_SIZE)
    d[:6] = (dt, *accel)
    d[6:9] = gamma
    return d


def _run(cs: np.ndarray, noise: np.ndarray, state: np.ndarray, dyn: np.ndarray,
         holonomic: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    _, t, b = noise.shape
    controls = np.zeros((3, t, b), dtype=np.float32)
    traj = np.zeros((3, t, b), dtype=np.float32)
    costs, arc = np.zeros(b), np.zeros(b)
    rollout(cs, noise, state, dyn, holonomic, controls, traj, costs, arc)
    return controls, traj, costs, arc


def _arc_closed_form(x0: float, y0: float, yaw0: float, vx: float, vy: float, wz: float,
                     dt: float, n: int) -> np.ndarray:
    """Nav2's explicit Euler: heading of the previous pose, yaw after each step."""
    k = np.arange(n)
    prev = yaw0 + k * wz * dt
    x = x0 + np.cumsum((vx * np.cos(prev) - vy * np.sin(prev)) * dt)
    y = y0 + np.cumsum((vx * np.sin(prev) + vy * np.cos(prev)) * dt)
    return np.vstack((x, y, yaw0 + (k + 1) * wz * dt))


def test_constant_twist_follows_the_closed_form() -> None:
    t, b, dt = 40, 3, 0.05
    for wz in (0.5, 14.0):  # 14 rad/s * 0.05 s = 0.7 rad per step: exact-trig branch
        cs = np.zeros((3, t))
        cs[0], cs[2] = 0.4, wz
        noise = np.zeros((3, t, b), dtype=np.float32)
        state = np.array([1.0, -2.0, 0.3, 0.4, 0.0, wz])
        controls, traj, _, arc = _run(cs, noise, state, _dyn(dt, accel=(3, -3, 3, -3, 1e3)),
                                      False)
        expected = _arc_closed_form(1.0, -2.0, 0.3, 0.4, 0.0, wz, dt, t)
        for i in range(b):
            np.testing.assert_allclose(traj[:, :, i], expected, atol=2e-5)
        np.testing.assert_allclose(arc, 0.4 * dt * (t - 1), rtol=1e-6)
        np.testing.assert_allclose(controls[0], 0.4, atol=1e-7)


def test_omni_integrates_lateral_velocity() -> None:
    t, dt = 20, 0.1
    cs = np.zeros((3, t))
    cs[1] = 0.3
    state = np.array([0.0, 0.0, math.pi / 2, 0.0, 0.3, 0.0])
    _, traj, _, arc = _run(cs, np.zeros((3, t, 2), dtype=np.float32), state, _dyn(dt), True)
    # facing +y, moving left = -x
    np.testing.assert_allclose(traj[0, :, 0], -0.03 * np.arange(1, t + 1), atol=1e-5)
    np.testing.assert_allclose(traj[1, :, 0], 0.0, atol=1e-5)
    assert math.isclose(arc[0], 0.3 * dt * (t - 1), rel_tol=1e-6)


def test_samples_are_acceleration_limited_and_the_last_stays_raw() -> None:
    t, dt = 12, 0.05
    cs = np.zeros((3, t))
    cs[0], cs[2] = 1.0, 2.0
    controls, _, _, _ = _run(cs, np.zeros((3, t, 1), dtype=np.float32),
                             np.zeros(6), _dyn(dt), False)
    steps = np.arange(1, t)
    np.testing.assert_allclose(controls[0, :-1, 0], np.minimum(0.15 * steps, 1.0), atol=1e-6)
    np.testing.assert_allclose(controls[2, :-1, 0], np.minimum(0.175 * steps, 2.0), atol=1e-6)
    assert controls[0, -1, 0] == 1.0 and controls[2, -1, 0] == 2.0  # Nav2 leaves it raw


def test_control_cost_term() -> None:
    t, b = 30, 4
    gamma, std = 0.015, 0.2
    cs = np.zeros((3, t))
    cs[0] = 0.2
    noise = np.zeros((3, t, b), dtype=np.float32)
    noise[0] = 0.1
    state = np.array([0.0, 0.0, 0.0, 0.3, 0.0, 0.0])
    _, _, costs, _ = _run(cs, noise, state, _dyn(0.05, (gamma / std ** 2, 0.0, 0.0)), False)
    # sum_t u (v - u) * gamma / std^2 = 30 * 0.2 * 0.1 * 0.375
    np.testing.assert_allclose(costs, t * 0.2 * 0.1 * gamma / std ** 2, rtol=1e-5)
