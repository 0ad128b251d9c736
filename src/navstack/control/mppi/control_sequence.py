"""The MPPI control sequence: Savitzky-Golay smoothing, limits, shifting.

The optimizer keeps one ``(3, T)`` sequence (rows ``vx``, ``vy``, ``wz``) that is the
mean of the sampling distribution and, after each update, the plan whose first (or,
when shifting, second) element is sent to the robot.

* :func:`savitzky_golay` is Nav2's ``utils::savitskyGolayFilter``: a 9-point window,
  quadratic (coefficients ``[-21, 14, 39, 54, 59, 54, 39, 14, -21] / 231``) or, with
  ``sgf_order: 1``, a moving average.  The four points before the sequence come from the
  history of sent controls, the points beyond its end repeat the last element, and the
  last element itself is left as is; sequences shorter than 21 are not filtered.  A
  quadratic 9-point Savitzky-Golay filter reproduces any polynomial of degree <= 2
  exactly (Savitzky & Golay, Anal. Chem. 36(8), 1964).
* :func:`apply_sequence_limits` is ``Optimizer::applyControlSequenceConstraints``: clip
  to the velocity limits, then walk the sequence clamping each step to what the previous
  one can reach within ``model_dt`` (``ax_*``, ``ay_*``, ``az_max``), then apply the
  motion model's own limits (Ackermann turning radius).
* :func:`shift` drops the executed first element and repeats the last
  (``Optimizer::shiftControlSequence``).

Nav2 Jazzy smooths after the limits are applied; navstack follows Nav2 Kilted and
smooths first, so the sent command always satisfies the limits (an Ackermann command
never violates ``|wz| <= |vx| / min_turning_r``).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.control.mppi.models import MotionModel

FloatArray = NDArray[np.float64]

SG_QUADRATIC = np.array([-21.0, 14.0, 39.0, 54.0, 59.0, 54.0, 39.0, 14.0, -21.0]) / 231.0
SG_LINEAR = np.full(9, 1.0 / 9.0)


@numba.njit(cache=True)
def _filter_rows(seq: FloatArray, history: FloatArray, coeffs: FloatArray) -> None:
    n_last = seq.shape[1] - 1  # Nav2 num_sequences: the last element is not filtered
    window = np.empty(9)
    for r in range(seq.shape[0]):
        initial = seq[r].copy()
        for k in range(4):
            window[k] = history[k, r]
        for k in range(5):
            window[4 + k] = initial[k]
        for idx in range(n_last):
            acc = 0.0
            for k in range(9):
                acc += window[k] * coeffs[k]
            seq[r, idx] = acc
            for k in range(8):
                window[k] = window[k + 1]
            window[8] = initial[idx + 5] if idx + 5 < n_last else initial[n_last]


def savitzky_golay(seq: FloatArray, history: FloatArray, order: int = 2) -> bool:
    """Smooth ``seq`` ``(R, T)`` in place with Nav2's 9-point filter.

    ``history`` ``(4, R)`` holds the last four sent controls, oldest first.  Returns
    False (and leaves ``seq`` alone) when the sequence is too short (``T - 1 < 20``).
    """
    if seq.shape[1] - 1 < 20:
        return False
    _filter_rows(seq, np.ascontiguousarray(history, dtype=np.float64),
                 SG_LINEAR if order == 1 else SG_QUADRATIC)
    return True


def push_history(history: FloatArray, control: FloatArray) -> None:
    """Append the sent control ``(R,)`` to the ``(4, R)`` history (Nav2 keeps four)."""
    history[:-1] = history[1:]
    history[-1] = control


@numba.njit(cache=True)
def _accel_walk(row: FloatArray, min_delta: float, max_delta: float) -> None:
    """Clamp each element to what the previous one reaches (``clampVelocityByAccel``)."""
    last = row[0]
    for t in range(1, row.shape[0]):
        if last >= 0.0:
            lo, hi = last + min_delta, last + max_delta
        else:
            lo, hi = last - max_delta, last - min_delta
        row[t] = min(max(row[t], lo), hi)
        last = row[t]


def apply_sequence_limits(seq: FloatArray, model: MotionModel, *, vx_min: float,
                          vx_max: float, vy_max: float, wz_max: float, dt: float,
                          accel: tuple[float, float, float, float, float]) -> None:
    """Velocity, acceleration and motion-model limits on ``seq`` ``(3, T)`` in place.

    ``accel`` is ``(ax_max, ax_min, ay_max, ay_min, az_max)`` (``ax_min``, ``ay_min``
    <= 0).  The acceleration walk starts from ``seq[:, 0]`` as Nav2 Jazzy does.
    """
    ax_max, ax_min, ay_max, ay_min, az_max = accel
    np.clip(seq[0], vx_min, vx_max, out=seq[0])
    np.clip(seq[2], -wz_max, wz_max, out=seq[2])
    _accel_walk(seq[0], dt * ax_min, dt * ax_max)
    _accel_walk(seq[2], -dt * az_max, dt * az_max)
    if model.is_holonomic:
        np.clip(seq[1], -vy_max, vy_max, out=seq[1])
        _accel_walk(seq[1], dt * ay_min, dt * ay_max)
    else:
        seq[1] = 0.0
    model.apply_constraints(seq[0], seq[1], seq[2])


@numba.njit(cache=True, fastmath=True)
def weighted_mean(controls: NDArray[np.float32], weights: FloatArray, channels: int,
                  out: FloatArray) -> None:
    """``out[ch, t] = sum_i weights[i] * controls[ch, t, i]`` (MPPI's importance-weighted
    mean) for the rows set in the bit mask ``channels`` (bit 0 vx, 1 vy, 2 wz);
    ``controls`` (3, T, B) float32, float64 accumulation."""
    for ch in range(controls.shape[0]):
        if (channels >> ch) & 1 == 0:
            continue
        for t in range(controls.shape[1]):
            acc = 0.0
            for i in range(controls.shape[2]):
                acc += weights[i] * controls[ch, t, i]
            out[ch, t] = acc


def shift(seq: FloatArray) -> None:
    """Drop the first element of every row and repeat the last one."""
    seq[:, :-1] = seq[:, 1:].copy()
    seq[:, -1] = seq[:, -2]
