"""Motion-quality metrics of issue 18 (pure: numpy in, numbers out).

* :func:`self_crossings` -- how often a driven leg crosses itself (a loop instead of a turn
  in place): proper intersections between non-adjacent segments of the trajectory
  resampled every ``step`` metres of arc length (so standing still or turning in place
  adds no segments);
* :func:`length_ratio` -- executed length of a leg over the length of its first plan;
* :func:`curvature_sign_changes` -- along a plan resampled every 0.1 m, the signed
  curvature ``k_i = wrap(h_i - h_(i-1)) / step`` (``h`` the segment headings); of the
  samples with ``|k| > threshold`` (0.2 1/m), how often the sign flips between
  consecutive ones; :func:`sign_changes_per_10m` scales it by ``10 / max(L, 10 m)``
  (a plan shorter than 10 m may change sign at most twice in all).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["curvature_sign_changes", "length_ratio", "path_length", "resample",
           "self_crossings", "sign_changes_per_10m"]

FloatArray = NDArray[np.float64]


def path_length(xy: FloatArray) -> float:
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0


def resample(xy: FloatArray, step: float) -> FloatArray:
    """Points every ``step`` metres of arc length along the polyline (ends included)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 2:
        return xy.copy()
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
    if s[-1] <= 0.0:
        return xy[:1].copy()
    at = np.arange(0.0, s[-1], step)
    if s[-1] - at[-1] > 1e-9:
        at = np.append(at, s[-1])
    return np.column_stack((np.interp(at, s, xy[:, 0]), np.interp(at, s, xy[:, 1])))


def self_crossings(xy: FloatArray, step: float = 0.05) -> int:
    """Proper crossings between non-adjacent segments of the resampled polyline."""
    p = resample(xy, step)
    if len(p) < 4:
        return 0
    a, b = p[:-1], p[1:]
    n = len(a)
    count = 0
    for i in range(n - 2):  # segments i and j > i + 1, vectorised over j
        j = np.arange(i + 2, n)
        c, d = a[j], b[j]
        d1 = _cross(a[i], b[i], c)
        d2 = _cross(a[i], b[i], d)
        d3 = _cross_rows(c, d, a[i])
        d4 = _cross_rows(c, d, b[i])
        count += int(np.count_nonzero((d1 * d2 < 0.0) & (d3 * d4 < 0.0)))
    return count


def _cross(o: FloatArray, e: FloatArray, pts: FloatArray) -> FloatArray:
    return np.asarray((e[0] - o[0]) * (pts[:, 1] - o[1]) - (e[1] - o[1]) * (pts[:, 0] - o[0]))


def _cross_rows(o: FloatArray, e: FloatArray, pt: FloatArray) -> FloatArray:
    return np.asarray((e[:, 0] - o[:, 0]) * (pt[1] - o[:, 1])
                      - (e[:, 1] - o[:, 1]) * (pt[0] - o[:, 0]))


def length_ratio(executed_xy: FloatArray, plan_xy: FloatArray) -> float:
    """Executed length over planned length (``nan`` for an empty plan)."""
    planned = path_length(plan_xy)
    return path_length(executed_xy) / planned if planned > 0.0 else math.nan


def curvature_sign_changes(xy: FloatArray, step: float = 0.1,
                           threshold: float = 0.2) -> int:
    """Sign flips of the curvature among the samples with ``|k| > threshold`` [1/m]."""
    p = resample(xy, step)
    if len(p) < 3:
        return 0
    d = np.diff(p, axis=0)
    seg = np.hypot(d[:, 0], d[:, 1])
    keep = seg > 1e-9
    h = np.arctan2(d[keep, 1], d[keep, 0])
    if len(h) < 2:
        return 0
    dh = np.angle(np.exp(1j * np.diff(h)))
    k = dh / step
    strong = k[np.abs(k) > threshold]
    if len(strong) < 2:
        return 0
    return int(np.count_nonzero(np.sign(strong[1:]) != np.sign(strong[:-1])))


def sign_changes_per_10m(xy: FloatArray, step: float = 0.1, threshold: float = 0.2) -> float:
    """:func:`curvature_sign_changes` per 10 m of plan (over at least 10 m)."""
    return curvature_sign_changes(xy, step, threshold) * 10.0 / max(path_length(xy), 10.0)
