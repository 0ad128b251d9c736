"""Images into the grey ``uint8`` arrays the ArUco detector works on.

Accepted: sensor_msgs/Image in ``mono8``/``8UC1``, ``bgr8``, ``rgb8``, ``bgra8``,
``rgba8`` (converted with OpenCV), or a numpy ``uint8`` array ``(h, w)`` / ``(h, w, 3)``
(BGR, as OpenCV reads files).  Anything else -- a 16-bit or float image, a depth image,
an empty one -- is an :class:`ImageEncodingError` saying what was given and what is
accepted.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import InvalidMessage
from navstack.core.msgs.camera_msgs import Image

ACCEPTED_ENCODINGS = ("mono8", "8UC1", "bgr8", "rgb8", "bgra8", "rgba8")
_CONVERSIONS = {"bgr8": cv2.COLOR_BGR2GRAY, "rgb8": cv2.COLOR_RGB2GRAY,
                "bgra8": cv2.COLOR_BGRA2GRAY, "rgba8": cv2.COLOR_RGBA2GRAY}


class ImageEncodingError(InvalidMessage):
    """An image the detector cannot read (wrong encoding, type or shape)."""


def to_gray(image: Image | NDArray[np.generic]) -> NDArray[np.uint8]:
    """A grey ``uint8`` view or copy of ``image`` (see module docstring)."""
    if isinstance(image, Image):
        if image.encoding not in ACCEPTED_ENCODINGS:
            raise ImageEncodingError(
                f"image in '{image.header.frame_id}' has encoding '{image.encoding}'; ArUco "
                f"detection needs an 8-bit image: {', '.join(ACCEPTED_ENCODINGS)}")
        if image.width == 0 or image.height == 0:
            raise ImageEncodingError(f"image in '{image.header.frame_id}' is empty "
                                     f"({image.width} x {image.height})")
        pixels = np.asarray(image.to_array(), dtype=np.uint8)
        code = _CONVERSIONS.get(image.encoding)
        return np.asarray(cv2.cvtColor(pixels, code) if code is not None else pixels,
                          dtype=np.uint8)
    arr = np.asarray(image)
    if arr.dtype != np.uint8:
        raise ImageEncodingError(f"image array has dtype {arr.dtype}; ArUco detection needs "
                                 "uint8 (mono8 or bgr8)")
    grey = np.asarray(arr, dtype=np.uint8)
    if grey.ndim == 2 and grey.size:
        return grey
    if grey.ndim == 3 and grey.shape[2] in (3, 4) and grey.size:
        code = cv2.COLOR_BGR2GRAY if grey.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        return np.asarray(cv2.cvtColor(grey, code), dtype=np.uint8)
    raise ImageEncodingError(f"image array of shape {arr.shape} is neither grey (h, w) nor "
                             "BGR (h, w, 3)")


__all__ = ["ACCEPTED_ENCODINGS", "ImageEncodingError", "to_gray"]
