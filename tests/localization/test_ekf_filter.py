"""The pure filters: model, Jacobian, exact answers, gating, history, speed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.localization.ekf import Ekf, EkfParams, Measurement, Ukf, UkfParams
from navstack.localization.ekf.model import (
    AX,
    PITCH,
    ROLL,
    STATE_SIZE,
    VX,
    VY,
    VYAW,
    YAW,
    X,
    Y,
    Z,
    process_model,
    transfer_jacobian,
)

INF = float("inf")


def meas(t: float, values: dict[int, float], var: float = 0.01, sensor: str = "s",
         threshold: float = INF) -> Measurement:
    z = np.zeros(STATE_SIZE)
    cov = np.zeros((STATE_SIZE, STATE_SIZE))
    update = np.zeros(STATE_SIZE, dtype=bool)
    for i, v in values.items():
        z[i], cov[i, i], update[i] = v, var, True
    return Measurement(sensor, f"{sensor}_part", t, z, cov, update, threshold)


def test_jacobian_matches_finite_differences() -> None:
    rng = np.random.default_rng(4)
    for _ in range(5):
        x = rng.normal(size=STATE_SIZE)
        x[PITCH] = 0.4 * np.tanh(x[PITCH])
        dt = 0.07
        J = np.zeros((STATE_SIZE, STATE_SIZE))
        transfer_jacobian(x, dt, J)
        numeric = np.zeros_like(J)
        for i in range(STATE_SIZE):
            e = np.zeros(STATE_SIZE)
            e[i] = 1e-6
            a, b = np.zeros(STATE_SIZE), np.zeros(STATE_SIZE)
            process_model(x + e, dt, a)
            process_model(x - e, dt, b)
            d = a - b
            d[3:6] = (d[3:6] + np.pi) % (2 * np.pi) - np.pi
            numeric[:, i] = d / 2e-6
        np.testing.assert_allclose(J, numeric, atol=1e-8)


def test_body_velocity_is_rotated_by_the_full_attitude() -> None:
    x = np.zeros(STATE_SIZE)
    x[YAW], x[PITCH] = math.pi / 2, -math.pi / 6  # facing +y, nose up 30 degrees
    x[VX] = 2.0
    process_model(x, 0.5, x)
    np.testing.assert_allclose(x[[X, Y, Z]], [0.0, math.cos(math.pi / 6), 0.5], atol=1e-12)


def test_constant_velocity_straight_line_gives_the_exact_pose() -> None:
    """Odometry pose + twist of a robot driving straight at 0.5 m/s, heading 30 degrees:
    every innovation is zero, so the estimate is the exact pose at every step."""
    f = Ekf(EkfParams())
    heading, v = math.radians(30.0), 0.5
    for k in range(501):
        t = 100.0 + 0.02 * k
        d = v * (t - 100.0)
        f.process_measurement(meas(t, {X: d * math.cos(heading), Y: d * math.sin(heading),
                                       YAW: heading, VX: v, VYAW: 0.0}))
    assert f.rejected == {}
    assert f.state[X] == pytest.approx(5.0 * math.cos(heading), abs=1e-9)
    assert f.state[Y] == pytest.approx(5.0 * math.sin(heading), abs=1e-9)
    assert f.state[YAW] == pytest.approx(heading, abs=1e-12)
    assert f.state[VX] == pytest.approx(v, abs=1e-12)


@pytest.mark.parametrize("cls", [Ekf, Ukf])
def test_two_d_mode_keeps_z_roll_pitch_and_rates_at_zero(cls: type[Ekf]) -> None:
    params = UkfParams if cls is Ukf else EkfParams
    f = cls(params.from_mapping({"two_d_mode": True}))
    rng = np.random.default_rng(0)
    for k in range(200):
        t = 0.05 * k
        # a planar robot whose sensors also claim z / roll / pitch motion
        f.process_measurement(meas(t, {X: 0.3 * t, Z: 0.1 + rng.normal(),
                                       ROLL: 0.2, PITCH: -0.1, VX: 0.3, 8: 0.5, 9: 0.3,
                                       10: -0.2, YAW: 0.01 * t, 14: 9.8}))
    for i in (Z, ROLL, PITCH, 8, 9, 10, 14):
        assert f.state[i] == 0.0
        assert np.count_nonzero(f.covariance[i]) == 1  # only its own variance
    assert f.state[X] == pytest.approx(0.3 * 9.95, abs=0.02)
    assert f.state[YAW] == pytest.approx(0.0995, abs=1e-3)


def test_ukf_and_ekf_agree_on_a_linear_case() -> None:
    """Angles known and unperturbed: the model is linear in x, vx, ax, where the UKF's
    sigma points reproduce the EKF exactly."""
    q = [0.0] * STATE_SIZE
    q[X], q[VX], q[AX] = 0.05, 0.025, 0.01
    ekf = Ekf(EkfParams.from_mapping({"process_noise_covariance": q}))
    ukf = Ukf(UkfParams.from_mapping({"process_noise_covariance": q}))
    rng = np.random.default_rng(1)
    for k in range(200):
        t = 0.05 * k
        m = meas(t, {X: 0.3 * t + 0.1 * t * t + 0.05 * rng.normal(),
                     VX: 0.3 + 0.2 * t + 0.02 * rng.normal(), AX: 0.2 + 0.05 * rng.normal()})
        assert ekf.process_measurement(m).accepted and ukf.process_measurement(m).accepted
    np.testing.assert_allclose(ukf.state, ekf.state, atol=1e-6)
    np.testing.assert_allclose(ukf.covariance, ekf.covariance, atol=1e-8)
    assert ekf.state[X] == pytest.approx(0.3 * 9.95 + 0.1 * 9.95 ** 2, abs=0.1)


def test_mahalanobis_gate_rejects_an_outlier_and_leaves_the_state() -> None:
    f = Ekf(EkfParams())
    for k in range(20):
        f.process_measurement(meas(0.1 * k, {X: 1.0, Y: 2.0, YAW: 0.3}, threshold=3.0))
    before_x, before_p = f.state.copy(), f.covariance.copy()
    result = f.process_measurement(meas(2.0, {X: 6.0, Y: 2.0, YAW: 0.3}, threshold=3.0))
    assert not result.accepted and result.mahalanobis2 > 9.0
    assert result.reason.startswith("Mahalanobis distance ")
    assert result.reason.endswith(">= rejection threshold 3")
    np.testing.assert_array_equal(f.state, before_x)
    np.testing.assert_array_equal(f.covariance, before_p)
    assert f.rejected == {"s": 1} and f.accepted["s"] == 20
    assert f.rejection_reasons == {("s", "mahalanobis"): 1}


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_measurement_is_rejected_with_a_reason(bad: float) -> None:
    f = Ekf(EkfParams())
    f.process_measurement(meas(0.0, {X: 1.0, VX: 0.2}))
    before = f.state.copy()
    result = f.process_measurement(meas(0.1, {X: bad, VX: 0.2}))
    assert not result.accepted
    assert result.reason == "non-finite value in the measurement or its covariance"
    assert f.rejected["s"] == 1
    assert f.last_rejection["s"] == ("s_part at t=0.100000 s: non-finite value in the "
                                     "measurement or its covariance")
    np.testing.assert_array_equal(f.state, before)


def _stream(n: int) -> list[Measurement]:
    rng = np.random.default_rng(7)
    out = []
    for k in range(n):
        t = 0.1 * k
        out.append(meas(t, {X: 0.5 * t + 0.05 * rng.normal(), VX: 0.5}, sensor="odom0"))
        out.append(meas(t + 0.05, {YAW: 0.0 + 0.01 * rng.normal()}, sensor="imu0"))
    return out


def test_late_measurement_is_rejected_without_history() -> None:
    f = Ekf(EkfParams())
    stream = _stream(10)
    late = stream.pop(8)  # odom0 at t = 0.4 arrives after everything else
    for m in stream:
        f.enqueue(m)
    f.integrate(1.0)
    f.enqueue(late)
    assert f.integrate(1.0) == 0
    assert f.rejected == {"odom0": 1}
    assert "older than the last processed measurement" in f.last_rejection["odom0"]
    assert f.rejection_reasons == {("odom0", "out-of-order"): 1}


def test_smooth_lagged_data_replays_a_late_measurement_exactly() -> None:
    params = EkfParams.from_mapping({"smooth_lagged_data": True, "history_length": 2.0})
    in_order, lagged = Ekf(params), Ekf(params)
    stream = _stream(10)
    for m in stream:
        in_order.enqueue(m)
    in_order.integrate(1.0)
    late = stream.pop(8)
    for m in stream:
        lagged.enqueue(m)
    lagged.integrate(1.0)
    lagged.enqueue(late)
    lagged.integrate(1.0)
    assert lagged.rejected == {}
    assert lagged.accepted == in_order.accepted == {"odom0": 10, "imu0": 10}
    np.testing.assert_allclose(lagged.state, in_order.state, atol=1e-12)
    np.testing.assert_allclose(lagged.covariance, in_order.covariance, atol=1e-12)


def test_dynamic_process_noise_scales_pose_noise_with_speed() -> None:
    """robot_localization: the pose block of Q is scaled by |twist|^2, so a robot at rest
    gains no pose uncertainty."""
    f = Ekf(EkfParams.from_mapping({"dynamic_process_noise_covariance": True}))
    f.process_measurement(meas(0.0, {X: 0.0, Y: 0.0, VX: 0.0, VY: 0.0}, var=1e-4))
    f.predict(1.0, 1.0)  # only the velocity / acceleration uncertainty flows into x
    assert f.covariance[X, X] == pytest.approx(1e-4 + 1e-4 + 0.25 * 1e-9, rel=1e-12)
    g = Ekf(EkfParams.from_mapping({"dynamic_process_noise_covariance": True}))
    g.process_measurement(meas(0.0, {X: 0.0, Y: 0.0, VX: 2.0, VY: 0.0}, var=1e-4))
    g.predict(0.5, 0.5)  # |v|^2 = 4: x gains 0.5 * 4 * 0.05 on top of the same terms
    assert g.covariance[X, X] == pytest.approx(
        1e-4 + 0.25 * 1e-4 + 0.0625 * 0.25 * 1e-9 + 0.5 * 4 * 0.05, rel=1e-12)


def test_sensor_timeout_predicts_to_now() -> None:
    f = Ekf(EkfParams.from_mapping({"sensor_timeout": 0.1}))
    f.enqueue(meas(0.0, {X: 0.0, VX: 1.0}))
    f.integrate(0.0)
    f.integrate(0.05)  # within the timeout: the filter waits for data
    assert f.last_measurement_time == 0.0
    f.integrate(0.5)  # silent for longer: predict to now, as robot_localization
    assert f.last_measurement_time == 0.5 and f.state[X] == pytest.approx(0.5, abs=1e-12)


def test_control_term_accelerates_towards_the_command() -> None:
    """robot_localization's control model: ax = clamp(gain * (cmd - v), limit)."""
    f = Ekf(EkfParams.from_mapping({"use_control": True, "control_timeout": 1.0,
                                    "control_config": [True] + [False] * 5,
                                    "acceleration_limits": [1.3] + [1.0] * 5,
                                    "acceleration_gains": [0.8] + [1.0] * 5}))
    f.process_measurement(meas(0.0, {X: 0.0, VX: 0.0}))
    f.set_control(np.array([1.0, 0, 0, 0, 0, 0]), 0.0)
    f.predict(0.1, 0.1)
    assert f.state[AX] == pytest.approx(0.8) and f.state[VX] == pytest.approx(0.08)


def test_every_update_is_timed() -> None:
    """Each predict + correct is timed (the 0.2 ms budget is ``navstack bench
    localization``'s)."""
    f = Ekf(EkfParams())
    stream = [meas(0.01 * k, {VX: 0.4, VYAW: 0.1, 7: 0.0}) if k % 2 else
              meas(0.01 * k, {YAW: 0.001 * k}, var=2.5e-5) for k in range(2100)]
    for m in stream:
        f.process_measurement(m)
    assert len(f.update_ms) == 2100 and min(f.update_ms) > 0.0
