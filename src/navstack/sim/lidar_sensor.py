"""Simulated planar lidar: turns true ranges into a noisy ``LaserScan``.

The geometry (casting ``beam_angles`` from the sensor pose into the world) is done by the
caller, e.g. ``navstack.sim.raycast.cast_rays``; this model only needs the true range of
each beam (``inf`` where the ray hits nothing) and applies the sensor's imperfections,
vectorised over beams (~20 us for 360 beams).

Range semantics follow sensor_msgs/LaserScan and REP-117:

- ``+inf``: no return within ``range_max`` (nothing hit, hit beyond ``range_max``, or a
  dropped beam -- a dark or specular surface that returned nothing);
- ``-inf``: an object closer than ``range_min``.  It is *not* reported as ``+inf``
  because consumers that clear free space along ``+inf`` rays (Nav2's obstacle layer
  with ``inf_is_valid``) would then erase an obstacle touching the robot;
- finite values always lie in ``[range_min, range_max]``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.core.errors import InvalidMessage
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import Header, LaserScan, Pose2D
from navstack.sim.robot import LidarParams, MountParams

FloatArray = NDArray[np.float64]
_EMPTY_F32 = np.zeros(0, dtype=np.float32)
_EMPTY_F32.setflags(write=False)


def beam_layout(angle_min: float, angle_max: float, beams: int) -> tuple[float, float]:
    """``(angle_increment, effective angle_max)`` for ``beams`` rays over the span.

    A full circle (span 2*pi) is divided into ``beams`` equal sectors so the first and
    last rays do not coincide; a partial span puts rays on both ends.
    """
    span = angle_max - angle_min
    full_circle = span >= 2.0 * math.pi - 1e-6
    inc = span / beams if full_circle else span / (beams - 1)
    return inc, angle_min + inc * (beams - 1)


class LidarModel:
    """Noise, bias, range clipping and dropout of a 2D lidar (see module docstring).

    Attributes used by the caller to cast rays: ``beam_angles`` (float64[n], radians
    relative to the sensor heading) and ``mount`` (sensor x, y, z, yaw in ``base_link``).
    All beams of a scan are taken at one instant (``time_increment`` 0): the simulator
    casts them from a single pose, so no motion distortion is modelled or advertised.
    """

    def __init__(self, params: LidarParams) -> None:
        self.params = params
        self.frame_id = params.frame_id
        self.rate_hz = params.rate_hz
        self.n_beams = params.beams
        self.range_min = params.range_min
        self.range_max = params.range_max
        self.angle_min = params.angle_min
        self.angle_increment, self.angle_max = beam_layout(params.angle_min, params.angle_max,
                                                           params.beams)
        self.beam_angles: FloatArray = self.angle_min + self.angle_increment * np.arange(
            self.n_beams, dtype=np.float64)
        self.beam_angles.setflags(write=False)
        self.mount: MountParams = params.mount
        self.scan_time = 1.0 / params.rate_hz

    def sensor_pose(self, robot_pose: Pose2D) -> Pose2D:
        """Pose of the sensor frame in the world given the ``base_link`` pose."""
        return robot_pose.compose(self.mount.pose2d)

    def world_beam_angles(self, robot_pose: Pose2D) -> FloatArray:
        """Beam directions in the world frame [rad] (float64[n])."""
        return np.asarray(normalize_angle(self.beam_angles + (robot_pose.theta
                                                              + self.mount.yaw)))

    def measure(self, ranges_true: ArrayLike, now: float,
                rng: np.random.Generator) -> LaserScan | None:
        """A scan stamped ``now`` from the true ranges (float64[n], ``inf`` = no hit).

        Returns ``None`` when the whole scan drops out (probability
        ``scan_dropout_prob``).  Raises ``InvalidMessage`` for a wrong length or NaN.
        """
        p = self.params
        r = np.asarray(ranges_true, dtype=np.float64)
        if r.shape != (self.n_beams,):
            raise InvalidMessage(f"lidar '{self.frame_id}' expects {self.n_beams} true ranges, "
                                 f"got shape {r.shape}")
        if math.isnan(r.sum()):
            raise InvalidMessage(f"lidar '{self.frame_id}': true ranges contain NaN or -inf; "
                                 "the ray caster must return a distance or +inf")
        if p.scan_dropout_prob > 0.0 and rng.random() < p.scan_dropout_prob:
            return None
        out = r + p.bias  # always a fresh array; inf stays inf
        if p.noise_std > 0.0 or p.noise_std_per_m > 0.0:
            std = p.noise_std + p.noise_std_per_m * np.where(np.isfinite(r), r, 0.0)
            out += std * rng.standard_normal(self.n_beams)
        out[out < self.range_min] = -np.inf
        out[out > self.range_max] = np.inf
        if p.dropout_prob > 0.0:
            out[rng.random(self.n_beams) < p.dropout_prob] = np.inf
        return LaserScan(Header(now, self.frame_id), self.angle_min, self.angle_max,
                         self.angle_increment, 0.0, self.scan_time, self.range_min,
                         self.range_max, out.astype(np.float32), _EMPTY_F32)
