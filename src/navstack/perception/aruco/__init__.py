"""ArUco markers: detection and pose (OpenCV), the camera model they are measured with,
and the marker map that fuses sightings in the ``map`` frame.

Pure algorithms (numpy + OpenCV, no bus): ``ArucoDetector(ArucoParams(...)).process(image,
camera)`` works in a notebook on any image.  The bus nodes live in ``navstack.nodes``.
"""

from navstack.perception.aruco.camera import PinholeCamera, load_camera_info
from navstack.perception.aruco.detector import (
    ArucoDetector,
    ArucoParams,
    DetectionStats,
    MarkerDetection,
    MarkerPose,
)
from navstack.perception.aruco.image_input import ImageEncodingError, to_gray

__all__ = ["ArucoDetector", "ArucoParams", "DetectionStats", "ImageEncodingError",
           "MarkerDetection", "MarkerPose", "PinholeCamera", "load_camera_info", "to_gray"]
