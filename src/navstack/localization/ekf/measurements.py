"""From sensor messages to filter measurements, as robot_localization's ``RosFilter``.

``MeasurementBuilder`` turns nav_msgs/Odometry, sensor_msgs/Imu,
PoseWithCovarianceStamped and TwistWithCovarianceStamped into :class:`Measurement`
objects in the filter's frames (``preparePose`` / ``prepareTwist`` /
``prepareAcceleration`` of robot_localization):

* poses are transformed into ``world_frame``; twists and accelerations into
  ``base_link_frame`` (rotation plus the lever-arm terms ``r x w`` and
  ``r x alpha - (r x w) x w``); covariances and update vectors are rotated with them;
* IMU orientation is the world attitude of the IMU; the mounting roll/pitch/yaw are
  removed and roll/pitch swapped by the mounting yaw, as upstream;
* ``_differential``: consecutive poses become a velocity ``(prev^-1 cur) / dt`` with
  covariance ``(cov_prev + cov_cur) dt`` (upstream's choice);
* ``_relative``: the first pose becomes the origin;
* ``_remove_gravitational_acceleration``: gravity, expressed in ``base_link`` through the
  IMU's attitude and mounting (or the state's attitude when the IMU gives none), is
  subtracted from the accelerometer (upstream subtracts it in the IMU frame after
  rotating the data to ``base_link``; the two agree for an IMU mounted level);
* ``two_d_mode`` drops z, roll, pitch and their rates from every update vector.

Anything unusable raises :class:`MeasurementRejected` with the reason: non-finite
numbers, a stamp older than the topic's previous message, a missing transform.
``SensorActivity`` keeps the set of sensors heard within ``sensor_timeout``.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import InvalidMessage
from navstack.core.geometry import normalize_angle, quaternion_to_rpy, rpy_to_quaternion
from navstack.core.msgs import (
    Imu,
    Odometry,
    Pose,
    PoseWithCovarianceStamped,
    TwistWithCovarianceStamped,
)
from navstack.core.tf import IDENTITY, Tf, tf_inverse, tf_mul
from navstack.localization.ekf.ekf import Measurement
from navstack.localization.ekf.model import STATE_SIZE, TWO_D_INDICES, VROLL
from navstack.localization.ekf.params import EkfParams, SensorParams

__all__ = ["MeasurementBuilder", "MeasurementRejected", "SensorActivity", "TransformLookup",
           "quaternion_matrix"]

TransformLookup = Callable[[str, str, float], Tf | None]
"""``lookup(target, source, stamp)``: the transform taking ``source`` data into
``target``, or ``None`` when it is unavailable."""

Vec3 = NDArray[np.float64]


class MeasurementRejected(InvalidMessage):
    """A message could not become a measurement; ``str(err)`` says why, ``category`` is
    one of ``REJECTION_CATEGORIES`` (``non-finite``, ``out-of-order``, ``no-transform``)."""

    def __init__(self, message: str, category: str) -> None:
        super().__init__(message)
        self.category = category


def quaternion_matrix(qx: float, qy: float, qz: float, qw: float) -> NDArray[np.float64]:
    """Rotation matrix (3, 3) of a unit quaternion."""
    return np.array([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]])


def _rot(t: Tf) -> NDArray[np.float64]:
    return quaternion_matrix(t[3], t[4], t[5], t[6])


def _rpy(t: Tf) -> tuple[float, float, float]:
    return quaternion_to_rpy(t[3], t[4], t[5], t[6])


def _rot6(r: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.zeros((6, 6))
    out[:3, :3] = r
    out[3:, 3:] = r
    return out


def _mask(update: NDArray[np.bool_], start: int, r: NDArray[np.float64]) -> None:
    """Rotate the 3 update flags at ``start`` like the data (robot_localization's mask
    matrices): a variable is measured if a measured one rotates into it."""
    rotated = r @ np.diag(update[start:start + 3].astype(np.float64))
    update[start:start + 3] = np.linalg.norm(rotated, axis=1) >= 1e-6


def _finite(sensor: str, **values: object) -> None:
    for name, value in values.items():
        if not np.isfinite(np.asarray(value, dtype=np.float64)).all():
            raise MeasurementRejected(f"{sensor}: non-finite value in {name}", "non-finite")


def _pose_tf(pose: Pose) -> Tf:
    p, q = pose.position, pose.orientation
    n = math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w)
    if n == 0.0:  # robot_localization: an all-zero quaternion means "no orientation"
        return (p.x, p.y, p.z, 0.0, 0.0, 0.0, 1.0)
    return (p.x, p.y, p.z, q.x / n, q.y / n, q.z / n, q.w / n)


class SensorActivity:
    """Which sensors were heard within ``timeout`` seconds.

    A sensor joins the active set with its first message, is dropped (``timeouts``
    counted) when silent for longer than ``timeout`` and re-admitted (``readmissions``
    counted) when it speaks again."""

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.last_heard: dict[str, float] = {}
        self.active: set[str] = set()
        self.timeouts: Counter[str] = Counter()
        self.readmissions: Counter[str] = Counter()

    def heard(self, sensor: str, now: float) -> bool:
        """Record a message; returns True when this re-admits a timed-out sensor."""
        returning = sensor in self.last_heard and sensor not in self.active
        self.last_heard[sensor] = now
        self.active.add(sensor)
        if returning:
            self.readmissions[sensor] += 1
        return returning

    def update(self, now: float) -> list[str]:
        """Drop the sensors silent for longer than ``timeout``; returns them."""
        dropped = sorted(s for s in self.active if now - self.last_heard[s] > self.timeout)
        for s in dropped:
            self.active.discard(s)
            self.timeouts[s] += 1
        return dropped


class MeasurementBuilder:
    """Per-sensor preprocessing state (previous poses, origins, stamps) and conversion."""

    def __init__(self, params: EkfParams, lookup: TransformLookup) -> None:
        self.params = params
        self.lookup = lookup
        self._last_stamp: dict[str, float] = {}
        self._previous: dict[str, tuple[Tf, NDArray[np.float64]]] = {}
        self._initial: dict[str, Tf] = {}
        self._two_d = np.array(TWO_D_INDICES, dtype=np.int64)

    def reset(self) -> None:
        self._last_stamp.clear()
        self._previous.clear()
        self._initial.clear()

    # --- messages ------------------------------------------------------------------------
    def odometry(self, s: SensorParams, msg: Odometry, state: NDArray[np.float64]
                 ) -> list[Measurement]:
        """Pose part into ``world_frame``, twist part into ``base_link_frame``."""
        u = s.update_vector
        out: list[Measurement] = []
        if u[:6].any():
            _finite(s.name, **{"pose.pose": _pose_tf(msg.pose.pose),
                               "pose.covariance": msg.pose.covariance})
        if u[6:12].any():
            tw = msg.twist.twist
            _finite(s.name, **{"twist.twist": (tw.linear.x, tw.linear.y, tw.linear.z,
                                               tw.angular.x, tw.angular.y, tw.angular.z),
                               "twist.covariance": msg.twist.covariance})
        if u[:6].any():
            source = (msg.child_frame_id or self.params.base_link_frame
                      if s.pose_use_child_frame else self.params.base_link_frame)
            out += self._pose(s, f"{s.name}_pose", msg.header.stamp, msg.header.frame_id,
                              _pose_tf(msg.pose.pose), msg.pose.covariance, self.params.world,
                              source, False, _only(u, 0, 6), s.pose_rejection_threshold, state)
        if u[6:12].any():
            tw = msg.twist.twist
            out += self._twist(s, f"{s.name}_twist", msg.header.stamp, msg.child_frame_id,
                               np.array([tw.linear.x, tw.linear.y, tw.linear.z]),
                               np.array([tw.angular.x, tw.angular.y, tw.angular.z]),
                               msg.twist.covariance, _only(u, 6, 12),
                               s.twist_rejection_threshold, state)
        return out

    def pose(self, s: SensorParams, msg: PoseWithCovarianceStamped,
             state: NDArray[np.float64]) -> list[Measurement]:
        """geometry_msgs/PoseWithCovarianceStamped into ``world_frame``."""
        tf = _pose_tf(msg.pose.pose)
        _finite(s.name, **{"pose.pose": tf, "pose.covariance": msg.pose.covariance})
        return self._pose(s, s.name, msg.header.stamp, msg.header.frame_id, tf,
                          msg.pose.covariance, self.params.world, self.params.base_link_frame,
                          False, _only(s.update_vector, 0, 6), s.pose_rejection_threshold,
                          state)

    def twist(self, s: SensorParams, msg: TwistWithCovarianceStamped,
              state: NDArray[np.float64]) -> list[Measurement]:
        """geometry_msgs/TwistWithCovarianceStamped into ``base_link_frame``."""
        tw = msg.twist.twist
        lin = np.array([tw.linear.x, tw.linear.y, tw.linear.z])
        ang = np.array([tw.angular.x, tw.angular.y, tw.angular.z])
        _finite(s.name, **{"twist.twist": np.concatenate((lin, ang)),
                           "twist.covariance": msg.twist.covariance})
        return self._twist(s, s.name, msg.header.stamp, msg.header.frame_id, lin, ang,
                           msg.twist.covariance, _only(s.update_vector, 6, 12),
                           s.twist_rejection_threshold, state)

    def imu(self, s: SensorParams, msg: Imu, state: NDArray[np.float64],
            angular_acceleration: Vec3) -> list[Measurement]:
        """Orientation (as a pose), angular velocity (as a twist) and linear acceleration;
        a part whose covariance[0, 0] is -1 is absent (sensor_msgs/Imu convention)."""
        u = s.update_vector
        has_orientation = abs(float(msg.orientation_covariance[0, 0]) + 1.0) >= 1e-9
        has_rate = abs(float(msg.angular_velocity_covariance[0, 0]) + 1.0) >= 1e-9
        has_accel = abs(float(msg.linear_acceleration_covariance[0, 0]) + 1.0) >= 1e-9
        q, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
        checks: dict[str, object] = {}
        if (u[3:6].any() and has_orientation) or (u[12:15].any() and has_accel):
            checks.update(orientation=(q.x, q.y, q.z, q.w),
                          orientation_covariance=msg.orientation_covariance)
        if u[9:12].any() and has_rate:
            checks.update(angular_velocity=(w.x, w.y, w.z),
                          angular_velocity_covariance=msg.angular_velocity_covariance)
        if u[12:15].any() and has_accel:
            checks.update(linear_acceleration=(a.x, a.y, a.z),
                          linear_acceleration_covariance=msg.linear_acceleration_covariance)
        _finite(s.name, **checks)
        base = self.params.base_link_frame
        out: list[Measurement] = []
        if u[3:6].any() and has_orientation:
            cov = np.zeros((6, 6))
            cov[3:, 3:] = msg.orientation_covariance
            tf = _pose_tf(Pose(orientation=q))
            out += self._pose(s, f"{s.name}_pose", msg.header.stamp, msg.header.frame_id, tf,
                              cov, base, base, True, _only(u, 3, 6),
                              s.pose_rejection_threshold, state)
        if u[9:12].any() and has_rate:
            cov = np.zeros((6, 6))
            cov[3:, 3:] = msg.angular_velocity_covariance
            out += self._twist(s, f"{s.name}_twist", msg.header.stamp, msg.header.frame_id,
                               np.zeros(3), np.array([w.x, w.y, w.z]), cov, _only(u, 9, 12),
                               s.twist_rejection_threshold, state)
        if u[12:15].any() and has_accel:
            out += self._acceleration(s, msg, has_orientation, _only(u, 12, 15), state,
                                      angular_acceleration)
        return out

    # --- robot_localization's prepare* --------------------------------------------------
    def _stamp_ok(self, s: SensorParams, topic: str, stamp: float) -> float | None:
        """Previous stamp of ``topic``; rejects a message older than it."""
        last = self._last_stamp.get(topic)
        if last is not None and stamp < last:
            raise MeasurementRejected(f"{s.name}: {topic} stamp {stamp:.6f} s is before the "
                                      f"previous message's ({last:.6f} s)", "out-of-order")
        self._last_stamp[topic] = stamp
        return last

    def _transform(self, s: SensorParams, target: str, source: str, stamp: float) -> Tf:
        if target == source:
            return IDENTITY
        tf = self.lookup(target, source, stamp)
        if tf is None:
            raise MeasurementRejected(f"{s.name}: no transform from '{source}' to '{target}' "
                                      f"at t={stamp:.6f} s", "no-transform")
        return tf

    def _finish(self, s: SensorParams, topic: str, stamp: float, z: NDArray[np.float64],
                cov: NDArray[np.float64], update: NDArray[np.bool_],
                threshold: float) -> list[Measurement]:
        if self.params.two_d_mode:
            update[self._two_d] = False
        if not update.any():
            return []
        return [Measurement(s.name, topic, stamp, z, cov, update, threshold)]

    def _pose(self, s: SensorParams, topic: str, stamp: float, frame: str, pose: Tf,
              cov6: NDArray[np.float64], target: str, source: str, imu: bool,
              update: NDArray[np.bool_], threshold: float, state: NDArray[np.float64]
              ) -> list[Measurement]:
        """robot_localization ``preparePose``."""
        previous_stamp = self._stamp_ok(s, topic, stamp)
        differential = s.use_differential
        frame = frame or (target if imu else self.params.world)
        pose_frame = target if differential and not imu else frame
        trans = self._transform(s, target, pose_frame, stamp)
        base = self.params.base_link_frame
        src = self._transform(s, source, base, stamp) if source != base else None
        r_target = _rot(trans)
        if imu:
            yaw_off = _rpy(trans)[2]
            c, sn = math.cos(yaw_off), math.sin(yaw_off)
            r_cov = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
        else:
            r_cov = r_target
        _mask(update, 0, r_cov)
        _mask(update, 3, r_cov)
        cov = np.array(cov6, dtype=np.float64).reshape(6, 6)
        if src is not None:
            r6 = _rot6(_rot(src))
            cov = r6.T @ cov @ r6
        cov_rotated = _rot6(r_cov) @ cov @ _rot6(r_cov).T
        if imu:  # remove the mounting attitude, swap roll/pitch by the mounting yaw
            ro, po, yo = _rpy(trans)
            r, p, y = _rpy(pose)
            rpy = r_cov @ np.array([normalize_angle(r - ro), normalize_angle(p - po),
                                    normalize_angle(y - yo)])
            pose = (pose[0], pose[1], pose[2], *rpy_to_quaternion(*(float(v) for v in rpy)))
            trans = IDENTITY
        if differential:
            previous = self._previous.get(topic)
            self._previous[topic] = (pose, cov)
            if previous is None or previous_stamp is None:
                return []
            dt = stamp - previous_stamp
            if not dt > 0.0:
                raise MeasurementRejected(f"{s.name}: {topic} differential step of {dt} s "
                                          "(repeated stamp)", "out-of-order")
            delta = tf_mul(tf_inverse(previous[0]), pose)
            delta = tf_mul((0.0, 0.0, 0.0, *trans[3:]), delta)
            lin = np.array(delta[:3]) / dt
            ang = np.array(_rpy(delta)) / dt
            twist_cov = (cov_rotated + _rot6(r_cov) @ previous[1] @ _rot6(r_cov).T) * dt
            twist_update = np.zeros(STATE_SIZE, dtype=bool)
            twist_update[6:12] = update[:6]
            return self._twist(s, topic, stamp, source, lin, ang, twist_cov, twist_update,
                               threshold, state, check_stamp=False)
        if src is not None:
            pose = tf_mul(pose, src)
        if s.use_relative:
            initial = self._initial.setdefault(topic, pose)
            pose = tf_mul(tf_inverse(initial), pose)
        pose = tf_mul(trans, pose)
        z = np.zeros(STATE_SIZE)
        z[:3] = pose[:3]
        z[3:6] = _rpy(pose)
        cov15 = np.zeros((STATE_SIZE, STATE_SIZE))
        cov15[:6, :6] = cov_rotated
        return self._finish(s, topic, stamp, z, cov15, update, threshold)

    def _twist(self, s: SensorParams, topic: str, stamp: float, frame: str, lin: Vec3,
               ang: Vec3, cov6: NDArray[np.float64], update: NDArray[np.bool_],
               threshold: float, state: NDArray[np.float64], check_stamp: bool = True
               ) -> list[Measurement]:
        """robot_localization ``prepareTwist``: into ``base_link_frame`` with the lever arm
        of the sensor (``v_base = R v + r x w``, ``w`` the state's body rates)."""
        if check_stamp:
            self._stamp_ok(s, topic, stamp)
        base = self.params.base_link_frame
        trans = self._transform(s, base, frame or base, stamp)
        r = _rot(trans)
        w_state = state[VROLL:VROLL + 3]
        ang_b = r @ ang
        lin_b = r @ lin + np.cross(np.array(trans[:3]), w_state)
        _mask(update, 6, r)
        _mask(update, 9, r)
        r6 = _rot6(r)
        z = np.zeros(STATE_SIZE)
        z[6:9], z[9:12] = lin_b, ang_b
        cov15 = np.zeros((STATE_SIZE, STATE_SIZE))
        cov15[6:12, 6:12] = r6 @ np.asarray(cov6, dtype=np.float64).reshape(6, 6) @ r6.T
        return self._finish(s, topic, stamp, z, cov15, update, threshold)

    def _acceleration(self, s: SensorParams, msg: Imu, has_orientation: bool,
                      update: NDArray[np.bool_], state: NDArray[np.float64],
                      alpha: Vec3) -> list[Measurement]:
        """robot_localization ``prepareAcceleration`` (lever arm, optional gravity removal)."""
        topic = f"{s.name}_acceleration"
        stamp = msg.header.stamp
        self._stamp_ok(s, topic, stamp)
        base = self.params.base_link_frame
        trans = self._transform(s, base, msg.header.frame_id or base, stamp)
        r = _rot(trans)
        a = msg.linear_acceleration
        offset = np.array(trans[:3])
        w = state[VROLL:VROLL + 3]
        acc = (r @ np.array([a.x, a.y, a.z]) + np.cross(offset, alpha)
               - np.cross(np.cross(offset, w), w))
        if s.remove_gravitational_acceleration:
            # gravity in base_link: R_world_base^T g, with R_world_base = R_world_imu r^T
            # from the IMU's attitude, or the state's attitude when the IMU reports none
            g = np.array([0.0, 0.0, self.params.gravitational_acceleration])
            if has_orientation:
                imu_attitude = quaternion_matrix(*_pose_tf(Pose(orientation=msg.orientation))[3:])
                acc = acc - r @ imu_attitude.T @ g
            else:
                q = rpy_to_quaternion(float(state[3]), float(state[4]), float(state[5]))
                acc = acc - quaternion_matrix(*q).T @ g
        _mask(update, 12, r)
        z = np.zeros(STATE_SIZE)
        z[12:15] = acc
        cov15 = np.zeros((STATE_SIZE, STATE_SIZE))
        cov15[12:15, 12:15] = r @ np.asarray(msg.linear_acceleration_covariance,
                                             dtype=np.float64).reshape(3, 3) @ r.T
        return self._finish(s, topic, stamp, z, cov15, update,
                            s.linear_acceleration_rejection_threshold)


def _only(update: NDArray[np.bool_], start: int, stop: int) -> NDArray[np.bool_]:
    """A copy of ``update`` with only ``[start, stop)`` kept."""
    out = np.zeros(STATE_SIZE, dtype=bool)
    out[start:stop] = update[start:stop]
    return out
