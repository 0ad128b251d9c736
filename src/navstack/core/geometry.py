"""SE(2) geometry on plain floats and on numpy arrays.

Poses are ``(x, y, theta)`` in metres and radians, REP-103 axes (x forward, y left,
theta counter-clockwise).  Array functions accept shape ``(3,)`` or ``(N, 3)`` and are
vectorised; angles are always normalised to ``(-pi, pi]``.
"""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

TWO_PI = 2.0 * math.pi
MAX_COORDINATE = 1e8
"""Largest |coordinate| [m] a goal or waypoint may have: beyond any map frame (UTM
northings reach 1e7 m, the Earth's circumference is 4e7 m); 1e300 is a typo, not a goal."""
FloatArray = NDArray[np.float64]
AngleT = TypeVar("AngleT", float, FloatArray)


def normalize_angle(angle: AngleT) -> AngleT:
    """Wrap an angle (scalar or array) into ``(-pi, pi]``."""
    if isinstance(angle, np.ndarray):
        out = angle - TWO_PI * np.ceil((angle - math.pi) / TWO_PI)
        # rounding near the ends can land one ulp outside; fold back once
        out = np.where(out > math.pi, out - TWO_PI, out)
        return np.where(out <= -math.pi, out + TWO_PI, out)
    a = float(angle)
    if -math.pi < a <= math.pi:
        return a
    out = a - TWO_PI * math.ceil((a - math.pi) / TWO_PI)
    if out > math.pi:
        out -= TWO_PI
    elif out <= -math.pi:
        out += TWO_PI
    return out


def angle_diff(a: AngleT, b: AngleT) -> AngleT:
    """Shortest signed difference ``a - b`` in ``(-pi, pi]``."""
    return normalize_angle(a - b)


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion ``(x, y, z, w)`` of a rotation by ``yaw`` about +z."""
    half = 0.5 * yaw
    return (0.0, 0.0, math.sin(half), math.cos(half))


def quaternion_to_yaw(x: float, y: float, z: float, w: float) -> float:
    """Yaw (rotation about +z) of a quaternion ``(x, y, z, w)`` in ``(-pi, pi]``."""
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return math.pi if yaw == -math.pi else yaw


def rpy_to_quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Quaternion ``(x, y, z, w)`` from fixed-axis roll, pitch, yaw (ROS convention)."""
    cr, sr = math.cos(roll * 0.5), math.sin(roll * 0.5)
    cp, sp = math.cos(pitch * 0.5), math.sin(pitch * 0.5)
    cy, sy = math.cos(yaw * 0.5), math.sin(yaw * 0.5)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def quaternion_to_rpy(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """Roll, pitch, yaw of a quaternion ``(x, y, z, w)``."""
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = max(-1.0, min(1.0, 2.0 * (w * y - z * x)))
    pitch = math.asin(s)
    return roll, pitch, quaternion_to_yaw(x, y, z, w)


def _as_poses(p: ArrayLike) -> FloatArray:
    arr = np.asarray(p, dtype=np.float64)
    if arr.shape[-1] != 3:
        raise ValueError(f"SE(2) poses need a last axis of 3 (x, y, theta), got shape {arr.shape}")
    return arr


def se2_compose(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """``a ⊕ b``: pose ``b`` expressed in frame ``a``, returned in ``a``'s parent frame."""
    a_, b_ = _as_poses(a), _as_poses(b)
    c, s = np.cos(a_[..., 2]), np.sin(a_[..., 2])
    out = np.empty(np.broadcast_shapes(a_.shape, b_.shape))
    out[..., 0] = a_[..., 0] + c * b_[..., 0] - s * b_[..., 1]
    out[..., 1] = a_[..., 1] + s * b_[..., 0] + c * b_[..., 1]
    out[..., 2] = normalize_angle(np.asarray(a_[..., 2] + b_[..., 2]))
    return out


def se2_inverse(a: ArrayLike) -> FloatArray:
    """Inverse transform: ``se2_compose(a, se2_inverse(a)) == 0``."""
    a_ = _as_poses(a)
    c, s = np.cos(a_[..., 2]), np.sin(a_[..., 2])
    out = np.empty(a_.shape)
    out[..., 0] = -(c * a_[..., 0] + s * a_[..., 1])
    out[..., 1] = s * a_[..., 0] - c * a_[..., 1]
    out[..., 2] = normalize_angle(np.asarray(-a_[..., 2]))
    return out


def se2_between(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Relative pose ``a^-1 ⊕ b`` (``b`` seen from ``a``)."""
    return se2_compose(se2_inverse(a), b)


def se2_apply(pose: ArrayLike, points: ArrayLike) -> FloatArray:
    """Transform ``points`` (shape ``(N, 2)``) from the pose's frame into its parent."""
    p = _as_poses(pose)
    pts = np.asarray(points, dtype=np.float64)
    c, s = math.cos(float(p[2])), math.sin(float(p[2]))
    out = np.empty_like(pts)
    out[..., 0] = p[0] + c * pts[..., 0] - s * pts[..., 1]
    out[..., 1] = p[1] + s * pts[..., 0] + c * pts[..., 1]
    return out


def se2_interpolate(a: ArrayLike, b: ArrayLike, fraction: float | FloatArray) -> FloatArray:
    """Interpolate between poses: linear in translation, shortest arc in heading.

    ``fraction`` 0 gives ``a``, 1 gives ``b``; values outside [0, 1] extrapolate.
    """
    a_, b_ = _as_poses(a), _as_poses(b)
    f = np.asarray(fraction, dtype=np.float64)
    out = np.empty(np.broadcast_shapes(a_.shape, b_.shape, (*f.shape, 3)))
    out[..., 0] = a_[..., 0] + f * (b_[..., 0] - a_[..., 0])
    out[..., 1] = a_[..., 1] + f * (b_[..., 1] - a_[..., 1])
    dth = normalize_angle(np.asarray(b_[..., 2] - a_[..., 2]))
    out[..., 2] = normalize_angle(np.asarray(a_[..., 2] + f * dth))
    return out
