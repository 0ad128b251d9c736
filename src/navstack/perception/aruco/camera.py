"""The calibrated camera a detection is measured with: intrinsics ``K`` and distortion.

Built from a sensor_msgs/CameraInfo (:meth:`PinholeCamera.from_camera_info`) or from a
ROS ``camera_calibration`` YAML file (:func:`load_camera_info`, the format
``camera_calibration`` and ``camera_info_manager`` write: ``image_width``,
``image_height``, ``camera_matrix: {rows, cols, data}``, ``distortion_model``,
``distortion_coefficients: {data}``, ...).  Every value is checked: a zero or negative
focal length, a principal point outside the image, an unsupported distortion model or a
wrong number of coefficients is a :class:`~navstack.core.errors.ConfigError` naming the
field and the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from navstack.core.errors import ConfigError
from navstack.core.msgs import Header
from navstack.core.msgs.camera_msgs import CameraInfo

FloatArray = NDArray[np.float64]
DISTORTION_MODELS = {"plumb_bob": (5,), "rational_polynomial": (8,), "": (0,)}
"""Distortion models OpenCV's pinhole functions take, with their coefficient counts."""


@dataclass(frozen=True, eq=False)
class PinholeCamera:
    """``K`` (3x3), distortion ``D`` (OpenCV order), image size and the optical frame."""

    K: FloatArray
    D: FloatArray
    width: int
    height: int
    frame_id: str = ""

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @staticmethod
    def create(K: Any, D: Any, width: int, height: int, frame_id: str = "", *,
               source: str = "", model: str = "plumb_bob") -> PinholeCamera:
        """Validated camera (see module docstring); ``source`` names the file or topic in
        errors."""
        k = np.asarray(K, dtype=np.float64)
        if k.size != 9:
            raise ConfigError(f"camera matrix K needs 9 values, got {k.size}", file=source,
                              key_path="k")
        k = k.reshape(3, 3)
        if not np.all(np.isfinite(k)):
            raise ConfigError("camera matrix K contains NaN or inf", file=source, key_path="k")
        if not (k[0, 0] > 0.0 and k[1, 1] > 0.0):
            raise ConfigError(f"focal lengths must be > 0 px, got fx={k[0, 0]}, fy={k[1, 1]}",
                              file=source, key_path="k",
                              suggestion="an all-zero CameraInfo means the camera is not "
                                         "calibrated; calibrate it (camera_calibration)")
        if int(width) <= 0 or int(height) <= 0:
            raise ConfigError(f"image size must be positive, got {width} x {height}",
                              file=source, key_path="width")
        if not (0.0 <= k[0, 2] <= width and 0.0 <= k[1, 2] <= height):
            raise ConfigError(f"principal point ({k[0, 2]}, {k[1, 2]}) lies outside the "
                              f"{width} x {height} image", file=source, key_path="k")
        if model not in DISTORTION_MODELS:
            raise ConfigError(f"distortion model '{model}' is not supported", file=source,
                              key_path="distortion_model",
                              suggestion="use plumb_bob or rational_polynomial")
        d = np.asarray(D, dtype=np.float64).reshape(-1)
        if d.size not in (0, 4, 5, 8, 12, 14):
            raise ConfigError(f"{d.size} distortion coefficients; OpenCV takes 4, 5, 8, 12 "
                              "or 14", file=source, key_path="d")
        if not np.all(np.isfinite(d)):
            raise ConfigError("distortion coefficients contain NaN or inf", file=source,
                              key_path="d")
        return PinholeCamera(k, d, int(width), int(height), frame_id)

    @staticmethod
    def from_camera_info(info: CameraInfo, source: str = "") -> PinholeCamera:
        """From a sensor_msgs/CameraInfo (raw image: ``k`` and ``d``)."""
        return PinholeCamera.create(info.k, info.d, info.width, info.height,
                                    info.header.frame_id,
                                    source=source or f"CameraInfo '{info.header.frame_id}'",
                                    model=info.distortion_model if info.d else "")

    def to_camera_info(self, stamp: float = 0.0) -> CameraInfo:
        """As a sensor_msgs/CameraInfo (plumb_bob for 5 coefficients)."""
        model = {5: "plumb_bob", 8: "rational_polynomial"}.get(self.D.size, "plumb_bob")
        p = (self.fx, 0.0, float(self.K[0, 2]), 0.0, 0.0, self.fy, float(self.K[1, 2]), 0.0,
             0.0, 0.0, 1.0, 0.0)
        return CameraInfo(Header(stamp, self.frame_id), self.height, self.width, model,
                          tuple(float(v) for v in self.D),
                          tuple(float(v) for v in self.K.reshape(-1)),
                          (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), p)

    def horizontal_fov(self) -> float:
        """Horizontal field of view [rad] of the undistorted pinhole."""
        return 2.0 * math.atan(0.5 * self.width / self.fx)


def _matrix(doc: dict[str, Any], key: str, source: str) -> list[float]:
    value = doc.get(key)
    if isinstance(value, dict):
        value = value.get("data")
    if not isinstance(value, list) or not all(isinstance(v, int | float) for v in value):
        raise ConfigError(f"'{key}' must be a list of numbers or {{rows, cols, data}}",
                          file=source, key_path=key)
    return [float(v) for v in value]


def load_camera_info(path: str | Path) -> PinholeCamera:
    """A camera from a ROS calibration YAML (``camera_calibration`` format) or a YAML
    holding CameraInfo fields (``width``, ``height``, ``k``, ``d``, ``distortion_model``).
    """
    p = Path(path)
    try:
        doc = yaml.safe_load(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError("camera info file not found", file=str(p),
                          suggestion="pass the calibration YAML written by "
                                     "camera_calibration") from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot read camera info: {exc}", file=str(p)) from None
    if not isinstance(doc, dict):
        raise ConfigError("a camera info file must be a mapping", file=str(p))
    source = str(p)
    if "camera_matrix" in doc:
        k = _matrix(doc, "camera_matrix", source)
        d = _matrix(doc, "distortion_coefficients", source) if (
            "distortion_coefficients" in doc) else []
        width, height = doc.get("image_width"), doc.get("image_height")
        size_keys = ("image_width", "image_height")
    else:
        k = _matrix(doc, "k", source)
        d = _matrix(doc, "d", source) if "d" in doc else []
        width, height = doc.get("width"), doc.get("height")
        size_keys = ("width", "height")
    for key, value in zip(size_keys, (width, height), strict=True):
        if not isinstance(value, int):
            raise ConfigError("image size must be an integer number of pixels", file=source,
                              key_path=key)
    model = str(doc.get("distortion_model", "plumb_bob" if d else ""))
    assert isinstance(width, int) and isinstance(height, int)
    return PinholeCamera.create(k, d, width, height, str(doc.get("camera_name", "")),
                                source=source, model=model if d else "")


__all__ = ["DISTORTION_MODELS", "PinholeCamera", "load_camera_info"]
