"""Measurements behind the health checks, on plain arrays (no bus, no bag).

* :func:`rate_over` -- messages per second inside a union of time intervals;
* :func:`follow_stats` -- how many non-zero velocity commands the base followed (its
  measured twist has the command's sign and a fair share of its size a little later);
* :func:`progress_trip` -- replays Nav2's ``SimpleProgressChecker`` rule (move more than
  ``required_movement_radius`` within ``movement_time_allowance``) over odometry;
* :func:`tf_staleness` -- the oldest the newest sample of a TF edge ever was.

Arrays are sorted by time; times are seconds on the run's clock.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION

FloatArray = NDArray[np.float64]
Intervals = list[tuple[float, float]]


def inside(t: FloatArray, intervals: Intervals) -> NDArray[np.bool_]:
    """Mask of the times that lie in any ``[lo, hi]`` of ``intervals``."""
    mask = np.zeros(len(t), dtype=bool)
    for lo, hi in intervals:
        mask |= (t >= lo) & (t <= hi)
    return mask


def total_length(intervals: Intervals) -> float:
    return float(sum(hi - lo for lo, hi in intervals))


def rate_over(times: FloatArray, intervals: Intervals) -> float:
    """Messages per second inside ``intervals`` (0 for an empty span)."""
    span = total_length(intervals)
    return float(np.count_nonzero(inside(times, intervals))) / span if span > 0 else 0.0


def nonzero_commands(cmd: FloatArray, min_linear: float, min_angular: float
                     ) -> NDArray[np.bool_]:
    """Rows of ``cmd`` ``(t, vx, wz)`` that ask for motion."""
    return (np.abs(cmd[:, 1]) >= min_linear) | (np.abs(cmd[:, 2]) >= min_angular)


def follow_stats(cmd: FloatArray, odom: FloatArray, intervals: Intervals, *,
                 min_linear: float, min_angular: float, ratio: float,
                 lag: float) -> tuple[int, int]:
    """``(non-zero commands, followed commands)`` of ``cmd`` inside ``intervals``.

    ``cmd`` rows ``(t, vx, wz)``, ``odom`` rows ``(t, x, y, yaw, vx, wz)``.  A command is
    followed when the odometry twist ``lag`` seconds later (linear interpolation) has the
    same sign as a non-zero component and at least ``ratio`` of its magnitude.  Commands
    whose response time lies after the last odometry sample are not judged.
    """
    if len(cmd) == 0:
        return 0, 0
    keep = inside(cmd[:, 0], intervals) & nonzero_commands(cmd, min_linear, min_angular)
    if len(odom):
        keep &= cmd[:, 0] + lag <= odom[-1, 0]
    c = cmd[keep]
    if len(c) == 0 or len(odom) < 2:
        return len(c), 0
    t = c[:, 0] + lag
    vx = np.interp(t, odom[:, 0], odom[:, 4])
    wz = np.interp(t, odom[:, 0], odom[:, 5])
    lin = (np.abs(c[:, 1]) >= min_linear) & (vx * c[:, 1] > 0) & (
        np.abs(vx) >= ratio * np.abs(c[:, 1]))
    ang = (np.abs(c[:, 2]) >= min_angular) & (wz * c[:, 2] > 0) & (
        np.abs(wz) >= ratio * np.abs(c[:, 2]))
    return len(c), int(np.count_nonzero(lin | ang))


@numba.njit(cache=True)
def _progress_kernel(t: FloatArray, x: FloatArray, y: FloatArray, active: NDArray[np.bool_],
                     radius: float, allowance: float) -> tuple[float, float]:
    """First time the progress rule trips and the baseline time it measured from
    (``nan, nan`` if never).  The baseline restarts whenever ``active`` is false."""
    have = False
    bx = by = bt = 0.0
    for i in range(len(t)):
        if not active[i]:
            have = False
            continue
        if not have or math.hypot(x[i] - bx, y[i] - by) > radius:
            bx, by, bt, have = x[i], y[i], t[i], True
        elif t[i] - bt > allowance:
            return t[i], bt
    return math.nan, math.nan


def progress_trip(odom: FloatArray, intervals: Intervals, radius: float,
                  allowance: float) -> tuple[float, float] | None:
    """``(trip time, baseline time)`` of the first progress failure inside the goal
    ``intervals``, or ``None``; samples between goals restart the baseline (Nav2 resets
    the checker on every new goal)."""
    if len(odom) == 0 or not intervals:
        return None
    t = np.ascontiguousarray(odom[:, 0])
    trip, base = _progress_kernel(t, np.ascontiguousarray(odom[:, 1]),
                                  np.ascontiguousarray(odom[:, 2]), inside(t, intervals),
                                  float(radius), float(allowance))
    return None if math.isnan(trip) else (float(trip), float(base))


def tf_staleness(samples: FloatArray, start: float, now: float) -> tuple[float, float]:
    """``(worst age, time of it)`` of the newest sample of one edge over ``[start, now]``.

    ``samples`` rows ``(publish time, stamp)``.  Just before each sample is published,
    and at ``now``, the newest stamp received so far is compared with the clock; a
    future-dated edge (``map -> odom`` with ``transform_tolerance``) has a negative age.
    With no sample before ``now`` the age is infinite.
    """
    pub, stamp = samples[:, 0], samples[:, 1]
    seen = pub <= now
    pub, stamp = pub[seen], stamp[seen]
    if len(pub) == 0:
        return math.inf, now
    newest = np.maximum.accumulate(stamp)
    check_t = np.append(pub[1:], now)
    age = check_t - newest
    age[check_t < start] = -math.inf
    i = int(np.argmax(age))
    return float(age[i]), float(check_t[i])


def blocked_fraction(data: NDArray[np.uint8]) -> tuple[int, float]:
    """``(known cells, share of them that are lethal or inscribed)`` of a costmap grid."""
    known = data != NO_INFORMATION
    n = int(np.count_nonzero(known))
    if n == 0:
        return 0, 0.0
    blocked = np.count_nonzero(known & (data >= INSCRIBED_INFLATED_OBSTACLE))
    return n, float(blocked) / n


def pose_stds(covariance: NDArray[np.float64]) -> tuple[float, float, float]:
    """Standard deviations of x [m], y [m] and yaw [rad] of a row-major 6x6 pose
    covariance (ROS ``PoseWithCovariance.covariance``)."""
    c = np.asarray(covariance, dtype=np.float64).reshape(6, 6)
    return (math.sqrt(max(float(c[0, 0]), 0.0)), math.sqrt(max(float(c[1, 1]), 0.0)),
            math.sqrt(max(float(c[5, 5]), 0.0)))
