"""Savitzky-Golay smoothing, sequence limits, shifting and softmax weights."""

from __future__ import annotations

import math

import numpy as np

from navstack.control.mppi import control_sequence as csq
from navstack.control.mppi.models import (
    AckermannMotionModel,
    DiffDriveMotionModel,
    OmniMotionModel,
)
from navstack.control.mppi.optimizer import softmax_weights


def _line(t: np.ndarray) -> np.ndarray:
    return 0.1 + 0.02 * t


def test_savitzky_golay_preserves_a_line_exactly() -> None:
    n = 56
    t = np.arange(n, dtype=np.float64)
    seq = np.vstack((_line(t), np.zeros(n), -2.0 * _line(t)))
    history = np.column_stack((_line(np.arange(-4, 0.0)), np.zeros(4),
                               -2.0 * _line(np.arange(-4, 0.0))))
    original = seq.copy()
    assert csq.savitzky_golay(seq, history)
    # windows fully inside the line (history before, real points after) are exact
    np.testing.assert_allclose(seq[:, :n - 4], original[:, :n - 4], rtol=0, atol=1e-12)
    # the last element is not filtered (Nav2)
    assert np.array_equal(seq[:, -1], original[:, -1])
    # near the end the window repeats the last point: a known, non-linear value
    coeffs = np.array([-21, 14, 39, 54, 59, 54, 39, 14, -21]) / 231.0
    window = np.concatenate((original[0, n - 8:], original[0, -1:]))
    assert math.isclose(seq[0, n - 4], float(coeffs @ window), abs_tol=1e-12)
    # ... which is the line plus -c8 * slope (the last point is one slope short)
    assert math.isclose(seq[0, n - 4], original[0, n - 4] + 21.0 / 231.0 * 0.02,
                        abs_tol=1e-12)


def test_savitzky_golay_preserves_a_parabola_and_skips_short_sequences() -> None:
    t = np.arange(-4, 40, dtype=np.float64)
    parabola = 0.3 - 0.05 * t + 0.004 * t ** 2
    seq = np.tile(parabola[4:], (3, 1))
    history = np.tile(parabola[:4, None], (1, 3))
    csq.savitzky_golay(seq, history)
    np.testing.assert_allclose(seq[:, :36 - 4], np.tile(parabola[4:36], (3, 1)), atol=1e-12)
    short = np.ones((3, 20))
    assert not csq.savitzky_golay(short, np.zeros((4, 3)))
    assert np.array_equal(short, np.ones((3, 20)))


def test_linear_order_is_a_moving_average() -> None:
    seq = np.zeros((3, 30))
    seq[0, 10] = 9.0
    csq.savitzky_golay(seq, np.zeros((4, 3)), order=1)
    np.testing.assert_allclose(seq[0, 6:15], 1.0, atol=1e-12)
    assert np.all(seq[0, :6] == 0.0) and np.all(seq[0, 15:] == 0.0)


def test_limits_clip_velocity_and_acceleration() -> None:
    seq = np.zeros((3, 6))
    seq[0] = [0.0, 1.0, 1.0, 1.0, -1.0, -1.0]
    seq[2] = [0.0, 5.0, 5.0, 5.0, 5.0, 5.0]
    seq[1] = 0.7
    csq.apply_sequence_limits(seq, DiffDriveMotionModel(), vx_min=-0.35, vx_max=0.5,
                              vy_max=0.5, wz_max=1.9, dt=0.05,
                              accel=(3.0, -3.0, 3.0, -3.0, 3.5))
    # vx: +0.15 per step up to 0.5, then braking at 0.15 per step
    np.testing.assert_allclose(seq[0], [0.0, 0.15, 0.3, 0.45, 0.3, 0.15], atol=1e-12)
    np.testing.assert_allclose(seq[2], [0.0, 0.175, 0.35, 0.525, 0.7, 0.875], atol=1e-12)
    assert np.all(seq[1] == 0.0)  # non-holonomic: no lateral velocity
    omni = np.zeros((3, 3))
    omni[1] = [0.0, 2.0, 2.0]
    csq.apply_sequence_limits(omni, OmniMotionModel(), vx_min=-0.35, vx_max=0.5,
                              vy_max=0.5, wz_max=1.9, dt=0.1,
                              accel=(3.0, -3.0, 3.0, -3.0, 3.5))
    np.testing.assert_allclose(omni[1], [0.0, 0.3, 0.5], atol=1e-12)


def test_reverse_braking_uses_the_magnitude_limits() -> None:
    seq = np.array([[-0.3, 0.5, 0.5], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    csq.apply_sequence_limits(seq, DiffDriveMotionModel(), vx_min=-0.35, vx_max=0.5,
                              vy_max=0.0, wz_max=1.9, dt=0.1,
                              accel=(3.0, -1.0, 3.0, -3.0, 3.5))
    # reversing at -0.3: speeding back up towards forward is braking (|ax_min| = 1)
    np.testing.assert_allclose(seq[0], [-0.3, -0.2, -0.1], atol=1e-12)


def test_ackermann_constraint_on_the_sequence() -> None:
    seq = np.array([[1.0, -2.0, 0.0, 0.5], [0.0] * 4, [1.0, 1.0, 0.3, -0.05]])
    AckermannMotionModel(5.0).apply_constraints(seq[0], seq[1], seq[2])
    np.testing.assert_allclose(seq[2], [0.2, 0.4, 0.0, -0.05], atol=1e-12)


def test_shift_drops_the_first_and_repeats_the_last() -> None:
    seq = np.arange(12, dtype=np.float64).reshape(3, 4)
    csq.shift(seq)
    np.testing.assert_array_equal(seq, [[1, 2, 3, 3], [5, 6, 7, 7], [9, 10, 11, 11]])


def test_softmax_weights() -> None:
    temperature = 0.3
    w = softmax_weights(np.array([0.0, temperature * math.log(2.0), 1e6]), temperature)
    np.testing.assert_allclose(w, [2.0 / 3.0, 1.0 / 3.0, 0.0], atol=1e-15)
    rng = np.random.default_rng(3)
    for scale in (1e-3, 1.0, 1e8):
        w = softmax_weights(rng.random(2000) * scale, temperature)
        assert math.isclose(float(w.sum()), 1.0, rel_tol=1e-12) and np.all(w >= 0.0)
