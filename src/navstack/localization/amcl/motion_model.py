"""Odometry motion models of Nav2's AMCL, sampled for every particle at once.

Both follow ``sample_motion_model_odometry`` (Thrun, Burgard & Fox, *Probabilistic
Robotics*, 2005, table 5.6) with Nav2's variants:

* :class:`DifferentialMotionModel` (``nav2_amcl::DifferentialMotionModel``): the motion
  between two odometry poses is ``rot1, trans, rot2``; each is perturbed by zero-mean
  Gaussian noise whose *variance* is ``alpha1 * rot^2 + alpha2 * trans^2`` (rotations) and
  ``alpha3 * trans^2 + alpha4 * (rot1^2 + rot2^2)`` (translation).  As in amcl, the
  rotations entering the noise are folded so that driving backwards counts like driving
  forwards (``min(|rot|, |pi - rot|)``), and ``rot1`` is taken as 0 when the robot moved
  less than 1 cm (in-place rotation: the bearing of a tiny translation is noise).
* :class:`OmniMotionModel` (``nav2_amcl::OmniMotionModel``): translation along the
  odometry bearing with standard deviation ``sqrt(alpha3 trans^2 + alpha4 rot^2)``, a
  sideways *strafe* ``sqrt(alpha4 rot^2 + alpha5 trans^2)`` (the ``alpha5`` term that only
  holonomic bases have) and a rotation ``sqrt(alpha1 rot^2 + alpha2 trans^2)``.

``delta`` is Nav2's odometry difference ``(x1 - x0, y1 - y0, angle_diff(yaw1, yaw0))`` in
the odom frame; ``odom_pose`` the new odometry pose.  Randomness comes only from the
``numpy.random.Generator`` passed in, so a seeded run is reproducible.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import normalize_angle
from navstack.localization.amcl.params import AmclParams

FloatArray = NDArray[np.float64]

IN_PLACE_THRESHOLD = 0.01
"""Translation [m] below which ``rot1`` is taken as 0 (amcl: in-place rotations)."""


def odometry_delta(odom_new: FloatArray, odom_old: FloatArray) -> FloatArray:
    """Nav2's ``delta``: ``(dx, dy, dyaw)`` between two odometry poses, yaw wrapped."""
    d = np.asarray(odom_new, np.float64) - np.asarray(odom_old, np.float64)
    return np.array([d[0], d[1], normalize_angle(float(d[2]))])


def _fold(angle: float) -> float:
    """``min(|angle|, |pi - angle|)`` wrapped: backwards motion counts as forwards."""
    return min(abs(normalize_angle(angle)), abs(normalize_angle(angle - math.pi)))


class MotionModel(Protocol):
    """Moves every particle by one sampled odometry motion."""

    def sample(self, poses: FloatArray, odom_pose: FloatArray, delta: FloatArray,
               rng: np.random.Generator) -> FloatArray:
        """New ``(N, 3)`` poses (yaw in (-pi, pi]) after the odometry motion ``delta``."""
        ...


class DifferentialMotionModel:
    """``sample_motion_model_odometry`` for a differential-drive base (amcl's noise)."""

    def __init__(self, alpha1: float, alpha2: float, alpha3: float, alpha4: float) -> None:
        self.alpha1, self.alpha2, self.alpha3, self.alpha4 = alpha1, alpha2, alpha3, alpha4

    def decompose(self, odom_pose: FloatArray, delta: FloatArray) -> tuple[float, float, float]:
        """``(rot1, trans, rot2)`` of the odometry motion (Probabilistic Robotics 5.4)."""
        dx, dy, dyaw = float(delta[0]), float(delta[1]), float(delta[2])
        old_yaw = float(odom_pose[2]) - dyaw
        trans = math.hypot(dx, dy)
        rot1 = 0.0 if trans < IN_PLACE_THRESHOLD else normalize_angle(math.atan2(dy, dx)
                                                                      - old_yaw)
        rot2 = normalize_angle(dyaw - rot1)
        return rot1, trans, rot2

    def standard_deviations(self, odom_pose: FloatArray, delta: FloatArray
                            ) -> tuple[float, float, float]:
        """Noise standard deviations of ``rot1, trans, rot2`` (amcl's formulas)."""
        rot1, trans, rot2 = self.decompose(odom_pose, delta)
        r1, r2 = _fold(rot1), _fold(rot2)
        a1, a2, a3, a4 = self.alpha1, self.alpha2, self.alpha3, self.alpha4
        return (math.sqrt(a1 * r1 * r1 + a2 * trans * trans),
                math.sqrt(a3 * trans * trans + a4 * r1 * r1 + a4 * r2 * r2),
                math.sqrt(a1 * r2 * r2 + a2 * trans * trans))

    def sample(self, poses: FloatArray, odom_pose: FloatArray, delta: FloatArray,
               rng: np.random.Generator) -> FloatArray:
        rot1, trans, rot2 = self.decompose(odom_pose, delta)
        s1, st, s2 = self.standard_deviations(odom_pose, delta)
        n = len(poses)
        noise = rng.standard_normal((3, n))
        rot1_hat = rot1 - s1 * noise[0]
        trans_hat = trans - st * noise[1]
        rot2_hat = rot2 - s2 * noise[2]
        heading = poses[:, 2] + rot1_hat
        out = np.empty_like(poses)
        out[:, 0] = poses[:, 0] + trans_hat * np.cos(heading)
        out[:, 1] = poses[:, 1] + trans_hat * np.sin(heading)
        out[:, 2] = normalize_angle(heading + rot2_hat)
        return out


class OmniMotionModel:
    """Nav2's omnidirectional odometry model (translation, strafe and rotation noise)."""

    def __init__(self, alpha1: float, alpha2: float, alpha3: float, alpha4: float,
                 alpha5: float) -> None:
        self.alpha1, self.alpha2, self.alpha3 = alpha1, alpha2, alpha3
        self.alpha4, self.alpha5 = alpha4, alpha5

    def standard_deviations(self, delta: FloatArray) -> tuple[float, float, float]:
        """Noise standard deviations of ``trans, rot, strafe`` (Nav2's formulas)."""
        trans = math.hypot(float(delta[0]), float(delta[1]))
        rot = float(delta[2])
        return (math.sqrt(self.alpha3 * trans * trans + self.alpha4 * rot * rot),
                math.sqrt(self.alpha1 * rot * rot + self.alpha2 * trans * trans),
                math.sqrt(self.alpha4 * rot * rot + self.alpha5 * trans * trans))

    def sample(self, poses: FloatArray, odom_pose: FloatArray, delta: FloatArray,
               rng: np.random.Generator) -> FloatArray:
        dx, dy, rot = float(delta[0]), float(delta[1]), float(delta[2])
        trans = math.hypot(dx, dy)
        old_yaw = float(odom_pose[2]) - rot
        bearing_odom = normalize_angle(math.atan2(dy, dx) - old_yaw)
        s_trans, s_rot, s_strafe = self.standard_deviations(delta)
        n = len(poses)
        noise = rng.standard_normal((3, n))
        trans_hat = trans + s_trans * noise[0]
        rot_hat = rot + s_rot * noise[1]
        strafe_hat = s_strafe * noise[2]
        bearing = poses[:, 2] + bearing_odom
        c, s = np.cos(bearing), np.sin(bearing)
        out = np.empty_like(poses)
        out[:, 0] = poses[:, 0] + trans_hat * c + strafe_hat * s
        out[:, 1] = poses[:, 1] + trans_hat * s - strafe_hat * c
        out[:, 2] = normalize_angle(poses[:, 2] + rot_hat)
        return out


def make_motion_model(params: AmclParams) -> DifferentialMotionModel | OmniMotionModel:
    """The motion model named by ``robot_model_type``."""
    p = params
    if p.omni:
        return OmniMotionModel(p.alpha1, p.alpha2, p.alpha3, p.alpha4, p.alpha5)
    return DifferentialMotionModel(p.alpha1, p.alpha2, p.alpha3, p.alpha4)
