"""A second decoding pass for small markers that OpenCV finds but cannot read.

OpenCV reads a candidate's bits through a perspective warp defined by the corners of its
contour, which are whole pixels; on a marker 12-16 px wide (a 5 cm marker at 2 m) a cell
is about 2 px and a one-pixel corner error shifts the sampling grid by half a cell, so
valid markers end among the rejected candidates.  Here each small rejected candidate
gets sub-pixel corners from :func:`~navstack.perception.aruco.refine.refine_corners_lines`
first; each cell is then sampled at nine points in its central 40 % (bilinear), the
threshold is taken half way between the border's black and the brightest inner cells,
the border must be black (up to ``max_erroneous_border_rate`` of its cells may not), and
the bits are identified in the dictionary with OpenCV's ``Dictionary.identify`` (same
error correction as the main pass).  The identified rotation reorders the corners as
OpenCV does, so a marker from this pass is indistinguishable from one of the main pass.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from navstack.perception.aruco.refine import refine_corners_lines

FloatArray = NDArray[np.float64]
MIN_CONTRAST = 25.0
"""Smallest grey-level difference between the border and the white cells."""


@lru_cache(maxsize=16)
def _cell_samples(cells: int) -> NDArray[np.float32]:
    """Unit-square sample points ``(cells * cells * 9, 2)``: 3x3 per cell, row-major."""
    sub = np.array([-0.2, 0.0, 0.2])
    centres = (np.arange(cells) + 0.5) / cells
    v, u = np.meshgrid(centres, centres, indexing="ij")
    dv, du = np.meshgrid(sub / cells, sub / cells, indexing="ij")
    pts = np.stack((u[:, :, None, None] + du[None, None], v[:, :, None, None] + dv[None, None]),
                   axis=-1)
    out = np.ascontiguousarray(pts.reshape(-1, 1, 2), dtype=np.float32)
    out.setflags(write=False)
    return out


def read_bits(gray: NDArray[np.uint8], corners: FloatArray, cells: int,
              max_erroneous_border_rate: float = 0.35) -> NDArray[np.uint8] | None:
    """The inner ``(cells - 2)^2`` bits of the quad ``corners`` (white = 1), or ``None`` if
    the contrast is too low or the border is not black."""
    unit = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], dtype=np.float32)
    h = cv2.getPerspectiveTransform(unit, np.asarray(corners, dtype=np.float32))
    pts = cv2.perspectiveTransform(_cell_samples(cells), h)
    pts = pts.reshape(-1, 2)
    if (pts[:, 0].min() < 0 or pts[:, 1].min() < 0 or pts[:, 0].max() > gray.shape[1] - 1
            or pts[:, 1].max() > gray.shape[0] - 1):
        return None
    samples = cv2.remap(gray, pts[:, 0].reshape(1, -1), pts[:, 1].reshape(1, -1),
                        cv2.INTER_LINEAR).astype(np.float64)
    values = samples.reshape(cells, cells, 9).mean(axis=2)
    border = np.ones((cells, cells), dtype=bool)
    border[1:-1, 1:-1] = False
    black = float(np.median(values[border]))
    inner = values[1:-1, 1:-1]
    white = float(np.percentile(inner, 90))
    if white - black < MIN_CONTRAST:
        return None
    threshold = 0.5 * (black + white)
    wrong = int((values[border] > threshold).sum())
    if wrong > max_erroneous_border_rate * int(border.sum()):
        return None
    return np.ascontiguousarray(inner > threshold, dtype=np.uint8)


def decode_rejected(gray: NDArray[np.uint8], rejected: Any, dictionary: Any, cells: int,
                    error_correction_rate: float, max_perimeter_px: float = 200.0
                    ) -> list[tuple[int, FloatArray]]:
    """``(id, corners (4, 2))`` of the rejected candidates this pass can read."""
    found: list[tuple[int, FloatArray]] = []
    for cand in rejected:
        corners = np.asarray(cand, dtype=np.float64).reshape(4, 2)
        perimeter = float(np.linalg.norm(corners - np.roll(corners, -1, axis=0), axis=1).sum())
        if perimeter > max_perimeter_px:
            continue
        refined = refine_corners_lines(gray, corners, cells, max_shift_cells=0.75)
        bits = read_bits(gray, refined, cells)
        if bits is None:
            continue
        ok, marker_id, rotation = dictionary.identify(bits, error_correction_rate)
        if not ok:
            continue
        found.append((int(marker_id), np.roll(refined, int(rotation), axis=0)))
    return found


__all__ = ["decode_rejected", "read_bits"]
