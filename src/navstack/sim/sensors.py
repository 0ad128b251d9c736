"""Simulated proprioceptive sensors and the sampling schedule shared by all sensors.

Pure models: every method takes the true state, the time ``now`` and the
``numpy.random.Generator`` explicitly, so a run is reproducible from its seed.  The
lidar model lives in :mod:`navstack.sim.lidar_sensor` and is re-exported here.

- :class:`WheelOdometryModel` -- dead reckoning from noisy, mis-calibrated wheel velocities
  (drifts from the truth like real odometry), nav_msgs/Odometry in ``odom``.
- :class:`ImuModel` -- gyro, accelerometer (with gravity) and orientation, sensor_msgs/Imu.
- :class:`GroundTruthModel` -- the exact pose and twist in ``map``, for evaluation.
- :class:`SensorSchedule` -- phase-stable "is a sample due" clock (sample k at start + k/rate).
"""

from __future__ import annotations

import math

import numpy as np

from navstack.core.errors import InvalidMessage, SimulationError
from navstack.core.geometry import angle_diff
from navstack.core.msgs import (
    Header,
    Imu,
    Odometry,
    Pose2D,
    PoseWithCovariance,
    Quaternion,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from navstack.sim.kinematics import RobotState, integrate_pose
from navstack.sim.lidar_sensor import LidarModel, beam_layout
from navstack.sim.robot import GroundTruthParams, ImuParams, OdometryParams

__all__ = [
    "GRAVITY", "GroundTruthModel", "ImuModel", "LidarModel", "SensorSchedule",
    "WheelOdometryModel", "beam_layout",
]

GRAVITY = 9.80665
"""Standard gravity [m/s^2]; an accelerometer at rest reads +GRAVITY on its z axis."""
UNOBSERVED_VARIANCE = 1e6
"""Variance put on z, roll and pitch of planar odometry (as diff_drive_controller configs do)."""
MIN_VARIANCE = 1e-9
"""Floor on reported variances so an ideal sensor never claims zero uncertainty."""


class SensorSchedule:
    """Decides when a periodic sensor samples: sample ``k`` is due at ``start + k / rate_hz``.

    Times are computed from the index, never by adding periods, so the phase does not
    drift however long the run.  If the caller skips past several sample times (a long
    step), only one sample is reported and the schedule resynchronises to the grid.
    """

    TOLERANCE = 1e-6
    """Fraction of a period by which ``now`` may fall short of a sample time (float noise)."""

    def __init__(self, rate_hz: float, start: float = 0.0) -> None:
        if not math.isfinite(rate_hz) or rate_hz <= 0.0:
            raise SimulationError(f"sensor rate_hz must be finite and > 0, got {rate_hz}")
        self.rate_hz = rate_hz
        self.period = 1.0 / rate_hz
        self.start = start
        self._next = 0

    def sample_time(self, k: int) -> float:
        """Time of sample ``k`` [s]."""
        return self.start + k / self.rate_hz

    @property
    def next_time(self) -> float:
        """Time of the next sample not yet reported [s]."""
        return self.sample_time(self._next)

    def due(self, now: float) -> bool:
        """True (and consume the sample) if a sample time in ``(last, now]`` has arrived."""
        k = math.floor((now - self.start) * self.rate_hz + self.TOLERANCE)
        if k < self._next:
            return False
        self._next = k + 1
        return True

    def reset(self, start: float = 0.0) -> None:
        self.start = start
        self._next = 0


def _diag6(values: tuple[float, float, float, float, float, float]) -> np.ndarray:
    return np.diag(np.maximum(np.asarray(values, dtype=np.float64), MIN_VARIANCE))


class WheelOdometryModel:
    """Wheel odometry that integrates noisy, mis-scaled body velocities into its own pose.

    Call :meth:`integrate` every simulation step (like encoders counting continuously) and
    :meth:`message` when the schedule says a sample is due, or :meth:`measure` to do both.
    Per step of length ``dt`` the measured velocities are
    ``v_m = (1 + linear_scale_error) * v + n_v``, ``w_m = (1 + angular_scale_error) * w
    + n_w``, with white noise scaled by ``sqrt(period / dt)`` so that the velocity
    averaged over one period ``1 / rate_hz`` has exactly the configured std whatever the
    simulation step.  With probability ``slip_prob`` per period the wheels slip and the
    step's motion is not counted.  The published twist is the mean measured velocity
    since the previous message.

    Covariance: the twist diagonal is the configured noise variance; the pose covariance
    is propagated from the white noise along the odometry's own trajectory (EKF-style,
    growing without bound as dead reckoning does).  The scale error is systematic and,
    as for a real uncalibrated robot, unknown to the odometry, so not in the covariance.
    """

    def __init__(self, params: OdometryParams, holonomic: bool = False,
                 initial_pose: Pose2D | None = None) -> None:
        self.params = params
        self.rate_hz = params.rate_hz
        self.holonomic = holonomic
        self._period = 1.0 / params.rate_hz
        # constant parts of the covariances, built once (message() runs at 50 Hz)
        self._pose_cov_template = _diag6((0.0, 0.0, UNOBSERVED_VARIANCE, UNOBSERVED_VARIANCE,
                                          UNOBSERVED_VARIANCE, 0.0))
        sv2 = params.linear_velocity_noise_std ** 2
        self._twist_cov = _diag6((sv2, sv2, UNOBSERVED_VARIANCE, UNOBSERVED_VARIANCE,
                                  UNOBSERVED_VARIANCE, params.angular_velocity_noise_std ** 2))
        self.reset(initial_pose or Pose2D())

    def reset(self, pose: Pose2D | None = None) -> None:
        """Restart dead reckoning at ``pose`` (default the odom origin) with zero covariance."""
        pose = pose or Pose2D()
        self._x, self._y, self._yaw = pose.x, pose.y, pose.theta
        self._P = [0.0] * 6  # xx, xy, xt, yy, yt, tt
        self._win_t = 0.0
        self._win = [0.0, 0.0, 0.0]
        self._twist = (0.0, 0.0, 0.0)

    @property
    def pose(self) -> Pose2D:
        """Current dead-reckoned pose of ``base_link`` in ``odom``."""
        return Pose2D(self._x, self._y, self._yaw)

    def integrate(self, true_state: RobotState, dt: float, rng: np.random.Generator) -> None:
        """Advance the dead reckoning by ``dt`` with the true body velocity of the step."""
        if not math.isfinite(dt) or dt < 0.0:
            raise SimulationError(f"odometry dt must be finite and >= 0, got {dt}")
        if dt == 0.0:
            return
        if not true_state.is_finite():
            raise InvalidMessage(f"odometry got a non-finite true state {true_state}")
        p = self.params
        ratio = self._period / dt
        if p.slip_prob > 0.0 and rng.random() < 1.0 - (1.0 - p.slip_prob) ** (1.0 / ratio):
            vx = vy = wz = 0.0
        else:
            vx = (1.0 + p.linear_scale_error) * true_state.vx
            vy = (1.0 + p.linear_scale_error) * true_state.vy if self.holonomic else 0.0
            wz = (1.0 + p.angular_scale_error) * true_state.wz
            sub = math.sqrt(ratio)
            if p.linear_velocity_noise_std > 0.0:
                vx += p.linear_velocity_noise_std * sub * rng.standard_normal()
                if self.holonomic:
                    vy += p.linear_velocity_noise_std * sub * rng.standard_normal()
            if p.angular_velocity_noise_std > 0.0:
                wz += p.angular_velocity_noise_std * sub * rng.standard_normal()
        x0, y0, yaw0 = self._x, self._y, self._yaw
        self._x, self._y, self._yaw = integrate_pose(x0, y0, yaw0, vx, vy, wz, dt)
        self._propagate_covariance(self._x - x0, self._y - y0, yaw0 + 0.5 * wz * dt, dt)
        self._win_t += dt
        self._win[0] += vx * dt
        self._win[1] += vy * dt
        self._win[2] += wz * dt

    def _propagate_covariance(self, dx: float, dy: float, heading: float, dt: float) -> None:
        """``P <- F P F^T + G Q G^T`` for the planar motion model (scalar form, 3x3)."""
        a, b, c, d, e, f = self._P
        p = self.params
        qx = p.linear_velocity_noise_std ** 2 * self._period * dt
        qy = qx if self.holonomic else 0.0
        qt = p.angular_velocity_noise_std ** 2 * self._period * dt
        cs, sn = math.cos(heading), math.sin(heading)
        self._P = [
            a - 2.0 * dy * c + dy * dy * f + cs * cs * qx + sn * sn * qy,
            b + dx * c - dy * e - dx * dy * f + cs * sn * (qx - qy),
            c - dy * f,
            d + 2.0 * dx * e + dx * dx * f + sn * sn * qx + cs * cs * qy,
            e + dx * f,
            f + qt,
        ]

    def message(self, now: float) -> Odometry:
        """The odometry message at ``now``; starts a new twist-averaging window."""
        if self._win_t > 0.0:
            t = self._win_t
            self._twist = (self._win[0] / t, self._win[1] / t, self._win[2] / t)
            self._win_t = 0.0
            self._win = [0.0, 0.0, 0.0]
        p = self.params
        a, b, c, d, e, f = self._P
        pose_cov = self._pose_cov_template.copy()
        pose_cov[0, 0], pose_cov[1, 1], pose_cov[5, 5] = (max(a, MIN_VARIANCE),
                                                          max(d, MIN_VARIANCE),
                                                          max(f, MIN_VARIANCE))
        pose_cov[0, 1] = pose_cov[1, 0] = b
        pose_cov[0, 5] = pose_cov[5, 0] = c
        pose_cov[1, 5] = pose_cov[5, 1] = e
        twist_cov = self._twist_cov.copy()
        vx, vy, wz = self._twist
        return Odometry(Header(now, p.frame_id), p.child_frame_id,
                        PoseWithCovariance(self.pose.to_pose(), pose_cov),
                        TwistWithCovariance(Twist.planar(vx, vy, wz), twist_cov))

    def measure(self, true_state: RobotState, dt: float, now: float,
                rng: np.random.Generator) -> Odometry:
        """:meth:`integrate` over ``dt`` then :meth:`message` at ``now``."""
        self.integrate(true_state, dt, rng)
        return self.message(now)


class ImuModel:
    """A planar-motion IMU mounted at ``mount`` (x, y, z, yaw) on ``base_link``.

    - orientation: yaw of the IMU frame in the world, ``yaw + mount.yaw`` plus noise;
    - angular velocity: the body rate (the same in any frame rotated about z) plus
      ``gyro_bias`` and white noise;
    - linear acceleration: the acceleration of the mount point, from the change of the
      world-frame velocity over ``dt`` (expressed at the mid-interval heading, which is
      exact for the centripetal term of a constant turn) plus the lever-arm terms
      ``alpha x r + w x (w x r)``, rotated into the IMU frame, with ``+GRAVITY`` on z as
      a real accelerometer reports, plus ``accel_bias`` and white noise.
    """

    def __init__(self, params: ImuParams) -> None:
        self.params = params
        self.rate_hz = params.rate_hz
        self.frame_id = params.frame_id
        p = params
        self._orient_cov = np.diag([max(p.orientation_noise_std ** 2, MIN_VARIANCE)] * 3)
        self._gyro_cov = np.diag([max(p.gyro_noise_std ** 2, MIN_VARIANCE)] * 3)
        self._accel_cov = np.diag([max(p.accel_noise_std ** 2, MIN_VARIANCE)] * 3)
        self._noisy = (p.orientation_noise_std > 0.0 or p.gyro_noise_std > 0.0
                       or p.accel_noise_std > 0.0)

    def measure(self, true_state: RobotState, prev_state: RobotState | None, dt: float,
                now: float, rng: np.random.Generator) -> Imu | None:
        """An IMU sample at ``now``; ``prev_state`` is the true state ``dt`` seconds earlier
        (``None`` on the first sample: zero acceleration).  ``None`` on dropout."""
        p = self.params
        if not true_state.is_finite() or (prev_state is not None
                                          and not prev_state.is_finite()):
            raise InvalidMessage(f"imu '{self.frame_id}' got a non-finite true state")
        if p.dropout_prob > 0.0 and rng.random() < p.dropout_prob:
            return None
        s = true_state
        ax = ay = alpha = 0.0
        if prev_state is not None and dt > 0.0:
            q = prev_state
            c1, s1, c0, s0 = math.cos(s.yaw), math.sin(s.yaw), math.cos(q.yaw), math.sin(q.yaw)
            awx = (c1 * s.vx - s1 * s.vy - (c0 * q.vx - s0 * q.vy)) / dt
            awy = (s1 * s.vx + c1 * s.vy - (s0 * q.vx + c0 * q.vy)) / dt
            mid = q.yaw + 0.5 * angle_diff(s.yaw, q.yaw)
            cm, sm = math.cos(mid), math.sin(mid)
            ax, ay = cm * awx + sm * awy, -sm * awx + cm * awy
            alpha = (s.wz - q.wz) / dt
        m = p.mount
        w2 = s.wz * s.wz
        ax += -alpha * m.y - w2 * m.x
        ay += alpha * m.x - w2 * m.y
        cy, sy = math.cos(m.yaw), math.sin(m.yaw)
        ax, ay = cy * ax + sy * ay, -sy * ax + cy * ay
        n = rng.standard_normal(7) if self._noisy else np.zeros(7)
        gb, ab = p.gyro_bias, p.accel_bias
        yaw = s.yaw + m.yaw + p.orientation_noise_std * float(n[0])
        sg, sa = p.gyro_noise_std, p.accel_noise_std
        return Imu(
            Header(now, self.frame_id),
            Quaternion.from_yaw(yaw),
            self._orient_cov.copy(),
            Vector3(gb[0] + sg * float(n[1]), gb[1] + sg * float(n[2]),
                    s.wz + gb[2] + sg * float(n[3])),
            self._gyro_cov.copy(),
            Vector3(ax + ab[0] + sa * float(n[4]), ay + ab[1] + sa * float(n[5]),
                    GRAVITY + ab[2] + sa * float(n[6])),
            self._accel_cov.copy(),
        )


class GroundTruthModel:
    """The exact pose (in ``frame_id``, default ``map``) and body twist of the robot."""

    def __init__(self, params: GroundTruthParams | None = None) -> None:
        self.params = params or GroundTruthParams()
        self.rate_hz = self.params.rate_hz

    def measure(self, true_state: RobotState, now: float) -> Odometry:
        p = self.params
        s = true_state
        return Odometry(Header(now, p.frame_id), p.child_frame_id,
                        PoseWithCovariance(Pose2D(s.x, s.y, s.yaw).to_pose(), np.zeros((6, 6))),
                        TwistWithCovariance(Twist.planar(s.vx, s.vy, s.wz), np.zeros((6, 6))))
