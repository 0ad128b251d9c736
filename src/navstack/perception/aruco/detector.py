"""ArUco marker detection and pose estimation with OpenCV.

Detection is OpenCV's ``cv2.aruco.ArucoDetector`` (main package since OpenCV 4.7) with
sub-pixel corner refinement: ``CORNER_REFINE_SUBPIX``, then by default the edge-line fit
of :mod:`navstack.perception.aruco.refine` (``corner_refinement: lines``), which removes
the inward bias ``cornerSubPix`` has on small markers.  Any predefined dictionary works,
the original ArUco one (``DICT_ARUCO_ORIGINAL``) included.  Small candidates OpenCV
rejects get a second reading with sub-pixel corners
(:mod:`navstack.perception.aruco.small_markers`).  Each marker's pose comes from
``solvePnPGeneric`` with ``SOLVEPNP_IPPE_SQUARE`` (Collins & Bartoli, "Infinitesimal
Plane-Based Pose Estimation", IJCV 2014), which returns the two poses a planar square
admits; the one with the smaller reprojection error is reported, the ratio of the two
errors as ``ambiguity`` (near 1: the view cannot tell them apart, typical of small or
distant markers seen square-on).

``confidence`` (aruco_msgs) is ``(1 - ambiguity) * exp(-e^2 / (8 sigma^2))`` for a
reprojection error ``e`` [px]: low when the two poses fit alike or the fit is poor.

Covariance (6x6, camera frame, ROS order x, y, z, rot x, rot y, rot z): first-order
propagation of isotropic corner noise ``corner_sigma_px`` through the projection,
``sigma^2 (J^T J)^-1`` with ``J`` the 8x6 Jacobian of the four corners with respect to the
translation and a small rotation in the camera frame, scaled by ``covariance_scale``.  It
grows with distance as it should: lateral ~ z sigma / f, depth ~ z^2 sigma / (f s).

Parameter names follow ``aruco_detect`` / OpenCV's ``DetectorParameters`` (snake case).
Bad parameters -- an unknown dictionary, a marker size <= 0 -- are ConfigErrors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import cv2
import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from navstack.core.aruco_dictionaries import check_dictionary_name, get_dictionary, marker_count
from navstack.core.errors import ConfigError
from navstack.core.msgs.camera_msgs import Image
from navstack.core.params import Params
from navstack.perception.aruco.camera import PinholeCamera
from navstack.perception.aruco.image_input import to_gray
from navstack.perception.aruco.refine import refine_corners_lines
from navstack.perception.aruco.small_markers import decode_rejected

FloatArray = NDArray[np.float64]
_REFINEMENT = {"none": 0, "subpix": 1, "contour": 2, "apriltag": 3, "lines": 1}


class ArucoParams(Params):
    """ArUco detector parameters (aruco_detect / OpenCV ``DetectorParameters`` names).

    ``marker_size`` [m] is the side of the black square; ``marker_sizes`` overrides it per
    id (aruco_detect ``fiducial_len_override``); ``ids`` keeps only those ids (empty: all
    of the dictionary).  ``corner_sigma_px`` [px] is the corner noise assumed by the
    covariance.  Adaptive thresholding runs at one window size, 13 px (OpenCV: 3, 13 and
    23): on ``navstack bench aruco`` it finds the same markers from 0.5 to 4 m at a third
    of the time; widen ``adaptive_thresh_win_size_*`` for markers far outside that range.
    """

    dictionary: str = "DICT_4X4_50"
    marker_size: float = 0.1
    marker_sizes: dict[int, float] = Field(default_factory=dict)
    ids: list[int] = Field(default_factory=list)
    corner_refinement: Literal["none", "subpix", "contour", "apriltag", "lines"] = "lines"
    corner_refinement_win_size: int = Field(default=5, ge=1)
    relative_corner_refinement_win_size: float = Field(default=0.3, gt=0.0)
    corner_refinement_max_iterations: int = Field(default=30, ge=1)
    corner_refinement_min_accuracy: float = Field(default=0.01, gt=0.0)
    adaptive_thresh_win_size_min: int = Field(default=13, ge=3)
    adaptive_thresh_win_size_max: int = Field(default=13, ge=3)
    adaptive_thresh_win_size_step: int = Field(default=10, ge=1)
    adaptive_thresh_constant: float = 7.0
    min_marker_perimeter_rate: float = Field(default=0.03, gt=0.0)
    max_marker_perimeter_rate: float = Field(default=4.0, gt=0.0)
    polygonal_approx_accuracy_rate: float = Field(default=0.03, gt=0.0)
    min_distance_to_border: int = Field(default=3, ge=0)
    error_correction_rate: float = Field(default=0.6, ge=0.0, le=1.0)
    small_marker_pass: bool = True
    """navstack: re-read small rejected candidates with sub-pixel corners (small_markers)."""
    perspective_remove_pixel_per_cell: int = Field(default=4, ge=1)
    perspective_remove_ignored_margin_per_cell: float = Field(default=0.13, ge=0.0, lt=0.5)
    corner_sigma_px: float = Field(default=0.5, gt=0.0)
    covariance_scale: float = Field(default=1.0, gt=0.0)

    @field_validator("dictionary")
    @classmethod
    def _dictionary(cls, value: str) -> str:
        try:
            return check_dictionary_name(value)
        except ConfigError as exc:
            raise ValueError(f"{exc.reason} ({exc.suggestion})") from None

    @field_validator("marker_size")
    @classmethod
    def _size(cls, value: float) -> float:
        if not (value > 0.0 and math.isfinite(value)):
            raise ValueError(f"marker size must be > 0 m (the side of the black square), "
                             f"got {value}")
        return value

    @field_validator("marker_sizes")
    @classmethod
    def _sizes(cls, value: dict[int, float]) -> dict[int, float]:
        for marker_id, size in value.items():
            if not (size > 0.0 and math.isfinite(size)):
                raise ValueError(f"marker size of id {marker_id} must be > 0 m, got {size}")
        return value

    def size_of(self, marker_id: int) -> float:
        """The marker size [m] of ``marker_id``."""
        return self.marker_sizes.get(marker_id, self.marker_size)


@dataclass(frozen=True, eq=False)
class MarkerDetection:
    """A marker found in an image: id and corners ``(4, 2)`` [px] (OpenCV order)."""

    id: int
    corners: FloatArray


@dataclass(frozen=True, eq=False)
class MarkerPose:
    """A marker's pose in the camera (optical) frame: ``T_camera_marker``."""

    id: int
    corners: FloatArray
    size: float
    rotation: FloatArray
    translation: FloatArray
    covariance: FloatArray
    reprojection_error: float
    ambiguity: float
    confidence: float
    alternative: tuple[FloatArray, FloatArray] | None = None
    """The other IPPE solution ``(rotation, translation)``."""

    @property
    def distance(self) -> float:
        return float(np.linalg.norm(self.translation))

    def matrix(self) -> FloatArray:
        """4x4 ``T_camera_marker``."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.translation
        return out


@dataclass
class DetectionStats:
    """Counts over the frames processed; a frame without markers is counted, not an error."""

    frames: int = 0
    frames_without_markers: int = 0
    markers: int = 0
    pose_failures: int = 0
    by_id: dict[int, int] = field(default_factory=dict)


def _rotation(rvec: Any) -> FloatArray:
    return np.asarray(cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))[0], dtype=np.float64)


def marker_object_points(size: float) -> FloatArray:
    """The four corners ``(4, 3)`` of a marker of side ``size`` in its own frame (OpenCV
    order, the layout ``SOLVEPNP_IPPE_SQUARE`` requires)."""
    h = 0.5 * size
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def pose_covariance(rotation: FloatArray, translation: FloatArray, size: float,
                    camera: PinholeCamera, sigma_px: float) -> FloatArray:
    """6x6 covariance of ``T_camera_marker`` from corner noise (module docstring)."""
    points = marker_object_points(size) @ rotation.T  # R X, camera frame, about the origin
    p = points + translation
    jac = np.zeros((8, 6))
    for i in range(4):
        x, y, z = p[i]
        z = max(z, 1e-6)
        duv_dp = np.array([[camera.fx / z, 0.0, -camera.fx * x / (z * z)],
                           [0.0, camera.fy / z, -camera.fy * y / (z * z)]])
        rx, ry, rz = points[i]
        # d(R X)/d(delta) for R' = exp([delta]x) R: -[R X]x
        dp_drot = np.array([[0.0, rz, -ry], [-rz, 0.0, rx], [ry, -rx, 0.0]])
        jac[2 * i:2 * i + 2, :3] = duv_dp
        jac[2 * i:2 * i + 2, 3:] = duv_dp @ dp_drot
    info = jac.T @ jac
    try:
        cov = np.linalg.inv(info) * sigma_px ** 2
    except np.linalg.LinAlgError:
        cov = np.linalg.pinv(info) * sigma_px ** 2
    return np.asarray(0.5 * (cov + cov.T))


class ArucoDetector:
    """Detects markers and estimates their poses (see module docstring)."""

    def __init__(self, params: ArucoParams | None = None) -> None:
        self.params = params or ArucoParams()
        p = self.params
        self.dictionary = get_dictionary(p.dictionary)
        count = marker_count(p.dictionary)
        self._ids = set(p.ids)
        bad = sorted(i for i in self._ids if not 0 <= i < count)
        if bad:
            raise ConfigError(f"ids {bad} are not in {p.dictionary} (ids 0..{count - 1})",
                              key_path="ids")
        dp = cv2.aruco.DetectorParameters()
        dp.cornerRefinementMethod = _REFINEMENT[p.corner_refinement]
        dp.cornerRefinementWinSize = p.corner_refinement_win_size
        dp.relativeCornerRefinmentWinSize = p.relative_corner_refinement_win_size
        dp.cornerRefinementMaxIterations = p.corner_refinement_max_iterations
        dp.cornerRefinementMinAccuracy = p.corner_refinement_min_accuracy
        dp.adaptiveThreshWinSizeMin = p.adaptive_thresh_win_size_min
        dp.adaptiveThreshWinSizeMax = max(p.adaptive_thresh_win_size_max,
                                          p.adaptive_thresh_win_size_min)
        dp.adaptiveThreshWinSizeStep = p.adaptive_thresh_win_size_step
        dp.adaptiveThreshConstant = p.adaptive_thresh_constant
        dp.minMarkerPerimeterRate = p.min_marker_perimeter_rate
        dp.maxMarkerPerimeterRate = p.max_marker_perimeter_rate
        dp.polygonalApproxAccuracyRate = p.polygonal_approx_accuracy_rate
        dp.minDistanceToBorder = p.min_distance_to_border
        dp.errorCorrectionRate = p.error_correction_rate
        dp.perspectiveRemovePixelPerCell = p.perspective_remove_pixel_per_cell
        dp.perspectiveRemoveIgnoredMarginPerCell = p.perspective_remove_ignored_margin_per_cell
        self._detector = cv2.aruco.ArucoDetector(self.dictionary, dp)
        self._cells = int(self.dictionary.markerSize) + 2
        self.stats = DetectionStats()

    @staticmethod
    def from_mapping(data: dict[str, Any] | None, file: str = "",
                     key_path: str = "") -> ArucoDetector:
        return ArucoDetector(ArucoParams.from_mapping(data, file=file, key_path=key_path))

    # --- detection ----------------------------------------------------------------------
    def detect(self, image: Image | NDArray[np.generic]) -> list[MarkerDetection]:
        """Markers in ``image`` (sensor_msgs/Image or numpy; see ``image_input``)."""
        gray = to_gray(image)
        corners, ids, rejected = self._detector.detectMarkers(gray)
        found: list[tuple[int, FloatArray]] = []
        lines = self.params.corner_refinement == "lines"
        if ids is not None:
            for c, marker_id in zip(corners, ids.reshape(-1), strict=True):
                pts = np.asarray(c, dtype=np.float64).reshape(4, 2)
                if lines:
                    pts = refine_corners_lines(gray, pts, self._cells)
                found.append((int(marker_id), pts))
        if self.params.small_marker_pass and rejected is not None and len(rejected):
            found += decode_rejected(gray, rejected, self.dictionary, self._cells,
                                     self.params.error_correction_rate)
        return [MarkerDetection(mid, pts) for mid, pts in found
                if not self._ids or mid in self._ids]

    def estimate_pose(self, detection: MarkerDetection, camera: PinholeCamera
                      ) -> MarkerPose | None:
        """The marker's pose in the camera frame (``None`` if PnP finds none)."""
        p = self.params
        size = p.size_of(detection.id)
        obj = marker_object_points(size)
        img = np.ascontiguousarray(detection.corners, dtype=np.float64).reshape(4, 1, 2)
        try:
            n, rvecs, tvecs, errors = cv2.solvePnPGeneric(
                obj, img, camera.K, camera.D, flags=cv2.SOLVEPNP_IPPE_SQUARE)
        except cv2.error:
            return None
        if not n:
            return None
        errs = np.asarray(errors, dtype=np.float64).reshape(-1) if errors is not None \
            else np.zeros(n)
        order = np.argsort(errs)
        best = int(order[0])
        rot = _rotation(rvecs[best])
        t = np.asarray(tvecs[best], dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(t)) or t[2] <= 0.0:
            return None
        alt = None
        ambiguity = 0.0
        if n > 1:
            other = int(order[1])
            alt = (_rotation(rvecs[other]), np.asarray(tvecs[other], dtype=np.float64).reshape(3))
            ambiguity = float(errs[best] / errs[other]) if errs[other] > 0.0 else 1.0
        cov = pose_covariance(rot, t, size, camera, p.corner_sigma_px) * p.covariance_scale
        err = float(errs[best])
        # aruco_msgs confidence: low for an ambiguous pose or a poor fit
        confidence = (1.0 - ambiguity) * math.exp(-0.5 * (err / (2.0 * p.corner_sigma_px)) ** 2)
        return MarkerPose(detection.id, detection.corners, size, rot, t, cov, err, ambiguity,
                          confidence, alt)

    def process(self, image: Image | NDArray[np.generic], camera: PinholeCamera
                ) -> list[MarkerPose]:
        """Detect and estimate every marker of one frame; updates :attr:`stats`."""
        return self.poses_from_detections(self.detect(image), camera)

    def poses_from_detections(self, detections: list[MarkerDetection], camera: PinholeCamera
                              ) -> list[MarkerPose]:
        """Poses of given detections (e.g. a simulated camera's corners); updates stats."""
        s = self.stats
        s.frames += 1
        if not detections:
            s.frames_without_markers += 1
        out = []
        for det in detections:
            if self._ids and det.id not in self._ids:
                continue
            pose = self.estimate_pose(det, camera)
            if pose is None:
                s.pose_failures += 1
                continue
            s.markers += 1
            s.by_id[det.id] = s.by_id.get(det.id, 0) + 1
            out.append(pose)
        return out


__all__ = ["ArucoDetector", "ArucoParams", "DetectionStats", "MarkerDetection", "MarkerPose",
           "marker_object_points", "pose_covariance"]
