"""``NavsatTransformNode``: robot_localization's ``navsat_transform_node`` on the bus.

The transform itself (datum, heading, antenna offset, outputs) is the pure
:class:`~navstack.localization.navsat.NavsatTransform`; this node feeds it ``/imu``,
``/odometry/filtered`` and ``/gps/fix``, looks the sensors' mounting offsets up in TF and
publishes its outputs at ``frequency``.
"""

from __future__ import annotations

from navstack.core.errors import ExtrapolationError, TransformError
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import Imu, NavSatFix, Odometry, TFMessage
from navstack.localization.navsat import NavsatTransform, NavsatTransformParams
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["NavsatTransformNode"]


class NavsatTransformNode(Node):
    """``navsat_transform_node`` on the bus: ``/imu``, ``/odometry/filtered``, ``/gps/fix``
    in; ``/odometry/gps``, ``/gps/filtered`` and optionally ``/tf_static`` out."""

    def __init__(self, runtime: Runtime, params: NavsatTransformParams | None = None,
                 name: str = "navsat_transform") -> None:
        super().__init__(name, runtime)
        self.params = params or NavsatTransformParams()
        self.core = NavsatTransform(self.params)
        self._start_t = 0.0
        self._broadcast_done = False
        self.tf_failures = 0
        self.last_tf_failure = ""

    def on_configure(self) -> None:
        p = self.params
        qos = QoS(depth=1)
        self.create_subscription("/odometry/filtered", Odometry, self._on_odom, qos)
        self.create_subscription("/gps/fix", NavSatFix, self._on_fix, qos)
        if not p.use_odometry_yaw and not p.wait_for_datum:
            self.create_subscription("/imu", Imu, self._on_imu, qos)
        self.pub_odom = self.create_publisher("/odometry/gps", Odometry, QoS(depth=10))
        if p.publish_filtered_gps:
            self.pub_filtered = self.create_publisher("/gps/filtered", NavSatFix, QoS(depth=10))
        if p.broadcast_cartesian_transform:
            self.pub_tf_static = self.create_publisher("/tf_static", TFMessage, LATCHED)
        self.create_timer(1.0 / p.frequency, self._tick)

    def on_activate(self) -> None:
        self._start_t = self.now + self.params.delay

    def _offset(self, frame: str, stamp: float) -> tuple[float, float, float, float] | None:
        """``base_link -> frame`` (x, y, z, yaw); None (counted) when TF cannot give it.

        Looked up at ``stamp``; if that is outside the buffer, the newest transform is
        accepted when it is at most ``transform_timeout`` seconds older."""
        base = self.core.base_link_frame_id
        if not frame or frame == base:
            return (0.0, 0.0, 0.0, 0.0)
        try:
            try:
                ts = self.tf.lookup(base, frame, stamp)
            except ExtrapolationError:
                ts = self.tf.lookup(base, frame, None)
                if stamp - ts.header.stamp > self.params.transform_timeout:
                    raise
        except TransformError as exc:
            self.tf_failures += 1
            self.last_tf_failure = str(exc)
            return None
        t = ts.transform
        return (t.translation.x, t.translation.y, t.translation.z, t.rotation.yaw)

    def _on_imu(self, msg: Imu) -> None:
        if self.core.latest_odom is None:  # base_link's name comes with the odometry
            return
        off = self._offset(msg.header.frame_id, msg.header.stamp)
        if off is not None:
            self.core.add_heading(normalize_angle(msg.orientation.yaw - off[3]))

    def _on_fix(self, msg: NavSatFix) -> None:
        off = self._offset(msg.header.frame_id, msg.header.stamp)
        antenna = (0.0, 0.0, 0.0) if off is None else off[:3]
        if not self.core.add_fix(msg, antenna):
            self.log.warning(self.core.last_rejection)

    def _on_odom(self, msg: Odometry) -> None:
        self.core.add_odometry(msg)

    def _tick(self) -> None:
        if self.now < self._start_t - 1e-9:
            return
        core = self.core
        if not core.transform_good:
            if core.compute_transform():
                self.log.info("navsat transform computed: %s", core.transform)
            return
        if self.params.broadcast_cartesian_transform and not self._broadcast_done:
            ts = core.cartesian_transform_message(self.now)
            if ts is not None:
                self.pub_tf_static.publish(TFMessage((ts,)))
                self._broadcast_done = True
        odom = core.gps_odometry()
        if odom is not None:
            self.pub_odom.publish(odom)
        if self.params.publish_filtered_gps:
            fix = core.filtered_gps()
            if fix is not None:
                self.pub_filtered.publish(fix)
