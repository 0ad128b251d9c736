"""The filter core shared by the EKF and UKF, and the EKF itself (robot_localization).

``FilterBase`` is robot_localization's ``FilterBase`` plus the measurement queue of its
``RosFilter``, with no bus: feed :class:`Measurement` objects with :meth:`enqueue` and
call :meth:`integrate` with the current time; it processes queued measurements in
timestamp order (predict to each stamp, then correct), as
``RosFilter::integrateMeasurements`` does.

* The first measurement initialises the variables it measures (``processMeasurement``).
* A measurement older than the last *processed measurement* cannot be fused where it
  belongs without history.  With ``smooth_lagged_data`` the filter keeps
  ``history_length`` seconds of states and measurements, reverts to the last state
  before the late one and replays (robot_localization's ``revertTo``); without it, the
  late measurement is rejected and counted (robot_localization would fuse it as if it
  were current, a silent error).  A measurement only older than the filter's predicted
  time (``predict_to_current_time``) is corrected without prediction, as upstream.
* Non-finite values, failed Mahalanobis gates and numerically broken updates are
  rejected with a reason and counted per sensor; the state is left untouched.
* ``two_d_mode`` holds z, roll, pitch and their rates exactly at zero (robot_localization
  fuses zero pseudo-measurements in ``forceTwoD``; pinning them is the same intent,
  exact and cheaper).
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
from abc import ABC, abstractmethod
from collections import Counter, deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import normalize_angle
from navstack.localization.ekf.model import (
    STATE_SIZE,
    TWO_D_INDICES,
    VROLL,
    VX,
    ekf_correct,
    ekf_predict,
)
from navstack.localization.ekf.params import EkfParams

__all__ = ["REJECTION_CATEGORIES", "CorrectionResult", "Ekf", "FilterBase", "Measurement",
           "control_acceleration"]

_TWO_D = np.array(TWO_D_INDICES, dtype=np.int64)


@dataclass(eq=False)
class Measurement:
    """One measurement, already in the filter's frames (robot_localization ``Measurement``).

    ``z`` (15,) and ``covariance`` (15, 15) are full state size; ``update_vector`` (15,)
    selects the measured variables.  ``topic`` names the part (``odom0_twist``),
    ``sensor`` the configured input (``odom0``) that rejections are counted against.
    ``replayed`` marks a measurement re-processed from the ``smooth_lagged_data``
    history: it is counted (accepted / rejected) only the first time.
    """

    sensor: str
    topic: str
    time: float
    z: NDArray[np.float64]
    covariance: NDArray[np.float64]
    update_vector: NDArray[np.bool_]
    threshold: float = float("inf")
    indices: NDArray[np.int64] = field(init=False)
    replayed: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        self.indices = np.flatnonzero(self.update_vector).astype(np.int64)


REJECTION_CATEGORIES = ("non-finite", "mahalanobis", "out-of-order", "no-transform",
                        "before-set-pose", "empty", "numerical")
"""What ``rejection_reasons`` counts per sensor (the full text is in ``last_rejection``)."""


@dataclass(frozen=True)
class CorrectionResult:
    """Outcome of one correction: ``accepted``, squared Mahalanobis distance, and for a
    refusal its ``category`` (one of :data:`REJECTION_CATEGORIES`) and ``reason``."""

    accepted: bool
    mahalanobis2: float
    reason: str = ""
    category: str = ""


@dataclass
class _Snapshot:
    time: float
    state: NDArray[np.float64]
    covariance: NDArray[np.float64]
    last_measurement_time: float
    last_processed_time: float
    initialized: bool


def control_acceleration(state: float, control: float, acceleration_limit: float,
                         acceleration_gain: float, deceleration_limit: float,
                         deceleration_gain: float) -> float:
    """robot_localization's ``computeControlAcceleration``: a clamped proportional pull of
    one velocity towards its commanded value (deceleration gains/limits when slowing)."""
    error = control - state
    same_sign = abs(error) <= abs(control) + 0.01
    set_point = control if same_sign else 0.0
    decelerating = abs(set_point) < abs(state)
    limit = deceleration_limit if decelerating else acceleration_limit
    gain = deceleration_gain if decelerating else acceleration_gain
    return min(max(gain * error, -limit), limit)


class FilterBase(ABC):
    """State, covariance, measurement queue, lagged-data history and bookkeeping."""

    def __init__(self, params: EkfParams | None = None) -> None:
        self.params = params or EkfParams()
        p = self.params
        self.process_noise = np.ascontiguousarray(p.process_noise)
        self.initial_covariance = np.ascontiguousarray(p.initial_covariance)
        self.two_d_mode = p.two_d_mode
        self.sensor_timeout = p.timeout
        self.update_ms: list[float] = []
        self.accepted: Counter[str] = Counter()
        self.rejected: Counter[str] = Counter()
        self.rejection_reasons: Counter[tuple[str, str]] = Counter()
        self.last_rejection: dict[str, str] = {}
        self.latest_control = np.zeros(6)
        self.latest_control_time = -math.inf
        self.reset()

    # --- state ---------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the uninitialised filter (robot_localization ``reset``)."""
        p = self.params
        self.state = np.zeros(STATE_SIZE)
        if p.initial_state is not None:
            self.state[:] = p.initial_state
        self.covariance = self.initial_covariance.copy()
        self.initialized = False
        self.last_measurement_time = 0.0
        self.last_processed_time = -math.inf
        self._queue: list[tuple[float, int, Measurement]] = []
        self._seq = itertools.count()
        self._states: deque[_Snapshot] = deque()
        self._history: deque[Measurement] = deque()
        self._enforce_two_d()

    def set_pose(self, state: NDArray[np.float64], covariance: NDArray[np.float64],
                 stamp: float) -> None:
        """Overwrite state and covariance (robot_localization ``set_pose``)."""
        self.state = np.array(state, dtype=np.float64).reshape(STATE_SIZE)
        self.covariance = np.array(covariance, dtype=np.float64).reshape(STATE_SIZE,
                                                                          STATE_SIZE)
        self.initialized = True
        self.last_measurement_time = stamp
        self.last_processed_time = stamp
        self._queue.clear()
        self._states.clear()
        self._history.clear()
        self._enforce_two_d()

    def set_control(self, control: NDArray[np.float64], stamp: float) -> None:
        """Latest commanded body velocity (vx, vy, vz, vroll, vpitch, vyaw)."""
        self.latest_control = np.asarray(control, dtype=np.float64).reshape(6)
        self.latest_control_time = stamp

    # --- queue -----------------------------------------------------------------------------
    def enqueue(self, measurement: Measurement) -> None:
        heapq.heappush(self._queue, (measurement.time, next(self._seq), measurement))

    @property
    def queued(self) -> int:
        return len(self._queue)

    def integrate(self, now: float) -> int:
        """Process queued measurements stamped ``<= now``; returns how many were fused.

        Then, as ``RosFilter::integrateMeasurements``, predict up to ``now`` when
        ``predict_to_current_time`` is set or no measurement arrived for
        ``sensor_timeout``."""
        p = self.params
        fused = 0
        predict_now = p.predict_to_current_time
        if self._queue:
            first = self._queue[0][2]
            if p.smooth_lagged_data and first.time < self.last_processed_time:
                self._revert_to(first.time)
            while self._queue and self._queue[0][0] <= now:
                m = heapq.heappop(self._queue)[2]
                if self.process_measurement(m).accepted:
                    fused += 1
                if p.smooth_lagged_data and (not self._history
                                             or m.time >= self._history[-1].time):
                    self._history.append(m)
                    if not self._queue or self._queue[0][0] != self.last_measurement_time:
                        self._save_state()
        elif self.initialized and now - self.last_measurement_time >= self.sensor_timeout:
            predict_now = True
        if self.initialized and predict_now and now > self.last_measurement_time:
            self.predict(now - self.last_measurement_time, now)
            self.last_measurement_time = now
        if p.smooth_lagged_data:
            self._clear_expired_history(self.last_measurement_time - abs(p.history_length))
        return fused

    # --- one measurement ------------------------------------------------------------------
    def process_measurement(self, m: Measurement) -> CorrectionResult:
        """Predict to ``m.time`` and correct (robot_localization ``processMeasurement``);
        the wall time of both is appended to :attr:`update_ms`."""
        if m.indices.size == 0:
            return self._reject(m, "empty", "measures no variable", math.nan)
        if m.time < self.last_processed_time:
            why = ("beyond history_length" if self.params.smooth_lagged_data else
                   "and no history is kept (enable smooth_lagged_data)")
            return self._reject(m, "out-of-order",
                                f"stamp {m.time:.6f} s is older than the last processed "
                                f"measurement ({self.last_processed_time:.6f} s) {why}",
                                math.nan)
        z = m.z[m.indices]
        r = m.covariance[np.ix_(m.indices, m.indices)]
        if not (np.isfinite(z).all() and np.isfinite(r).all()):
            return self._reject(m, "non-finite",
                                "non-finite value in the measurement or its covariance", math.nan)
        t0 = time.perf_counter()
        if not self.initialized:
            self._initialize_from(m)
            self.update_ms.append((time.perf_counter() - t0) * 1e3)
            self.accepted[m.sensor] += not m.replayed
            return CorrectionResult(True, 0.0)
        saved_x, saved_p = self.state.copy(), self.covariance.copy()
        dt = m.time - self.last_measurement_time
        if dt > 0.0:
            self.predict(dt, m.time)
        result = self.correct(m)
        if result.accepted and not (np.isfinite(self.state).all()
                                    and np.isfinite(self.covariance).all()):
            result = CorrectionResult(False, result.mahalanobis2,
                                      "update produced non-finite values; state restored",
                                      "numerical")
        if not result.accepted:
            self.state, self.covariance = saved_x, saved_p
            self.update_ms.append((time.perf_counter() - t0) * 1e3)
            return self._reject(m, result.category, result.reason, result.mahalanobis2)
        self.update_ms.append((time.perf_counter() - t0) * 1e3)
        self.last_measurement_time = max(self.last_measurement_time, m.time)
        self.last_processed_time = m.time
        self.accepted[m.sensor] += not m.replayed
        return result

    def _initialize_from(self, m: Measurement) -> None:
        idx = m.indices
        self.state[idx] = m.z[idx]
        for i in idx:
            if i in (3, 4, 5):
                self.state[i] = normalize_angle(float(self.state[i]))
        self.covariance[np.ix_(idx, idx)] = m.covariance[np.ix_(idx, idx)]
        self.initialized = True
        self.last_measurement_time = m.time
        self.last_processed_time = m.time
        self._enforce_two_d()

    def count_rejection(self, sensor: str, category: str, message: str) -> None:
        """Count a refused message or measurement of ``sensor``: ``rejected[sensor]``,
        ``rejection_reasons[(sensor, category)]``, and the text in ``last_rejection``."""
        self.rejected[sensor] += 1
        self.rejection_reasons[(sensor, category)] += 1
        self.last_rejection[sensor] = message

    def _reject(self, m: Measurement, category: str, reason: str, d2: float
                ) -> CorrectionResult:
        if not m.replayed:
            self.count_rejection(m.sensor, category, f"{m.topic} at t={m.time:.6f} s: {reason}")
        return CorrectionResult(False, d2, reason, category)

    # --- filter-specific -------------------------------------------------------------------
    @abstractmethod
    def predict(self, dt: float, reference_time: float) -> None:
        """Project state and covariance ``dt`` seconds ahead (to ``reference_time``)."""

    @abstractmethod
    def correct(self, m: Measurement) -> CorrectionResult:
        """Fuse ``m`` (already predicted to its stamp) or refuse it with a reason."""

    # --- helpers for subclasses ------------------------------------------------------------
    def _apply_control(self, dt: float, reference_time: float) -> None:
        """robot_localization ``prepareControl`` + step (1) of ``predict``: commanded
        accelerations on the body rates and linear accelerations."""
        p = self.params
        if not p.use_control:
            return
        timed_out = reference_time - self.latest_control_time >= p.control_timeout
        acc = np.zeros(6)
        for k in range(6):
            if p.control_config[k]:
                cmd = 0.0 if timed_out else float(self.latest_control[k])
                acc[k] = control_acceleration(float(self.state[VX + k]), cmd,
                                              p.acceleration_limits[k],
                                              p.acceleration_gains[k], p.decel_limits[k],
                                              p.decel_gains[k])
        self.state[VROLL:VROLL + 3] += acc[3:] * dt
        for k in range(3):
            if p.control_config[k]:
                self.state[12 + k] = acc[k]

    def _enforce_two_d(self) -> None:
        if not self.two_d_mode:
            return
        self.state[_TWO_D] = 0.0
        diag = self.initial_covariance[_TWO_D, _TWO_D]
        self.covariance[_TWO_D, :] = 0.0
        self.covariance[:, _TWO_D] = 0.0
        self.covariance[_TWO_D, _TWO_D] = np.maximum(diag, 1e-9)

    # --- history (smooth_lagged_data) -------------------------------------------------------
    def _save_state(self) -> None:
        self._states.append(_Snapshot(self.last_measurement_time, self.state.copy(),
                                      self.covariance.copy(), self.last_measurement_time,
                                      self.last_processed_time, self.initialized))

    def _revert_to(self, t: float) -> bool:
        """Restore the last state saved strictly before ``t`` and re-queue the measurements
        processed after it (robot_localization ``revertTo``)."""
        keep = None
        for k in range(len(self._states) - 1, -1, -1):
            if self._states[k].time < t:
                keep = k
                break
        if keep is None:
            return False
        while len(self._states) > keep + 1:
            self._states.pop()
        snap = self._states[-1]
        self.state, self.covariance = snap.state.copy(), snap.covariance.copy()
        self.last_measurement_time = snap.last_measurement_time
        self.last_processed_time = snap.last_processed_time
        self.initialized = snap.initialized
        while self._history and self._history[-1].time > snap.time:
            m = self._history.pop()
            m.replayed = True
            self.enqueue(m)
        return True

    def _clear_expired_history(self, cutoff: float) -> None:
        while len(self._states) > 1 and self._states[1].time < cutoff:
            self._states.popleft()
        oldest = self._states[0].time if self._states else math.inf
        while self._history and self._history[0].time < min(cutoff, oldest):
            self._history.popleft()


class Ekf(FilterBase):
    """Extended Kalman filter over the 15-state omnidirectional model (robot_localization
    ``Ekf``): Jacobian time update, Joseph-form partial-state correction with Mahalanobis
    gating, all in numba kernels (:mod:`navstack.localization.ekf.model`)."""

    def __init__(self, params: EkfParams | None = None) -> None:
        super().__init__(params)
        self._J = np.zeros((STATE_SIZE, STATE_SIZE))

    def predict(self, dt: float, reference_time: float) -> None:
        """Project state and covariance ``dt`` seconds ahead."""
        self._apply_control(dt, reference_time)
        ekf_predict(self.state, self.covariance, self.process_noise, dt,
                    self.params.dynamic_process_noise_covariance, self._J)
        self._enforce_two_d()

    def correct(self, m: Measurement) -> CorrectionResult:
        """Fuse ``m`` unless its Mahalanobis distance reaches ``m.threshold``."""
        d2 = ekf_correct(self.state, self.covariance, m.z, m.covariance, m.indices,
                         m.threshold)
        if not d2 < m.threshold * m.threshold:
            if not math.isfinite(d2):
                return CorrectionResult(False, d2, "innovation is not finite", "numerical")
            return CorrectionResult(False, d2, f"Mahalanobis distance {math.sqrt(d2):.3f} >= "
                                               f"rejection threshold {m.threshold:g}",
                                    "mahalanobis")
        self._enforce_two_d()
        return CorrectionResult(True, d2)
