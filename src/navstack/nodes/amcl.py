"""``AmclNode``: Nav2's ``amcl`` lifecycle node on the navstack bus.

* subscribes ``map_topic`` (latched ``OccupancyGrid``; with ``first_map_only`` later maps
  are ignored), ``scan_topic`` (``LaserScan``; the laser mount comes from TF
  ``base_frame_id -> scan frame``, the odometry at the scan's stamp from TF
  ``odom_frame_id -> base_frame_id``; a scan waits up to ``transform_tolerance`` until
  that odometry is in the buffer, in a :class:`~navstack.runtime.tf_filter.TfMessageFilter`
  as behind Nav2's tf2 message filter) and ``/initialpose``
  (``PoseWithCovarianceStamped`` in ``global_frame_id``);
* updates the filter on the first scan after (re)initialisation and whenever odometry
  moved more than ``update_min_d`` in x or y or ``update_min_a`` in yaw since the last
  update (Nav2 ``shouldUpdateFilter``), or after ``/request_nomotion_update``;
* publishes ``/amcl_pose`` (latched, the heaviest cluster's mean with the filter's
  covariance in the x, y, yaw entries of the 6x6 matrix), ``/particle_cloud``
  (``PoseArray``, built only when someone listens) and, with ``tf_broadcast``,
  ``global_frame_id -> odom_frame_id`` on ``/tf`` stamped ``scan stamp +
  transform_tolerance`` (re-sent with every scan, so odometry-rate lookups never wait);
* services ``/reinitialize_global_localization`` (uniform particles over free space),
  ``/set_initial_pose`` (``{"x", "y", "yaw", "covariance": 3x3 | 6x6}`` or a
  ``PoseWithCovarianceStamped``) and ``/request_nomotion_update``.

Bad input never corrupts the filter: NaN/-inf ranges are skipped beams (counted in
``invalid_beams``); a non-finite or malformed initial pose is rejected before anything
changes (``rejected_initial_poses``, ``last_rejection``); a scan whose stamp is not newer
than the previous one is dropped (``scans_out_of_order``, ``last_problem``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.core.errors import TransformError
from navstack.core.msgs import (
    Header,
    LaserScan,
    OccupancyGrid,
    Pose,
    Pose2D,
    PoseArray,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    TFMessage,
    Transform,
    TransformStamped,
)
from navstack.localization.amcl.motion_model import odometry_delta
from navstack.localization.amcl.params import AmclParams
from navstack.localization.amcl.particle_filter import AmclFilter, InvalidInitialPose
from navstack.localization.amcl.sensor_model import AmclMapError, prepare_scan
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime
from navstack.runtime.tf_filter import TfMessageFilter

__all__ = ["DEFAULT_INITIAL_COVARIANCE", "AmclNode"]

DEFAULT_INITIAL_COVARIANCE = np.diag([0.5 ** 2, 0.5 ** 2, (math.pi / 12.0) ** 2])
"""Covariance used when an initial pose comes without one (``set_initial_pose``
parameter, Python calls): ROS 1 amcl's ``initial_cov_xx/yy/aa`` defaults."""

SCAN_QUEUE = 5
"""Scans held while waiting for odometry at their stamp (the tf2 filter's queue)."""
UPDATE_HISTORY = 10000
"""Per-update wall times kept in ``update_ms``."""


def _cov3(cov: ArrayLike) -> NDArray[np.float64]:
    """A 3x3 (x, y, yaw) covariance from a 3x3 or ROS 6x6 matrix (rows/cols 0, 1, 5)."""
    c = np.asarray(cov, np.float64)
    if c.shape == (36,):
        c = c.reshape(6, 6)
    if c.shape == (6, 6):
        return c[np.ix_((0, 1, 5), (0, 1, 5))].copy()
    if c.shape != (3, 3):
        raise InvalidInitialPose(f"covariance must be 3x3 (x, y, yaw) or 6x6 (ROS), "
                                 f"got shape {c.shape}")
    return c.copy()


class AmclNode(Node):
    """Adaptive Monte Carlo Localization (Nav2 ``nav2_amcl::AmclNode``)."""

    def __init__(self, runtime: Runtime, params: AmclParams | None = None,
                 rng: np.random.Generator | None = None, name: str = "amcl") -> None:
        super().__init__(name, runtime)
        self.params = params or AmclParams()
        seed = None if self.params.random_seed < 0 else self.params.random_seed
        self.rng = rng if rng is not None else np.random.default_rng(seed)
        self.filter = AmclFilter(self.params, self.rng)
        self.estimate = np.full(3, np.nan)
        self.covariance = np.full((3, 3), np.nan)
        self.update_ms: list[float] = []
        self.updates = 0
        self.initial_pose_known = False
        self.saved_pose: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        self.maps_received = self.maps_rejected = self.maps_ignored = 0
        self.scans_received = self.scans_out_of_order = 0
        self.scans_without_map = self.scans_without_pose = self.invalid_beams = 0
        self.rejected_initial_poses = 0
        self.last_rejection = ""
        self.last_problem = ""
        self._reset_tracking()
        self._map_to_odom: Pose2D | None = None
        self._sent_first_transform = False
        self._scans: TfMessageFilter[LaserScan, tuple[str, Pose2D, Pose2D]] = TfMessageFilter(
            self, self._scan_transforms, self._on_scan_placed, queue_size=SCAN_QUEUE,
            timeout=self.params.transform_tolerance, what="scan", on_drop=self._on_scan_dropped)
        self._last_scan_stamp = -math.inf
        self._mounts: dict[str, Pose2D] = {}
        self._last_save_t = -math.inf

    def _reset_tracking(self) -> None:
        """Forget the odometry reference (Nav2 ``pf_init_ = false``)."""
        self._pf_odom: NDArray[np.float64] | None = None
        self._lasers_update: dict[str, bool] = {}
        self._force_update = False
        self._first_pose_sent = False

    # --- lifecycle -----------------------------------------------------------------------
    def on_configure(self) -> None:
        p = self.params
        self.pub_pose = self.create_latched_publisher("/amcl_pose", PoseWithCovarianceStamped)
        self.pub_cloud = self.create_publisher("/particle_cloud", PoseArray, QoS(depth=2))
        self.pub_tf = self.create_publisher("/tf", TFMessage, QoS(depth=100))
        self.create_subscription(p.map_topic, OccupancyGrid, self._on_map, LATCHED)
        self.create_subscription(p.scan_topic, LaserScan, self._on_scan, SENSOR_DATA)
        self.create_subscription("/initialpose", PoseWithCovarianceStamped,
                                 self._on_initial_pose, QoS(depth=10))
        self.bus.advertise_service("/reinitialize_global_localization", self._global_request)
        self.bus.advertise_service("/set_initial_pose", self._initial_pose_request)
        self.bus.advertise_service("/request_nomotion_update", self._nomotion_request)

    def on_activate(self) -> None:
        p = self.params
        if p.set_initial_pose:
            ip = p.initial_pose
            self.set_initial_pose(ip.x, ip.y, ip.yaw)
        elif not p.always_reset_initial_pose and self.saved_pose is not None \
                and not self.initial_pose_known:
            self._apply_initial(*self.saved_pose)

    def on_cleanup(self) -> None:
        for service in ("/reinitialize_global_localization", "/set_initial_pose",
                        "/request_nomotion_update"):
            self.bus.remove_service(service)
        self.filter = AmclFilter(self.params, self.rng)
        self.initial_pose_known = False
        self._scans.clear()
        self._mounts.clear()
        self._reset_tracking()
        self._map_to_odom = None
        self._sent_first_transform = False

    # --- initialisation ------------------------------------------------------------------
    def set_initial_pose(self, x: float, y: float, yaw: float,
                         cov: ArrayLike | None = None) -> None:
        """Re-seed the particles around ``(x, y, yaw)`` in ``global_frame_id`` with ``cov``
        (3x3 over x, y, yaw or ROS 6x6; default :data:`DEFAULT_INITIAL_COVARIANCE`).
        Raises :class:`InvalidInitialPose` and leaves the filter as it was."""
        mean = np.array([x, y, yaw], np.float64)
        cov3 = DEFAULT_INITIAL_COVARIANCE.copy() if cov is None else _cov3(cov)
        self._apply_initial(mean, cov3)

    def global_localization(self) -> None:
        """Spread the particles uniformly over the map's free space (Nav2
        ``reinitialize_global_localization``).  Raises :class:`AmclMapError` without map."""
        if self.filter.map is None:
            raise AmclMapError(f"no map yet: global localization samples the free space of "
                               f"the map on '{self.params.map_topic}'; publish it first")
        self.filter.initialize_global()
        self.initial_pose_known = True
        self._reset_tracking()

    def _apply_initial(self, mean: NDArray[np.float64], cov: NDArray[np.float64]) -> None:
        self.filter.initialize_pose(mean, cov)  # validates before changing anything
        self.initial_pose_known = True
        self._reset_tracking()

    def _reject(self, source: str, reason: str) -> str:
        self.rejected_initial_poses += 1
        self.last_rejection = f"{source} rejected: {reason}"
        self.log.warning(self.last_rejection)
        return self.last_rejection

    def _on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        frame = msg.header.frame_id.lstrip("/")
        g = self.params.global_frame_id
        if frame != g:
            self._reject("/initialpose", f"frame '{frame}' is not the global frame '{g}'; "
                                         "initial poses must be given in the global frame")
            return
        pose = msg.pose.pose
        mean = np.array([pose.position.x, pose.position.y, pose.orientation.yaw])
        try:
            cov = _cov3(msg.pose.covariance)
            if np.isfinite(mean).all():
                mean = self._advance_by_odometry(mean, msg.header.stamp)
            self._apply_initial(mean, cov)
        except InvalidInitialPose as exc:
            self._reject("/initialpose", str(exc))

    def _advance_by_odometry(self, mean: NDArray[np.float64], stamp: float
                             ) -> NDArray[np.float64]:
        """Move a pose given at ``stamp`` by the odometry since then (Nav2
        ``handleInitialPose``); unchanged when TF cannot tell."""
        p = self.params
        try:
            then = self.tf.lookup_pose2d(p.odom_frame_id, p.base_frame_id, stamp)
            now = self.tf.lookup_pose2d(p.odom_frame_id, p.base_frame_id)
        except TransformError:
            return mean
        moved = Pose2D.from_array(mean) @ (then.inverse() @ now)
        return moved.as_array()

    # --- services --------------------------------------------------------------------------
    def _global_request(self, request: Any) -> dict[str, Any]:
        try:
            self.global_localization()
        except AmclMapError as exc:
            return {"result": False, "reason": str(exc)}
        return {"result": True, "particles": len(self.filter.pf)}

    def _initial_pose_request(self, request: Any) -> dict[str, Any]:
        try:
            if isinstance(request, PoseWithCovarianceStamped):
                pose = request.pose.pose
                self.set_initial_pose(pose.position.x, pose.position.y, pose.orientation.yaw,
                                      request.pose.covariance)
            elif isinstance(request, dict) and {"x", "y", "yaw"} <= request.keys():
                self.set_initial_pose(float(request["x"]), float(request["y"]),
                                      float(request["yaw"]), request.get("covariance"))
            else:
                raise InvalidInitialPose("request must be {'x', 'y', 'yaw', 'covariance'} "
                                         "or a PoseWithCovarianceStamped")
        except (InvalidInitialPose, TypeError, ValueError) as exc:
            return {"result": False, "reason": self._reject("/set_initial_pose", str(exc))}
        return {"result": True}

    def _nomotion_request(self, request: Any) -> dict[str, Any]:
        self._force_update = True
        return {"result": True}

    # --- map -------------------------------------------------------------------------------
    def _on_map(self, grid: OccupancyGrid) -> None:
        p = self.params
        if p.first_map_only and self.filter.map is not None:
            self.maps_ignored += 1
            return
        if grid.header.frame_id and grid.header.frame_id != p.global_frame_id:
            self.log.warning("map frame '%s' differs from global_frame_id '%s'",
                             grid.header.frame_id, p.global_frame_id)
        try:
            self.filter.set_map(grid)
        except AmclMapError as exc:
            self.maps_rejected += 1
            self.last_problem = f"map rejected: {exc}"
            self.log.warning(self.last_problem)
            return
        self.maps_received += 1

    # --- scans -----------------------------------------------------------------------------
    @property
    def tf_failures(self) -> int:
        """Scans dropped because TF had no odometry (or mount) at their stamp within
        ``transform_tolerance``."""
        return self._scans.dropped_timeout

    def _on_scan(self, scan: LaserScan) -> None:
        self.scans_received += 1
        stamp = scan.header.stamp
        waiting = self._scans.pending
        newest = waiting[-1].header.stamp if waiting else self._last_scan_stamp
        if not stamp > newest:
            self.scans_out_of_order += 1
            self.last_problem = (f"scan at t={stamp:.3f} dropped: not newer than the previous "
                                 f"scan (t={newest:.3f}); scans must arrive in stamp order")
            return
        self._scans.add(scan)

    def _scan_transforms(self, scan: LaserScan) -> tuple[str, Pose2D, Pose2D]:
        """The scan's frame, the odometry pose at its stamp and the laser mount (cached:
        mounts are static); raises :class:`TransformError` while TF lacks them."""
        p = self.params
        frame = scan.header.frame_id or p.base_frame_id
        odom = self.tf.lookup_pose2d(p.odom_frame_id, p.base_frame_id, scan.header.stamp)
        mount = self._mounts.get(frame) or self.tf.lookup_pose2d(p.base_frame_id, frame)
        return frame, odom, mount

    def _on_scan_placed(self, scan: LaserScan, transforms: tuple[str, Pose2D, Pose2D]) -> None:
        frame, odom, mount = transforms
        self._mounts[frame] = mount
        self._last_scan_stamp = scan.header.stamp
        self._process(scan, frame, odom, mount)

    def _on_scan_dropped(self, scan: LaserScan, reason: str) -> None:
        self.last_problem = reason

    def _process(self, scan: LaserScan, frame: str, odom: Pose2D, mount: Pose2D) -> None:
        """Nav2 ``laserReceived`` once the transforms are known."""
        p = self.params
        if self.filter.map is None:
            self.scans_without_map += 1
            self.last_problem = f"waiting for a map on '{p.map_topic}'"
            return
        if not self.initial_pose_known:
            self.scans_without_pose += 1
            self.last_problem = ("no initial pose: publish /initialpose, call /set_initial_pose "
                                 "or /reinitialize_global_localization")
            return
        pose = odom.as_array()
        delta = None
        force_publication = False
        if self._pf_odom is None:
            self._pf_odom = pose
            self._lasers_update = dict.fromkeys(self._lasers_update, True)
            self._lasers_update[frame] = True
            force_publication = True
            self.filter.resample_count = 0
        else:
            delta = odometry_delta(pose, self._pf_odom)
            if (abs(delta[0]) > p.update_min_d or abs(delta[1]) > p.update_min_d
                    or abs(delta[2]) > p.update_min_a or self._force_update):
                self._lasers_update = dict.fromkeys(self._lasers_update, True)
                self._lasers_update[frame] = True
            self._force_update = False
        resampled = False
        if self._lasers_update.get(frame, False):
            data = prepare_scan(scan.ranges, scan.angle_min, scan.angle_increment,
                                scan.range_min, scan.range_max, (mount.x, mount.y, mount.theta),
                                p)
            self.invalid_beams += data.invalid
            resampled = self.filter.update(pose, delta, data)
            self._lasers_update[frame] = False
            self._pf_odom = pose
            self.updates += 1
            self.update_ms.append(self.filter.last_update_ms)
            if len(self.update_ms) > 2 * UPDATE_HISTORY:
                del self.update_ms[:-UPDATE_HISTORY]
            self._publish_cloud()
        stamp = scan.header.stamp
        if resampled or force_publication or not self._first_pose_sent:
            self._publish_pose(stamp, odom)
        if p.tf_broadcast and self._map_to_odom is not None:
            self._send_transform(stamp)

    # --- outputs ---------------------------------------------------------------------------
    @property
    def particle_count(self) -> int:
        return len(self.filter.pf)

    def _publish_pose(self, stamp: float, odom: Pose2D) -> None:
        p = self.params
        mean, cov = self.filter.pf.estimate()
        if not (np.isfinite(mean).all() and np.isfinite(cov).all()):
            self.last_problem = "no pose: the filter estimate is not finite"
            return
        self.estimate, self.covariance = mean, cov
        cov6 = np.zeros((6, 6))
        cov6[np.ix_((0, 1, 5), (0, 1, 5))] = cov
        best = Pose2D(float(mean[0]), float(mean[1]), float(mean[2]))
        self.pub_pose.publish(PoseWithCovarianceStamped(
            Header(stamp, p.global_frame_id), PoseWithCovariance(best.to_pose(), cov6)))
        self._first_pose_sent = True
        self._map_to_odom = best @ odom.inverse()
        if p.save_pose_rate > 0.0 and self.now - self._last_save_t >= 1.0 / p.save_pose_rate:
            self.saved_pose = (mean.copy(), cov.copy())
            self._last_save_t = self.now

    def _send_transform(self, stamp: float) -> None:
        """``global -> odom`` valid until ``stamp + transform_tolerance`` (Nav2)."""
        p = self.params
        assert self._map_to_odom is not None
        transform = Transform.from_pose2d(self._map_to_odom)
        stamps = [stamp + p.transform_tolerance]
        if not self._sent_first_transform and p.transform_tolerance > 0.0:
            stamps.insert(0, stamp)  # lookups at the scan time need a sample there too
        self._sent_first_transform = True
        self.pub_tf.publish(TFMessage(tuple(
            TransformStamped(Header(t, p.global_frame_id), p.odom_frame_id, transform)
            for t in stamps)))

    def _publish_cloud(self) -> None:
        if not (self.pub_cloud.subscription_count() or self.bus.taps):
            return  # 2000 Pose objects per update only when someone listens
        self.pub_cloud.publish(PoseArray(Header(self.now, self.params.global_frame_id),
                                         self.particle_poses()))

    def particle_poses(self) -> tuple[Pose, ...]:
        """The particles as ``Pose`` messages (what ``/particle_cloud`` carries)."""
        return tuple(Pose2D(float(x), float(y), float(t)).to_pose()
                     for x, y, t in self.filter.pf.poses)
