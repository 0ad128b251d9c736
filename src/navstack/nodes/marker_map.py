"""``MarkerMapNode``: detected markers placed on the map, as frames, markers and obstacles.

Subscribes ``/aruco/markers`` (aruco_msgs/MarkerArray in a camera frame), waits for TF
to place each frame at its stamp (a TF message filter), transforms every marker into
``map_frame`` (pose and position covariance) and fuses it in a
:class:`~navstack.perception.aruco.marker_map.MarkerMap`.  Then, for every marker whose
estimate is published:

* ``/tf_static`` ``map -> aruco_marker_<id>`` (``frame_prefix``; the Nav2 lab's
  ``aruco_marker_frame``), re-sent when the estimate moves by more than
  ``republish_distance`` / ``republish_angle``;
* ``/aruco/marker_map`` (aruco_msgs/MarkerArray in the map frame, latched) and
  ``/aruco/marker_map/markers`` (visualization_msgs/MarkerArray: a flat cube per marker
  and its id, latched) for Foxglove and the dashboard.

Markers whose id is in ``package_ids`` are packages (TurtleBot course): they are fused in
a separate map (a package carries its id on several faces, so sightings of one package
spread over its size: ``package_position_floor``) and each becomes a ring of points on
``/package_cloud`` (sensor_msgs/PointCloud2, map frame; 25 points, 0.3 m across, z 0.05)
whenever the set changes and every ``cloud_period`` seconds, for the obstacle layer's
``package_cloud`` source.  ``ignore_package(id)`` removes a package from the cloud (the
one the gripper holds; also the service ``/package_cloud/ignore``).  ``/aruco/packages``
(latched) lists the packages found with their centres.  Services: ``/marker_map/save``
(a path -> the YAML written) and ``/marker_map/load`` (a path -> the number of markers
loaded).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.msgs import (
    ColorRGBA,
    Header,
    Marker,
    MarkerArray,
    Point,
    Pose,
    PoseWithCovariance,
    TFMessage,
    TransformStamped,
    Vector3,
)
from navstack.core.msgs.fiducial_msgs import (
    IGNORE_PACKAGE_SERVICE,
    MARKER_MAP_TOPIC,
    MARKER_MAP_VIZ_TOPIC,
    PACKAGES_TOPIC,
    ArucoMarker,
    ArucoMarkerArray,
)
from navstack.core.msgs.sensor_msgs import PointCloud2
from navstack.core.params import Params
from navstack.core.rotations import (
    matrix_to_pose,
    matrix_to_transform,
    pose_to_matrix,
    rotation_angle,
    transform_to_matrix,
)
from navstack.perception.aruco.marker_map import (
    MarkerEstimate,
    MarkerMap,
    MarkerMapParams,
    Sighting,
)
from navstack.perception.package_cloud import package_cloud
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Node, Runtime
from navstack.runtime.tf_filter import TfMessageFilter


class MarkerMapNodeParams(Params):
    """Marker map node (navstack): frames, topics, fusion and the package cloud."""

    map_frame: str = "map"
    markers_topic: str = "/aruco/markers"
    frame_prefix: str = "aruco_marker_"
    fusion: MarkerMapParams = Field(default_factory=MarkerMapParams)
    republish_distance: float = Field(default=0.01, ge=0.0)
    republish_angle: float = Field(default=0.01, ge=0.0)
    transform_timeout: float = Field(default=0.5, ge=0.0)
    package_ids: list[int] = Field(default_factory=list)
    package_position_floor: float = Field(default=0.06, ge=0.0)
    package_min_sightings: int = Field(default=1, ge=1)
    """A package enters the cloud on its first sighting: the course asks the system to
    respond within 0.4 s, and a ring in the wrong place costs a detour, not a collision."""
    package_depth: float = Field(default=0.03, ge=0.0)
    """How far behind its marker [m] a package's centre is assumed (half its depth)."""
    freeze_ignored: bool = False
    """Stop updating an ignored package's estimate (default: keep tracking it)."""
    cloud_topic: str = "/package_cloud"
    cloud_period: float = Field(default=1.0, gt=0.0)
    ring_diameter: float = Field(default=0.3, gt=0.0)
    ring_points: int = Field(default=25, ge=3)
    ring_height: float = 0.05


class MarkerMapNode(Node):
    """Fuses marker detections on the map (see module docstring)."""

    def __init__(self, runtime: Runtime, params: MarkerMapNodeParams | None = None,
                 name: str = "marker_map", marker_map: MarkerMap | None = None) -> None:
        super().__init__(name, runtime)
        self.params = p = params or MarkerMapNodeParams()
        self.map = marker_map or MarkerMap(p.fusion, p.map_frame)
        self.packages = MarkerMap(p.fusion.updated(position_floor=p.package_position_floor,
                                                    min_sightings=p.package_min_sightings),
                                  p.map_frame)
        self._package_ids = set(p.package_ids)
        self.ignored_packages: set[int] = set()
        self._sent: dict[int, np.ndarray] = {}
        self.package_first_seen: dict[int, float] = {}
        """Stamp of the first image in which each package was detected."""
        self.package_in_cloud: dict[int, float] = {}
        self._cloud_ids: tuple[int, ...] = ()
        self.cloud_rings: dict[int, np.ndarray] = {}
        """The ring points (map frame) of each package in the last published cloud."""
        self.sightings = 0
        self.tf_drops = 0

    def on_configure(self) -> None:
        p = self.params
        self.filter: TfMessageFilter[ArucoMarkerArray, np.ndarray] = TfMessageFilter(
            self, self._lookup, self._on_placed, queue_size=30, timeout=p.transform_timeout,
            what="marker detections", on_drop=self._on_drop)
        self.create_subscription(p.markers_topic, ArucoMarkerArray, self.filter.add,
                                 QoS(depth=30))
        self.pub_tf_static = self.create_publisher("/tf_static", TFMessage,
                                                   QoS(depth=1, latched=True))
        self.pub_map = self.create_publisher(MARKER_MAP_TOPIC, ArucoMarkerArray, LATCHED)
        self.pub_viz = self.create_publisher(MARKER_MAP_VIZ_TOPIC, MarkerArray, LATCHED)
        self.pub_cloud = self.create_publisher(p.cloud_topic, PointCloud2, QoS(depth=1))
        self.pub_packages = self.create_publisher(PACKAGES_TOPIC, ArucoMarkerArray, LATCHED)
        self.bus.advertise_service("/marker_map/save", self._save)
        self.bus.advertise_service("/marker_map/load", self._load)
        self.bus.advertise_service(IGNORE_PACKAGE_SERVICE, self._ignore)
        if self._package_ids:
            self.create_timer(p.cloud_period, self.publish_cloud)

    def on_activate(self) -> None:
        if self.map.estimates():
            self._publish_markers()

    def on_cleanup(self) -> None:
        self.filter.clear()
        for service in ("/marker_map/save", "/marker_map/load", IGNORE_PACKAGE_SERVICE):
            self.bus.remove_service(service)

    # --- input ----------------------------------------------------------------------------
    def _lookup(self, msg: ArucoMarkerArray) -> np.ndarray:
        if not msg.markers:
            return np.eye(4)
        ts = self.tf.lookup(self.params.map_frame, msg.header.frame_id, msg.header.stamp)
        return transform_to_matrix(ts.transform)

    def _on_drop(self, msg: ArucoMarkerArray, reason: str) -> None:
        self.tf_drops += 1
        self.log.debug(reason)

    def _on_placed(self, msg: ArucoMarkerArray, map_from_camera: np.ndarray) -> None:
        changed: list[int] = []
        packages_changed = False
        r = map_from_camera[:3, :3]
        for m in msg.markers:
            if not np.all(np.isfinite(m.pose.covariance)):
                continue
            in_cam = pose_to_matrix(m.pose.pose)
            in_map = map_from_camera @ in_cam
            cov = r @ np.asarray(m.pose.covariance)[:3, :3] @ r.T
            ambiguity = 1.0 - float(m.confidence)  # the detector's confidence (aruco_msgs)
            sighting = Sighting(in_map[:3, 3].copy(), in_map[:3, :3].copy(), cov,
                                msg.header.stamp, ambiguity, float(np.linalg.norm(in_cam[:3, 3])))
            self.sightings += 1
            if m.id in self._package_ids:
                if m.id in self.ignored_packages and self.params.freeze_ignored:
                    continue
                before = self.packages.estimate(m.id)
                est = self.packages.add(m.id, sighting)
                if est is not None:
                    self.package_first_seen.setdefault(m.id, msg.header.stamp)
                if est is not None and est.published:
                    packages_changed |= before is None or not before.published or float(
                        np.linalg.norm(est.position - before.position)) > 0.02
                continue
            est = self.map.add(m.id, sighting)
            if est is not None and est.published and self._moved(est):
                changed.append(m.id)
        if changed:
            self._publish_markers(changed)
        if packages_changed:
            self.publish_cloud()

    def _moved(self, est: MarkerEstimate) -> bool:
        last = self._sent.get(est.id)
        if last is None:
            return True
        p = self.params
        return (float(np.linalg.norm(est.position - last[:3, 3])) > p.republish_distance
                or rotation_angle(est.rotation, last[:3, :3]) > p.republish_angle)

    # --- output ---------------------------------------------------------------------------
    def _publish_markers(self, changed: list[int] | None = None) -> None:
        p = self.params
        now = self.now
        estimates = self.map.estimates()
        ids = set(changed) if changed is not None else {e.id for e in estimates}
        tfs = []
        for e in estimates:
            if e.id in ids:
                tfs.append(TransformStamped(Header(now, p.map_frame), f"{p.frame_prefix}{e.id}",
                                            matrix_to_transform(e.matrix())))
                self._sent[e.id] = e.matrix()
        if tfs:
            self.pub_tf_static.publish(TFMessage(tuple(tfs)))
        head = Header(now, p.map_frame)
        self.pub_map.publish(ArucoMarkerArray(head, tuple(_aruco(e, head) for e in estimates)))
        self._publish_viz()

    def _publish_viz(self) -> None:
        head = Header(self.now, self.params.map_frame)
        markers = [m for e in self.map.estimates() for m in _visual(e, head)]
        for pid, (x, y) in self.package_centres().items():
            markers += _package_visual(pid, x, y, self.params.ring_diameter, head)
        self.pub_viz.publish(MarkerArray(tuple(markers)))

    def package_centres(self, include_ignored: bool = False) -> dict[int, tuple[float, float]]:
        """Estimated centre (x, y) of every published package (the ignored ones too with
        ``include_ignored``)."""
        out = {}
        for e in self.packages.estimates():
            if e.id in self.ignored_packages and not include_ignored:
                continue
            back = -self.params.package_depth * e.rotation[:, 2]
            out[e.id] = (float(e.position[0] + back[0]), float(e.position[1] + back[1]))
        return out

    def ignore_package(self, package_id: int) -> None:
        """Leave a package out of the cloud from now on (e.g. the one being carried)."""
        self.ignored_packages.add(int(package_id))
        self.publish_cloud()

    def publish_cloud(self) -> None:
        """The rings of every known package on ``cloud_topic`` (possibly empty)."""
        p = self.params
        centres = self.package_centres()
        pts = package_cloud(list(centres.values()), p.ring_diameter, p.ring_points,
                            p.ring_height)
        self.cloud_rings = {pid: pts[i * p.ring_points:(i + 1) * p.ring_points]
                            for i, pid in enumerate(centres)}
        for pid in centres:
            self.package_in_cloud.setdefault(pid, self.now)
        if tuple(centres) != self._cloud_ids:
            self._publish_viz()
        self._cloud_ids = tuple(centres)
        head = Header(self.now, p.map_frame)
        found = []
        every = self.package_centres(include_ignored=True)
        for e in self.packages.estimates():
            if e.id in every:
                m = e.matrix()
                m[:2, 3] = every[e.id]
                found.append(ArucoMarker(head, e.id, PoseWithCovariance(
                    matrix_to_pose(m), _cov6(e.covariance)), 1.0))
        self.pub_packages.publish(ArucoMarkerArray(head, tuple(found)))
        cols: dict[str, NDArray[np.generic]] = {c: pts[:, i].astype(np.float32)
                                                for i, c in enumerate("xyz")}
        self.pub_cloud.publish(PointCloud2.from_fields(Header(self.now, p.map_frame), cols))

    # --- services -------------------------------------------------------------------------
    def _ignore(self, package_id: int) -> bool:
        self.ignore_package(int(package_id))
        return True

    def _save(self, path: str | Path) -> str:
        return str(self.map.save(path))

    def _load(self, path: str | Path) -> int:
        loaded = MarkerMap.load(path, self.params.fusion)
        for e in loaded.estimates():
            self.map.add(e.id, Sighting(e.position, e.rotation, e.covariance, prior=True),
                         e.size)
        self._publish_markers()
        return len(loaded.estimates())


def _cov6(position_cov: np.ndarray) -> np.ndarray:
    cov = np.zeros((6, 6))
    cov[:3, :3] = position_cov
    cov[3:, 3:] = np.eye(3) * 1e-3
    return cov


def _aruco(e: MarkerEstimate, header: Header) -> ArucoMarker:
    return ArucoMarker(header, e.id, PoseWithCovariance(matrix_to_pose(e.matrix()),
                                                        _cov6(e.covariance)),
                       min(1.0, e.inliers / 10.0))


def _visual(e: MarkerEstimate, header: Header) -> tuple[Marker, Marker]:
    size = e.size or 0.1
    pose = matrix_to_pose(e.matrix())
    cube = Marker(header, "aruco_markers", e.id, Marker.CUBE, Marker.ADD, pose,
                  Vector3(size, size, 0.01), ColorRGBA(0.1, 0.6, 1.0, 0.9))
    text = Marker(header, "aruco_marker_ids", e.id, Marker.TEXT_VIEW_FACING, Marker.ADD,
                  Pose(Point(pose.position.x, pose.position.y, pose.position.z + max(size, 0.1))),
                  Vector3(0.15, 0.15, 0.15), ColorRGBA(1.0, 1.0, 1.0, 1.0),
                  text=f"aruco {e.id}")
    return cube, text


def _package_visual(pid: int, x: float, y: float, diameter: float, header: Header
                    ) -> tuple[Marker, Marker]:
    ring = Marker(header, "packages", pid, Marker.CYLINDER, Marker.ADD,
                  Pose(Point(x, y, 0.025)), Vector3(diameter, diameter, 0.05),
                  ColorRGBA(1.0, 0.6, 0.1, 0.6))
    text = Marker(header, "package_ids", pid, Marker.TEXT_VIEW_FACING, Marker.ADD,
                  Pose(Point(x, y, 0.25)), Vector3(0.12, 0.12, 0.12),
                  ColorRGBA(1.0, 1.0, 1.0, 1.0), text=f"package {pid}")
    return ring, text


__all__ = ["MarkerMapNode", "MarkerMapNodeParams"]
