"""Fiducial marker messages: ``fiducial_msgs`` vertices and ``aruco_msgs`` poses.

* :class:`Fiducial` / :class:`FiducialArray` -- ``fiducial_msgs/Fiducial(Array)`` (the
  ``aruco_detect`` package's ``/fiducial_vertices``): each marker's id and its four image
  corners ``(x0, y0) .. (x3, y3)`` [px] in OpenCV's order (top-left, top-right,
  bottom-right, bottom-left of the marker as printed).
* :class:`ArucoMarker` / :class:`ArucoMarkerArray` -- ``aruco_msgs/Marker(Array)``: each
  marker's pose with covariance in ``header.frame_id`` (the camera's optical frame from
  a detector, ``map`` from the marker map) and a ``confidence`` in [0, 1].

The marker frame is OpenCV's: origin at the marker centre, x to the right and y up as the
printed marker is read, z out of the marker towards the viewer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs.geometry_msgs import PoseWithCovariance
from navstack.core.msgs.std import Header

MARKER_MAP_TOPIC = "/aruco/marker_map"
"""aruco_msgs/MarkerArray of the fused markers in the map frame (latched)."""
MARKER_MAP_VIZ_TOPIC = "/aruco/marker_map/markers"
"""visualization_msgs/MarkerArray of the fused markers and packages (latched)."""
PACKAGES_TOPIC = "/aruco/packages"
"""aruco_msgs/MarkerArray of the packages found: each package's centre in the map frame
(orientation: its marker's), latched."""
IGNORE_PACKAGE_SERVICE = "/package_cloud/ignore"
"""Service: a package id -> True; the package leaves the package cloud (being gripped)."""


@dataclass(frozen=True, slots=True)
class Fiducial:
    """fiducial_msgs/Fiducial: one detected marker's id and image corners [px]."""

    fiducial_id: int = 0
    direction: int = 0
    x0: float = 0.0
    y0: float = 0.0
    x1: float = 0.0
    y1: float = 0.0
    x2: float = 0.0
    y2: float = 0.0
    x3: float = 0.0
    y3: float = 0.0

    @staticmethod
    def from_corners(fiducial_id: int, corners: NDArray[np.floating]) -> Fiducial:
        """From a ``(4, 2)`` corner array (OpenCV order)."""
        c = np.asarray(corners, dtype=np.float64).reshape(4, 2)
        return Fiducial(int(fiducial_id), 0, *(float(v) for v in c.reshape(-1)))

    def corners(self) -> NDArray[np.float64]:
        """The corners as a ``(4, 2)`` array [px]."""
        return np.array([[self.x0, self.y0], [self.x1, self.y1], [self.x2, self.y2],
                         [self.x3, self.y3]])


@dataclass(frozen=True, slots=True)
class FiducialArray:
    """fiducial_msgs/FiducialArray: the markers found in one image (possibly none)."""

    header: Header = field(default_factory=Header)
    image_seq: int = 0
    fiducials: tuple[Fiducial, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class ArucoMarker:
    """aruco_msgs/Marker: a marker's pose (with covariance) in ``header.frame_id``."""

    header: Header = field(default_factory=Header)
    id: int = 0
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    confidence: float = 1.0


@dataclass(frozen=True, slots=True, eq=False)
class ArucoMarkerArray:
    """aruco_msgs/MarkerArray: every marker seen in one image (possibly none)."""

    header: Header = field(default_factory=Header)
    markers: tuple[ArucoMarker, ...] = ()


__all__ = ["IGNORE_PACKAGE_SERVICE", "MARKER_MAP_TOPIC", "MARKER_MAP_VIZ_TOPIC", "PACKAGES_TOPIC",
           "ArucoMarker", "ArucoMarkerArray", "Fiducial", "FiducialArray"]
