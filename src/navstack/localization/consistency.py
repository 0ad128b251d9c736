"""Covariance consistency: the normalised estimation error squared (NEES).

For an estimate with error ``e`` (k-vector, truth minus estimate, angles wrapped) and
claimed covariance ``P``, ``NEES = e^T P^-1 e`` is chi-square distributed with ``k``
degrees of freedom when the filter is consistent (Bar-Shalom, Li & Kirubarajan,
"Estimation with Applications to Tracking and Navigation", 2001, section 5.4).  A single
run is checked step by step against the two-sided 95% band ``[chi2(0.025, k),
chi2(0.975, k)]``: a consistent filter falls inside on about 95% of steps; too many steps
above means over-confidence, too many below under-confidence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

from navstack.core.geometry import normalize_angle

__all__ = ["NeesBand", "nees", "nees_band"]


def nees(errors: ArrayLike, covariances: ArrayLike, angle_index: int | None = 2
         ) -> NDArray[np.float64]:
    """Per-step NEES of ``errors`` (N, k) under ``covariances`` (N, k, k).

    ``angle_index``: the error column holding an angle, wrapped to (-pi, pi] first."""
    e = np.array(errors, dtype=np.float64, ndmin=2)
    p = np.asarray(covariances, dtype=np.float64)
    if p.shape != (e.shape[0], e.shape[1], e.shape[1]):
        raise ValueError(f"covariances shape {p.shape} does not match errors {e.shape}; "
                         "give one k x k matrix per error row")
    if angle_index is not None and e.shape[1] > angle_index:
        e[:, angle_index] = normalize_angle(e[:, angle_index])
    solved = np.linalg.solve(p, e[..., None])[..., 0]
    return np.einsum("ni,ni->n", e, solved)


@dataclass(frozen=True)
class NeesBand:
    """Share of steps inside / above / below the two-sided chi-square band."""

    inside: float
    above: float
    below: float
    lower: float
    upper: float
    steps: int


def nees_band(values: ArrayLike, dof: int, confidence: float = 0.95) -> NeesBand:
    """Where the NEES values fall relative to the ``confidence`` chi-square band."""
    v = np.asarray(values, dtype=np.float64)
    tail = 0.5 * (1.0 - confidence)
    lower, upper = float(chi2.ppf(tail, dof)), float(chi2.ppf(1.0 - tail, dof))
    n = max(v.size, 1)
    return NeesBand(inside=float(np.mean((v >= lower) & (v <= upper))) if v.size else 0.0,
                    above=float(np.sum(v > upper)) / n, below=float(np.sum(v < lower)) / n,
                    lower=lower, upper=upper, steps=int(v.size))
