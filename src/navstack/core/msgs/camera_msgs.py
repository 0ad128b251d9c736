"""sensor_msgs/Image and sensor_msgs/CameraInfo equivalents (ROS 2 field names).

``Image.data`` is the flat ``uint8`` buffer of ROS (``step * height`` bytes, row-major);
:meth:`Image.to_array` gives the numpy view ``(height, width)`` or ``(height, width,
channels)`` in the encoding's element type.  Encodings follow ``sensor_msgs/image_encodings``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import InvalidMessage
from navstack.core.msgs.std import Header

ENCODINGS: dict[str, tuple[str, int]] = {
    "mono8": ("u1", 1), "8UC1": ("u1", 1),
    "bgr8": ("u1", 3), "rgb8": ("u1", 3), "8UC3": ("u1", 3),
    "bgra8": ("u1", 4), "rgba8": ("u1", 4), "8UC4": ("u1", 4),
    "mono16": ("u2", 1), "16UC1": ("u2", 1),
    "32FC1": ("f4", 1),
}
"""``encoding -> (numpy element type, channels)`` of the encodings navstack reads."""


def _empty_u8() -> NDArray[np.uint8]:
    return np.zeros(0, dtype=np.uint8)


@dataclass(frozen=True, slots=True, eq=False)
class Image:
    """sensor_msgs/Image: ``height`` rows of ``step`` bytes in ``data`` (uint8)."""

    header: Header = field(default_factory=Header)
    height: int = 0
    width: int = 0
    encoding: str = ""
    is_bigendian: bool = False
    step: int = 0
    data: NDArray[np.uint8] = field(default_factory=_empty_u8)

    @staticmethod
    def from_array(array: NDArray[np.generic], encoding: str,
                   header: Header | None = None) -> Image:
        """An image holding ``array`` (``(h, w)`` or ``(h, w, c)``) in ``encoding``.

        Raises :class:`InvalidMessage` when the array's element type or channel count
        does not match the encoding.
        """
        if encoding not in ENCODINGS:
            raise InvalidMessage(f"unknown image encoding '{encoding}'; known: "
                                 f"{', '.join(ENCODINGS)}")
        kind, channels = ENCODINGS[encoding]
        arr = np.asarray(array)
        shape_ok = (arr.ndim == 2 and channels == 1) or (arr.ndim == 3
                                                         and arr.shape[2] == channels)
        if not shape_ok or arr.dtype.kind + str(arr.dtype.itemsize) != kind:
            raise InvalidMessage(f"an array of shape {arr.shape} and dtype {arr.dtype} is not "
                                 f"a '{encoding}' image (needs {channels} channel(s) of {kind})")
        arr = np.ascontiguousarray(arr, dtype=arr.dtype.newbyteorder("<"))
        h, w = arr.shape[:2]
        return Image(header or Header(), h, w, encoding, False, w * channels * arr.itemsize,
                     arr.reshape(-1).view(np.uint8))

    def to_array(self) -> NDArray[np.generic]:
        """The pixels as ``(height, width)`` or ``(height, width, channels)`` (a view).

        Raises :class:`InvalidMessage` for an unknown encoding or a buffer whose size
        does not match ``height``, ``width`` and ``step``.
        """
        if self.encoding not in ENCODINGS:
            raise InvalidMessage(f"image in '{self.header.frame_id}' has encoding "
                                 f"'{self.encoding}', which navstack cannot read; known: "
                                 f"{', '.join(ENCODINGS)}")
        kind, channels = ENCODINGS[self.encoding]
        dtype = np.dtype((">" if self.is_bigendian else "<") + kind)
        row = self.width * channels * dtype.itemsize
        data = np.asarray(self.data, dtype=np.uint8).reshape(-1)
        if self.step < row or data.size != self.step * self.height:
            raise InvalidMessage(f"'{self.encoding}' image {self.width}x{self.height} with "
                                 f"step {self.step} needs {self.step * self.height} bytes "
                                 f"(step >= {row}), got {data.size}")
        rows = data.reshape(self.height, self.step)[:, :row]
        pixels = np.ascontiguousarray(rows).view(dtype) if self.step != row else rows.view(dtype)
        shape = (self.height, self.width) if channels == 1 else (self.height, self.width,
                                                                 channels)
        return pixels.reshape(shape)


@dataclass(frozen=True, slots=True)
class RegionOfInterest:
    """sensor_msgs/RegionOfInterest (all zero: the full image)."""

    x_offset: int = 0
    y_offset: int = 0
    height: int = 0
    width: int = 0
    do_rectify: bool = False


def _identity9() -> tuple[float, ...]:
    return (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True, slots=True)
class CameraInfo:
    """sensor_msgs/CameraInfo: intrinsics ``k`` (3x3 row-major), distortion ``d`` for
    ``distortion_model`` (``plumb_bob``: k1, k2, p1, p2, k3), rectification ``r`` and
    projection ``p`` (3x4) of the image in ``header.frame_id`` (an optical frame:
    z forward, x right, y down)."""

    header: Header = field(default_factory=Header)
    height: int = 0
    width: int = 0
    distortion_model: str = "plumb_bob"
    d: tuple[float, ...] = ()
    k: tuple[float, ...] = (0.0,) * 9
    r: tuple[float, ...] = field(default_factory=_identity9)
    p: tuple[float, ...] = (0.0,) * 12
    binning_x: int = 0
    binning_y: int = 0
    roi: RegionOfInterest = field(default_factory=RegionOfInterest)

    def camera_matrix(self) -> NDArray[np.float64]:
        """``k`` as a 3x3 array."""
        return np.asarray(self.k, dtype=np.float64).reshape(3, 3)


__all__ = ["ENCODINGS", "CameraInfo", "Image", "RegionOfInterest"]
