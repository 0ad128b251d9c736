"""Rules a SLAM link follows once its matches are in: which fit places a scan without
odometry, when a match is degenerate (a corridor, an open hall), and how it is fused with
the odometry.  Pure functions of poses and covariances, split out of
:mod:`navstack.mapping.slam` (:meth:`~navstack.mapping.slam.SlamMapper._add_linked_node`
applies them).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import se2_between, se2_compose
from navstack.mapping.scan_matcher import MatchResult

FloatArray = NDArray[np.float64]

__all__ = ["GAP_STRONG_RESPONSE", "GAP_WEAK_RESPONSE", "degenerate", "distance", "fuse",
           "gap_choice", "weak_part"]

#: a scan without odometry keeps the local fit around its prediction when the wide
#: search found nothing only if it scores at least this share of the typical link
#: response (:func:`gap_choice`); a strong fit is at least ``GAP_STRONG_RESPONSE``
GAP_WEAK_RESPONSE = 0.5
GAP_STRONG_RESPONSE = 0.9


def gap_choice(local: MatchResult | None, wide: MatchResult | None, ambiguous: bool,
                typical: float) -> MatchResult | None:
    """The fit of a scan with no odometry over its step (a gap): ``local`` around the
    motion prediction, ``wide`` the best fit within the robot's reach
    (:func:`~navstack.mapping.recovery.predicted_link`), ``ambiguous`` when another fit
    there scores almost as well, ``typical`` the links' typical response.

    * a unique wide fit wins (with a guessed motion a strong local fit is often an
      alias along a corridor: Intel, every second interval without odometry, 13 of the
      first 150 gap scans were placed 0.3-1.2 m off that way);
    * an ambiguous one loses to a strong local fit (``GAP_STRONG_RESPONSE`` times the
      typical response: the prediction was right; in the ACES corridors the ambiguous
      wide fits were often the 180 degree turned corridor), else it wins;
    * without any wide fit the local one is kept only if it is not weak
      (``GAP_WEAK_RESPONSE``): a weak fit around a guess that is tens of degrees off
      (ACES scan 73: 55 degrees) bent the whole map, a scan left unplaced (tied
      loosely, :meth:`SlamMapper._add_linked_node`) does not."""
    if wide is None:
        return local if local is not None and local.response >= GAP_WEAK_RESPONSE * typical \
            else None
    if ambiguous and local is not None and local.response >= GAP_STRONG_RESPONSE * typical:
        return local
    return wide


def distance(a: FloatArray, b: FloatArray) -> float:
    """Distance between the positions of two poses."""
    return math.hypot(float(a[0] - b[0]), float(a[1] - b[1]))


def fuse(a: FloatArray, cov_a: FloatArray, b: FloatArray, cov_b: FloatArray) -> FloatArray:
    """Information-weighted mean of two poses (covariances in their tangent spaces, taken
    as the same frame: the poses are centimetres apart)."""
    d = se2_between(a, b)
    info_a, info_b = np.linalg.inv(cov_a), np.linalg.inv(cov_b)
    step = np.linalg.solve(info_a + info_b, info_b @ d)
    return se2_compose(a, step)




def degenerate(cov: FloatArray, unit: FloatArray, ratio: float = 3.0) -> bool:
    """Is a match covariance (scaled by the perfect match's deviations ``unit``) at least
    ``ratio`` times longer in its weakest direction than in its strongest?"""
    scaled = cov / (unit[:, None] * unit[None, :])
    w = np.linalg.eigvalsh(0.5 * (scaled + scaled.T))
    return bool(w[-1] >= ratio * ratio * max(float(w[0]), 1e-12))


def weak_part(information: FloatArray, cov: FloatArray, unit: FloatArray,
               ratio: float = 3.0) -> FloatArray:
    """``information`` restricted to the weak directions of a match covariance ``cov``
    (those at least ``ratio`` times longer than its strongest, measured in the perfect
    match's deviations ``unit``): ``P I P`` with ``P`` the projector on them, plus a
    negligible information (a thousand ``unit`` deviations) elsewhere so that it stays
    positive definite."""
    s_inv = 1.0 / unit
    scaled = cov * s_inv[:, None] * s_inv[None, :]
    w, v = np.linalg.eigh(0.5 * (scaled + scaled.T))
    weak = v[:, w >= ratio * ratio * max(float(w[0]), 1e-12)]
    proj = weak @ weak.T
    info_scaled = information * unit[:, None] * unit[None, :]
    part = proj @ info_scaled @ proj
    part = 0.5 * (part + part.T) * s_inv[:, None] * s_inv[None, :]
    return part + np.diag(1.0 / (1e3 * unit) ** 2)
