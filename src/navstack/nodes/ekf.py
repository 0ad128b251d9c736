"""``EkfNode``: robot_localization's ``ekf_node`` / ``ukf_node`` on the navstack bus.

* subscribes every configured input (``odom0: odom`` -> nav_msgs/Odometry on ``/odom``,
  ``imuN`` sensor_msgs/Imu, ``poseN`` PoseWithCovarianceStamped, ``twistN``
  TwistWithCovarianceStamped) with ``<sensor>_queue_size`` as its queue depth, plus
  ``set_pose`` (PoseWithCovarianceStamped: reset the filter to that pose) and, with
  ``use_control``, ``cmd_vel`` (Twist, or TwistStamped with ``stamped_control``);
* every ``1 / frequency`` seconds fuses the queued measurements in stamp order
  (:meth:`FilterBase.integrate`) and publishes ``odometry/filtered`` (nav_msgs/Odometry
  in ``world_frame`` with the pose and twist covariance blocks) stamped with the filter
  time;
* with ``publish_tf``: ``world_frame -> base_link_frame`` when ``world_frame`` is the
  odom frame; when it is the map frame, ``map -> odom`` computed as
  ``T(map, base_link) T(odom, base_link)^-1`` from the odometry TF, as robot_localization
  does (REP-105: a frame has one parent); stamped ``transform_time_offset`` ahead;
* keeps the set of sensors heard within ``sensor_timeout`` (``active_sensors``), with
  drop and re-admission counts, and counts every rejected message per sensor with its
  reason (``rejected``, ``rejection_reasons``).

``publish_acceleration`` is accepted; the acceleration estimate is ``state[12:15]`` and
``angular_acceleration`` (navstack has no AccelWithCovarianceStamped message yet).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import TransformError
from navstack.core.geometry import quaternion_to_rpy, rpy_to_quaternion
from navstack.core.msgs import (
    Header,
    Imu,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    TFMessage,
    Twist,
    TwistStamped,
    TwistWithCovariance,
    TwistWithCovarianceStamped,
    Vector3,
)
from navstack.core.tf import Tf, tf_from_msg, tf_inverse, tf_mul, tf_to_stamped
from navstack.localization.ekf.diagnostics import configuration_diagnostics
from navstack.localization.ekf.ekf import Ekf, FilterBase
from navstack.localization.ekf.measurements import (
    MeasurementBuilder,
    MeasurementRejected,
    SensorActivity,
)
from navstack.localization.ekf.model import STATE_SIZE, VROLL
from navstack.localization.ekf.params import EkfParams, SensorParams, UkfParams
from navstack.localization.ekf.ukf import Ukf
from navstack.runtime.bus import QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["EkfNode"]

_MSG_TYPES: dict[str, type[Any]] = {"odom": Odometry, "imu": Imu,
                                    "pose": PoseWithCovarianceStamped,
                                    "twist": TwistWithCovarianceStamped}


class EkfNode(Node):
    """State estimation node (robot_localization semantics) around an :class:`Ekf` or,
    with ``filter_type="ukf"`` or :class:`UkfParams`, a :class:`Ukf`."""

    def __init__(self, runtime: Runtime, params: EkfParams | None = None,
                 name: str = "ekf_filter_node",
                 filter_type: Literal["ekf", "ukf"] | None = None) -> None:
        super().__init__(name, runtime)
        self.params = params or EkfParams()
        kind = filter_type or ("ukf" if isinstance(self.params, UkfParams) else "ekf")
        self.filter: FilterBase = Ukf(self.params) if kind == "ukf" else Ekf(self.params)
        self.builder = MeasurementBuilder(self.params, self._lookup)
        self.activity = SensorActivity(self.params.timeout)
        self.enabled = not self.params.disabled_at_startup
        self.diagnostics = configuration_diagnostics(self.params)
        self.angular_acceleration = np.zeros(3)
        self.published = 0
        self.tf_published = 0
        self.tf_failures = 0
        self.last_problem = ""
        self._last_published_stamp = -math.inf
        self._last_rates = np.zeros(3)
        self._last_diff_time: float | None = None
        self._last_update_time = -math.inf
        self._set_pose_time = -math.inf

    # --- what tests and dashboards read -----------------------------------------------
    @property
    def estimate(self) -> NDArray[np.float64]:
        """The 15-state estimate ``[x y z roll pitch yaw vx vy vz vroll vpitch vyaw ax ay
        az]`` (named so because ``Node.state`` is the lifecycle state)."""
        return self.filter.state

    @property
    def covariance(self) -> NDArray[np.float64]:
        """The (15, 15) estimate covariance."""
        return self.filter.covariance

    @property
    def update_ms(self) -> list[float]:
        """Wall time [ms] of predict + correct for every processed measurement."""
        return self.filter.update_ms

    @property
    def rejected(self) -> Counter[str]:
        """Rejected messages/measurements per sensor (``odom0`` ...)."""
        return self.filter.rejected

    @property
    def rejection_reasons(self) -> Counter[tuple[str, str]]:
        return self.filter.rejection_reasons

    @property
    def active_sensors(self) -> set[str]:
        """Sensors heard within ``sensor_timeout``."""
        return set(self.activity.active)

    @property
    def sensor_timeouts(self) -> Counter[str]:
        return self.activity.timeouts

    @property
    def sensor_readmissions(self) -> Counter[str]:
        return self.activity.readmissions

    # --- lifecycle ---------------------------------------------------------------------
    def on_configure(self) -> None:
        p = self.params
        self.pub_odom = self.create_publisher("odometry/filtered", Odometry, QoS(depth=10))
        self.pub_tf = self.create_publisher("/tf", TFMessage, QoS(depth=100))
        for s in p.sensors:
            self.create_subscription(s.topic, _MSG_TYPES[s.kind], self._sensor_callback(s),
                                     QoS(depth=s.queue_size))
        self.create_subscription("set_pose", PoseWithCovarianceStamped, self._on_set_pose,
                                 QoS(depth=1))
        if p.use_control:
            if p.stamped_control:
                self.create_subscription("cmd_vel", TwistStamped, self._on_control_stamped,
                                         QoS(depth=1))
            else:
                self.create_subscription("cmd_vel", Twist, self._on_control, QoS(depth=1))
        self.create_timer(1.0 / p.frequency, self.periodic_update)
        if p.print_diagnostics:
            for line in self.diagnostics:
                self.log.warning(line)

    def on_cleanup(self) -> None:
        self.reset()

    # --- commands --------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget everything (robot_localization ``reset`` service)."""
        self.filter.reset()
        self.builder.reset()
        self._last_published_stamp = -math.inf
        self._last_diff_time = None

    def enable(self) -> None:
        """Start a filter that had ``disabled_at_startup`` (the ``enable`` service)."""
        self.enabled = True

    # --- inputs ---------------------------------------------------------------------------
    def _lookup(self, target: str, source: str, stamp: float) -> Tf | None:
        """TF at ``stamp``, else the latest available (robot_localization's
        ``lookupTransformSafe``), else ``None``."""
        try:
            return tf_from_msg(self.tf.lookup(target, source, stamp).transform)
        except TransformError:
            try:
                return tf_from_msg(self.tf.lookup(target, source, None).transform)
            except TransformError:
                return None

    def _sensor_callback(self, s: SensorParams) -> Callable[[Any], None]:
        def callback(msg: Any) -> None:
            self._on_sensor(s, msg)
        return callback

    def _on_sensor(self, s: SensorParams, msg: Any) -> None:
        if not self.enabled:
            return
        if self.activity.heard(s.name, self.now):
            self.log.info("%s is back after a silence longer than sensor_timeout", s.name)
        stamp = float(msg.header.stamp)
        if stamp <= self._set_pose_time:
            self.filter.count_rejection(s.name, "before-set-pose",
                                        f"{s.name}: stamp {stamp:.6f} s is not after the "
                                        f"last set_pose ({self._set_pose_time:.6f} s)")
            return
        try:
            if s.kind == "odom":
                measurements = self.builder.odometry(s, msg, self.filter.state)
            elif s.kind == "imu":
                measurements = self.builder.imu(s, msg, self.filter.state,
                                                self.angular_acceleration)
            elif s.kind == "pose":
                measurements = self.builder.pose(s, msg, self.filter.state)
            else:
                measurements = self.builder.twist(s, msg, self.filter.state)
        except MeasurementRejected as exc:
            self.filter.count_rejection(s.name, exc.category, str(exc))
            self.last_problem = str(exc)
            self.log.warning("rejected %s message: %s", s.name, exc)
            return
        for m in measurements:
            self.filter.enqueue(m)

    def _on_set_pose(self, msg: PoseWithCovarianceStamped) -> None:
        """Reset the filter to the given pose (twist and acceleration zero)."""
        pose = msg.pose.pose
        q = pose.orientation
        state = np.zeros(STATE_SIZE)
        state[:3] = (pose.position.x, pose.position.y, pose.position.z)
        state[3:6] = quaternion_to_rpy(q.x, q.y, q.z, q.w)
        cov = self.filter.initial_covariance.copy()
        cov[:6, :6] = np.asarray(msg.pose.covariance, dtype=np.float64).reshape(6, 6)
        if not (np.isfinite(state).all() and np.isfinite(cov).all()):
            self.filter.count_rejection("set_pose", "non-finite",
                                        "set_pose: non-finite pose or covariance")
            return
        self.builder.reset()
        self.filter.set_pose(state, cov, msg.header.stamp)
        self._set_pose_time = msg.header.stamp
        self._last_published_stamp = -math.inf

    def _on_control(self, twist: Twist, stamp: float | None = None) -> None:
        lin, ang = twist.linear, twist.angular
        self.filter.set_control(np.array([lin.x, lin.y, lin.z, ang.x, ang.y, ang.z]),
                                self.now if stamp is None else stamp)

    def _on_control_stamped(self, msg: TwistStamped) -> None:
        self._on_control(msg.twist, msg.header.stamp)

    # --- the periodic update ------------------------------------------------------------
    def periodic_update(self) -> None:
        """Fuse what arrived, estimate the angular acceleration, publish (``periodicUpdate``)."""
        now = self.now
        p = self.params
        if now < self._last_update_time and p.reset_on_time_jump:
            self.log.warning("time jumped back %.3f s: resetting the filter",
                             self._last_update_time - now)
            self.reset()
        self._last_update_time = now
        for s in self.activity.update(now):
            self.log.warning("%s silent for more than sensor_timeout (%.3f s): dropped from "
                             "the active sensors", s, p.timeout)
        if not self.enabled:
            return
        self.filter.integrate(now)
        self._differentiate(now)
        if self.filter.initialized:
            self._publish()

    def _differentiate(self, now: float) -> None:
        if not self.filter.initialized:
            return
        rates = self.filter.state[VROLL:VROLL + 3].copy()
        if self._last_diff_time is not None and now > self._last_diff_time:
            self.angular_acceleration = (rates - self._last_rates) / (now - self._last_diff_time)
        self._last_rates = rates
        self._last_diff_time = now

    def filtered_odometry(self) -> Odometry:
        """The current estimate as nav_msgs/Odometry (``odometry/filtered``)."""
        p, x, P = self.params, self.filter.state, self.filter.covariance
        q = Quaternion(*rpy_to_quaternion(float(x[3]), float(x[4]), float(x[5])))
        pose = Pose(Point(float(x[0]), float(x[1]), float(x[2])), q)
        twist = Twist(Vector3(float(x[6]), float(x[7]), float(x[8])),
                      Vector3(float(x[9]), float(x[10]), float(x[11])))
        return Odometry(Header(self.filter.last_measurement_time, p.world),
                        p.base_link_output,
                        PoseWithCovariance(pose, P[:6, :6].copy()),
                        TwistWithCovariance(twist, P[6:12, 6:12].copy()))

    def _publish(self) -> None:
        p = self.params
        odom = self.filtered_odometry()
        stamp = odom.header.stamp
        if not p.permit_corrected_publication and self._last_published_stamp >= stamp:
            return  # nothing new (or a re-published correction) since the last output
        if not (np.isfinite(self.filter.state).all()
                and np.isfinite(self.filter.covariance).all()):
            self.last_problem = "non-finite filter output; not published"
            self.log.error(self.last_problem)
            return
        if p.publish_tf:
            self._publish_tf(odom)
        self._last_published_stamp = stamp
        self.pub_odom.publish(odom)
        self.published += 1

    def _publish_tf(self, odom: Odometry) -> None:
        p = self.params
        pose = odom.pose.pose
        world_base: Tf = (pose.position.x, pose.position.y, pose.position.z,
                          pose.orientation.x, pose.orientation.y, pose.orientation.z,
                          pose.orientation.w)
        stamp = odom.header.stamp + p.transform_time_offset
        if p.world == p.odom_frame:
            out = tf_to_stamped(world_base, p.world, odom.child_frame_id, stamp)
        else:
            try:
                odom_base = tf_from_msg(self.tf.lookup(p.odom_frame, p.base_link_frame,
                                                       None).transform)
            except TransformError as exc:
                self.tf_failures += 1
                self.last_problem = (f"cannot publish {p.map_frame} -> {p.odom_frame}: no "
                                     f"{p.odom_frame} -> {p.base_link_frame} transform ({exc})")
                self.log.warning(self.last_problem)
                return
            map_odom = tf_mul(world_base, tf_inverse(odom_base))
            out = tf_to_stamped(map_odom, p.map_frame, p.odom_frame, stamp)
        self.pub_tf.publish(TFMessage((out,)))
        self.tf_published += 1
