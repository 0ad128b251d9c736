"""3-D rotations: matrices, quaternions ``(x, y, z, w)`` and 4x4 rigid transforms.

Small helpers for code that works with full 3-D poses (camera and marker frames); planar
code uses :mod:`navstack.core.geometry`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Point, Pose, Quaternion, Transform, Vector3

FloatArray = NDArray[np.float64]


def matrix_to_quaternion(r: FloatArray) -> Quaternion:
    """Unit quaternion of a rotation matrix (Shepperd's method, ``w >= 0``)."""
    m = np.asarray(r, dtype=np.float64)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = (0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(max(1.0 + m[0, 0] - m[1, 1] - m[2, 2], 1e-300))
        q = ((m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s)
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(max(1.0 + m[1, 1] - m[0, 0] - m[2, 2], 1e-300))
        q = ((m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s)
    else:
        s = 2.0 * math.sqrt(max(1.0 + m[2, 2] - m[0, 0] - m[1, 1], 1e-300))
        q = ((m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s)
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    sign = 1.0 if w >= 0.0 else -1.0
    return Quaternion(sign * x / n, sign * y / n, sign * z / n, sign * w / n)


def quaternion_to_matrix(q: Quaternion) -> FloatArray:
    """Rotation matrix of a (normalised here) quaternion."""
    x, y, z, w = q.x, q.y, q.z, q.w
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def transform_to_matrix(t: Transform) -> FloatArray:
    """4x4 homogeneous matrix of a geometry_msgs/Transform."""
    out = np.eye(4)
    out[:3, :3] = quaternion_to_matrix(t.rotation)
    out[:3, 3] = (t.translation.x, t.translation.y, t.translation.z)
    return out


def matrix_to_transform(m: FloatArray) -> Transform:
    """geometry_msgs/Transform of a 4x4 rigid matrix."""
    return Transform(Vector3(float(m[0, 3]), float(m[1, 3]), float(m[2, 3])),
                     matrix_to_quaternion(m[:3, :3]))


def matrix_to_pose(m: FloatArray) -> Pose:
    """geometry_msgs/Pose of a 4x4 rigid matrix."""
    return Pose(Point(float(m[0, 3]), float(m[1, 3]), float(m[2, 3])),
                matrix_to_quaternion(m[:3, :3]))


def pose_to_matrix(p: Pose) -> FloatArray:
    """4x4 rigid matrix of a geometry_msgs/Pose."""
    out = np.eye(4)
    out[:3, :3] = quaternion_to_matrix(p.orientation)
    out[:3, 3] = (p.position.x, p.position.y, p.position.z)
    return out


def rotation_angle(a: FloatArray, b: FloatArray) -> float:
    """Angle [rad] of the rotation between matrices ``a`` and ``b`` (0 .. pi)."""
    c = 0.5 * (float(np.trace(np.asarray(a).T @ np.asarray(b))) - 1.0)
    return math.acos(min(1.0, max(-1.0, c)))


__all__ = ["matrix_to_pose", "matrix_to_quaternion", "matrix_to_transform", "pose_to_matrix",
           "quaternion_to_matrix", "rotation_angle", "transform_to_matrix"]
