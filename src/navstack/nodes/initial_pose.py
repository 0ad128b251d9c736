"""``InitialPoseNode``: the GNSS + magnetometer + scan-matching initial pose on the bus.

The estimate (guess from the fix and the magnetometer, correlative search, point-to-line
ICP) is :func:`~navstack.localization.initial_pose.estimate_initial_pose`; this node
collects ``/gps/fix``, ``/imu/mag``, ``/scan`` and ``/map``, looks the sensor mounts up in
TF and publishes ``/initialpose`` for AMCL.
"""

from __future__ import annotations

from navstack.core.errors import InvalidMessage, TransformError
from navstack.core.msgs import (
    LaserScan,
    MagneticField,
    NavSatFix,
    OccupancyGrid,
    Pose2D,
    PoseWithCovarianceStamped,
)
from navstack.localization.initial_pose import (
    InitialPoseEstimate,
    InitialPoseParams,
    MapMatcher,
    estimate_initial_pose,
)
from navstack.localization.navsat import fix_rejection_reason
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["InitialPoseNode"]


class InitialPoseNode(Node):
    """Publishes ``/initialpose`` once from ``/gps/fix``, ``/imu/mag``, ``/scan`` and ``/map``
    (and again after :meth:`request`).  Sensor mounts come from TF (``base_link`` ->
    frame of each message)."""

    def __init__(self, runtime: Runtime, params: InitialPoseParams,
                 base_frame: str = "base_link", name: str = "initial_pose") -> None:
        super().__init__(name, runtime)
        self.params = params
        self.base_frame = base_frame
        self.matcher: MapMatcher | None = None
        self.fix: NavSatFix | None = None
        self.mag: MagneticField | None = None
        self.estimate: InitialPoseEstimate | None = None
        self.pending = True
        self.failures = 0
        self.last_failure = ""

    def on_configure(self) -> None:
        self.pub = self.create_publisher("/initialpose", PoseWithCovarianceStamped, LATCHED)
        self.create_subscription("/map", OccupancyGrid, self._on_map, QoS(depth=1, latched=True))
        self.create_subscription("/gps/fix", NavSatFix, self._on_fix, SENSOR_DATA)
        self.create_subscription("/imu/mag", MagneticField, self._on_mag, SENSOR_DATA)
        self.create_subscription("/scan", LaserScan, self._on_scan, SENSOR_DATA)

    def request(self) -> None:
        """Estimate and publish again with the next scan (e.g. after a kidnapping)."""
        self.pending = True

    def _on_map(self, msg: OccupancyGrid) -> None:
        self.matcher = MapMatcher.from_grid(msg, self.params)

    def _on_fix(self, msg: NavSatFix) -> None:
        if not fix_rejection_reason(msg):
            self.fix = msg

    def _on_mag(self, msg: MagneticField) -> None:
        self.mag = msg

    def _mount(self, frame: str) -> Pose2D:
        return Pose2D() if frame == self.base_frame else self.tf.lookup_pose2d(
            self.base_frame, frame)

    def _on_scan(self, scan: LaserScan) -> None:
        if not self.pending or self.matcher is None or self.fix is None or self.mag is None:
            return
        t = scan.header.stamp
        age = self.params.max_input_age
        if t - self.fix.header.stamp > age or t - self.mag.header.stamp > age:
            return
        try:
            lidar = self._mount(scan.header.frame_id)
            gps = self._mount(self.fix.header.frame_id)
            mag = self._mount(self.mag.header.frame_id)
            est = estimate_initial_pose(self.matcher, self.fix, self.mag, scan, lidar,
                                        (gps.x, gps.y), mag.theta)
        except (TransformError, InvalidMessage) as exc:
            self.failures += 1
            self.last_failure = str(exc)
            self.log.warning("initial pose: %s", exc)
            return
        self.estimate = est
        self.pending = False
        if not est.refined:
            self.log.warning("initial pose not refined: %s", est.reason)
        self.pub.publish(est.message(t))
