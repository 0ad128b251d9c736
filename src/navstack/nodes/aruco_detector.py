"""``ArucoDetectorNode``: ArUco markers from a camera on the bus (aruco_detect / aruco_ros).

Input (``input``):

* ``image`` -- sensor_msgs/Image on ``image_topic`` with sensor_msgs/CameraInfo on
  ``camera_info_topic`` (the latest info is used);
* ``vertices`` -- fiducial_msgs/FiducialArray on ``vertices_topic`` (a simulated camera in
  corners mode, or another detector) with the camera info.

Output: ``/fiducial_vertices`` (the corners, image input only), ``/aruco/markers``
(aruco_msgs/MarkerArray: poses with covariance in the camera's optical frame, one message
per frame, empty when no marker is seen) and, with ``publish_tf``, ``/tf``
``<optical frame> -> marker_<id>`` at the image's stamp.

Bad input never stops the node: an image of an unusable encoding or a CameraInfo with
zero focal length is counted (``bad_images``, ``bad_camera_info``), its reason kept in
``last_error`` and logged once; images before any valid CameraInfo are counted in
``waiting_for_camera_info``.  Frames without markers are counted by the detector
(``detector.stats.frames_without_markers``), not errors.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from navstack.core.errors import ConfigError, InvalidMessage
from navstack.core.msgs import (
    Header,
    PoseWithCovariance,
    TFMessage,
    TransformStamped,
)
from navstack.core.msgs.camera_msgs import CameraInfo, Image
from navstack.core.msgs.fiducial_msgs import (
    ArucoMarker,
    ArucoMarkerArray,
    Fiducial,
    FiducialArray,
)
from navstack.core.params import Params
from navstack.core.rotations import matrix_to_pose, matrix_to_transform
from navstack.perception.aruco import ArucoDetector, ArucoParams, MarkerDetection, PinholeCamera
from navstack.perception.aruco.detector import MarkerPose
from navstack.runtime.bus import SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime


class ArucoNodeParams(Params):
    """Topics and detector of the ArUco node (navstack; detector keys as aruco_detect)."""

    input: Literal["image", "vertices"] = "image"
    image_topic: str = "/camera/image_raw"
    camera_info_topic: str = "/camera/camera_info"
    vertices_topic: str = "/fiducial_vertices"
    markers_topic: str = "/aruco/markers"
    publish_tf: bool = True
    marker_frame_prefix: str = "marker_"
    detector: ArucoParams = Field(default_factory=ArucoParams)


def to_aruco_marker(pose: MarkerPose, header: Header) -> ArucoMarker:
    """aruco_msgs/Marker of a detector pose."""
    return ArucoMarker(header, pose.id, PoseWithCovariance(matrix_to_pose(pose.matrix()),
                                                           pose.covariance.copy()),
                       pose.confidence)


class ArucoDetectorNode(Node):
    """Detects markers in camera images (see module docstring)."""

    def __init__(self, runtime: Runtime, params: ArucoNodeParams | None = None,
                 name: str = "aruco_detector") -> None:
        super().__init__(name, runtime)
        self.params = params or ArucoNodeParams()
        self.detector = ArucoDetector(self.params.detector)
        self.camera: PinholeCamera | None = None
        self._info_key: tuple[tuple[float, ...], tuple[float, ...], int, int] | None = None
        self.bad_images = 0
        self.bad_camera_info = 0
        self.waiting_for_camera_info = 0
        self.last_error = ""
        self._seq = 0

    def on_configure(self) -> None:
        p = self.params
        self.create_subscription(p.camera_info_topic, CameraInfo, self._on_info, SENSOR_DATA)
        if p.input == "image":
            self.create_subscription(p.image_topic, Image, self._on_image, SENSOR_DATA)
            self.pub_vertices = self.create_publisher("/fiducial_vertices", FiducialArray,
                                                      QoS(depth=10))
        else:
            self.create_subscription(p.vertices_topic, FiducialArray, self._on_vertices,
                                     QoS(depth=10))
        self.pub_markers = self.create_publisher(p.markers_topic, ArucoMarkerArray,
                                                 QoS(depth=10))
        self.pub_tf = self.create_publisher("/tf", TFMessage, QoS(depth=100))

    def _error(self, message: str) -> None:
        if message != self.last_error:
            self.log.warning(message)
        self.last_error = message

    def _on_info(self, info: CameraInfo) -> None:
        key = (tuple(info.k), tuple(info.d), info.width, info.height)
        if key == self._info_key:
            return
        try:
            self.camera = PinholeCamera.from_camera_info(info, source=self.params.camera_info_topic)
        except ConfigError as exc:
            self.bad_camera_info += 1
            self.camera = None
            self._error(str(exc))
        self._info_key = key

    def _on_image(self, image: Image) -> None:
        if self.camera is None:
            self.waiting_for_camera_info += 1
            return
        try:
            detections = self.detector.detect(image)
        except InvalidMessage as exc:
            self.bad_images += 1
            self._error(str(exc))
            return
        if self.params.input == "image" and self.pub_vertices.subscription_count():
            self.pub_vertices.publish(FiducialArray(
                image.header, self._seq,
                tuple(Fiducial.from_corners(d.id, d.corners) for d in detections)))
        self._publish(image.header, detections)

    def _on_vertices(self, msg: FiducialArray) -> None:
        if self.camera is None:
            self.waiting_for_camera_info += 1
            return
        self._publish(msg.header, [MarkerDetection(f.fiducial_id, f.corners())
                                   for f in msg.fiducials])

    def _publish(self, header: Header, detections: list[MarkerDetection]) -> None:
        assert self.camera is not None
        self._seq += 1
        frame = header.frame_id or self.camera.frame_id
        head = Header(header.stamp, frame)
        poses = self.detector.poses_from_detections(detections, self.camera)
        self.pub_markers.publish(ArucoMarkerArray(head, tuple(to_aruco_marker(p, head)
                                                              for p in poses)))
        if self.params.publish_tf and poses:
            prefix = self.params.marker_frame_prefix
            self.pub_tf.publish(TFMessage(tuple(
                TransformStamped(head, f"{prefix}{p.id}", matrix_to_transform(p.matrix()))
                for p in poses if np.all(np.isfinite(p.translation)))))


__all__ = ["ArucoDetectorNode", "ArucoNodeParams", "to_aruco_marker"]
