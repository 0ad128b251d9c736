"""Unscented Kalman filter over the same 15-state model (robot_localization ``Ukf``).

Sigma points ``x, x +- sqrt((n + lambda) P)_i`` with ``lambda = alpha^2 (n + kappa) - n``
and the scaled weights of Julier & Uhlmann / Wan & van der Merwe ("The Unscented Kalman
Filter for Nonlinear Estimation", 2000); robot_localization's defaults ``alpha`` 0.001,
``kappa`` 0, ``beta`` 2.

Two deliberate differences from robot_localization's implementation, both towards the
textbook filter:

* predict pushes every sigma point through the *nonlinear* process model
  (:func:`process_model_batch`); upstream multiplies them by the transfer matrix built at
  the mean, which makes its UKF prediction a linearised one;
* correct draws fresh sigma points from the predicted mean and covariance, so the
  process noise of the last prediction is part of the innovation covariance (upstream
  reuses the propagated points, which leave ``dt Q`` out of ``S``).  The measurement
  model selects state variables, so this update is exact.

Means and differences of sigma points handle the angle wrap (differences to the central
point are wrapped before averaging).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import normalize_angle
from navstack.localization.ekf.ekf import CorrectionResult, FilterBase, Measurement
from navstack.localization.ekf.model import (
    ANGLE_INDICES,
    STATE_SIZE,
    VX,
    process_model_batch,
)
from navstack.localization.ekf.params import EkfParams, UkfParams

__all__ = ["Ukf"]

_ANGLES = np.array(ANGLE_INDICES, dtype=np.int64)


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class Ukf(FilterBase):
    """Unscented Kalman filter; parameters as :class:`UkfParams` (``alpha``, ``kappa``,
    ``beta``), an :class:`EkfParams` uses robot_localization's UKF defaults."""

    def __init__(self, params: EkfParams | None = None) -> None:
        super().__init__(params or UkfParams())
        p = self.params
        alpha = p.alpha if isinstance(p, UkfParams) else 0.001
        kappa = p.kappa if isinstance(p, UkfParams) else 0.0
        beta = p.beta if isinstance(p, UkfParams) else 2.0
        n = STATE_SIZE
        lam = alpha * alpha * (n + kappa) - n
        self.spread = n + lam  # alpha^2 (n + kappa) > 0: UkfParams bounds kappa > -n
        self.mean_weights = np.full(2 * n + 1, 1.0 / (2.0 * self.spread))
        self.mean_weights[0] = lam / self.spread
        self.cov_weights = self.mean_weights.copy()
        self.cov_weights[0] += 1.0 - alpha * alpha + beta

    # --- sigma points ----------------------------------------------------------------------
    def sigma_points(self) -> NDArray[np.float64]:
        """(2n + 1, n) sigma points of the current state and covariance."""
        L = _cholesky(self.spread * self.covariance)
        X = np.repeat(self.state[None, :], 2 * STATE_SIZE + 1, axis=0)
        X[1:STATE_SIZE + 1] += L.T
        X[STATE_SIZE + 1:] -= L.T
        return X

    def _mean(self, X: NDArray[np.float64], angles: NDArray[np.bool_]
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Weighted mean of the rows of ``X`` and the (wrapped) deviations from it."""
        d = X - X[0]
        d[:, angles] = _wrap(d[:, angles])
        mean = X[0] + self.mean_weights @ d
        mean[angles] = _wrap(mean[angles])
        dev = X - mean
        dev[:, angles] = _wrap(dev[:, angles])
        return mean, dev

    # --- filter ------------------------------------------------------------------------------
    def predict(self, dt: float, reference_time: float) -> None:
        """Unscented time update: propagate the sigma points, re-estimate mean and
        covariance, add ``dt Q`` (scaled by ``|twist|^2`` on the pose block when
        ``dynamic_process_noise_covariance``)."""
        self._apply_control(dt, reference_time)
        q = self.process_noise
        if self.params.dynamic_process_noise_covariance:
            q = q.copy()
            q[:VX, :VX] *= float(np.dot(self.state[VX:VX + 6], self.state[VX:VX + 6]))
        X = self.sigma_points()
        process_model_batch(X, dt)
        angles = np.zeros(STATE_SIZE, dtype=bool)
        angles[_ANGLES] = True
        mean, dev = self._mean(X, angles)
        P = (dev.T * self.cov_weights) @ dev + dt * q
        self.state = mean
        self.covariance = 0.5 * (P + P.T)
        self._enforce_two_d()

    def correct(self, m: Measurement) -> CorrectionResult:
        """Sigma-point measurement update of the variables ``m`` measures, gated on the
        Mahalanobis distance like the EKF."""
        idx = m.indices
        X = self.sigma_points()
        Z = X[:, idx]
        z_angles = np.isin(idx, _ANGLES)
        z_mean, dz = self._mean(Z, z_angles)
        dx = X - self.state
        dx[:, _ANGLES] = _wrap(dx[:, _ANGLES])
        R = m.covariance[np.ix_(idx, idx)].copy()
        diag = np.abs(np.diag(R))
        np.fill_diagonal(R, np.maximum(diag, 1e-9))
        S = (dz.T * self.cov_weights) @ dz + R
        Pxz = (dx.T * self.cov_weights) @ dz
        nu = m.z[idx] - z_mean
        nu[z_angles] = _wrap(nu[z_angles])
        try:
            S_inv = np.linalg.inv(S)
        except np.linalg.LinAlgError:
            return CorrectionResult(False, math.nan, "innovation covariance is singular",
                                    "numerical")
        d2 = float(nu @ S_inv @ nu)
        if not d2 < m.threshold * m.threshold:
            if not math.isfinite(d2):
                return CorrectionResult(False, d2, "innovation is not finite", "numerical")
            return CorrectionResult(False, d2, f"Mahalanobis distance {math.sqrt(d2):.3f} >= "
                                               f"rejection threshold {m.threshold:g}",
                                    "mahalanobis")
        K = Pxz @ S_inv
        self.state = self.state + K @ nu
        for i in ANGLE_INDICES:
            self.state[i] = normalize_angle(float(self.state[i]))
        P = self.covariance - K @ S @ K.T
        self.covariance = 0.5 * (P + P.T)
        self._enforce_two_d()
        return CorrectionResult(True, d2)


def _cholesky(P: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lower Cholesky factor; a covariance that lost definiteness to rounding is
    projected onto the nearest positive-definite matrix first (eigenvalues floored)."""
    try:
        return np.asarray(np.linalg.cholesky(P), dtype=np.float64)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(0.5 * (P + P.T))
        floor = max(1e-12, 1e-12 * float(np.max(np.abs(w))))
        fixed = np.linalg.cholesky((V * np.maximum(w, floor)) @ V.T)
        return np.asarray(fixed, dtype=np.float64)
