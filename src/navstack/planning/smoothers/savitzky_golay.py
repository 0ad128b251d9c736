"""Savitzky-Golay smoother (Nav2 ``nav2_smoother::SavitzkyGolaySmoother``).

Each directional segment (cusps split the path, see
:mod:`navstack.planning.smoothers.common`) is convolved, x and y separately, with the
Savitzky-Golay smoothing kernel of ``window_size`` points and polynomial order
``poly_order`` (Savitzky & Golay, Anal. Chem. 1964): the value at the centre of the
least-squares polynomial fitted to the window, i.e. row 0 of the pseudo-inverse of the
window's Vandermonde matrix.  Nav2's defaults (7 points, order 3) give
``[-2, 3, 6, 7, 6, 3, -2] / 21``.  Beyond the ends of a segment the window repeats the end
point (Nav2 clamps the index); the end points themselves never move.  With
``do_refinement`` the filter runs ``refinement_num`` more times on its own output.
Segments need ``end - start > window_size + 2`` (Nav2), i.e. at least 11 poses for 7.

The filter reproduces polynomials up to ``poly_order``: on a straight, evenly sampled
line every pose at least ``window_size // 2`` from an end (per pass) stays where it is,
and since each output is an affine combination of input points, every pose of any straight
line stays on that line.  Nav2 does not look at the costmap here; navstack applies the
collision rule of :mod:`~navstack.planning.smoothers.common` after every pass and keeps the
last pass that introduced no collision.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from navstack.core.interfaces import Smoother
from navstack.core.msgs import Path
from navstack.core.params import Params
from navstack.core.plugins import register_smoother
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning.smoothers.common import (
    CollisionGuard,
    SmootherTimedOut,
    find_directional_path_segments,
    update_approximate_path_orientations,
)

FloatArray = NDArray[np.float64]


class SavitzkyGolaySmootherParams(Params):
    """Nav2 ``SavitzkyGolaySmoother`` parameters (names and defaults)."""

    do_refinement: bool = True
    refinement_num: int = Field(2, ge=1)
    enforce_path_inversion: bool = True
    window_size: int = 7
    """Odd number of poses in the filter window, >= 3."""
    poly_order: int = Field(3, ge=1)
    """Order of the fitted polynomial, < window_size."""

    @model_validator(mode="after")
    def _check_window(self) -> Self:
        if self.window_size < 3 or self.window_size % 2 == 0:
            raise ValueError(f"window_size must be odd and >= 3, got {self.window_size}")
        if self.poly_order >= self.window_size:
            raise ValueError(f"poly_order ({self.poly_order}) must be smaller than "
                             f"window_size ({self.window_size})")
        return self


def savitzky_golay_coefficients(window_size: int, poly_order: int) -> FloatArray:
    """Smoothing coefficients ``(window_size,)``: row 0 of ``pinv(V)`` for the Vandermonde
    matrix ``V[i, k] = j_i ** k`` over offsets ``j = -h..h``."""
    h = (window_size - 1) // 2
    v = np.vander(np.arange(-h, h + 1, dtype=np.float64), poly_order + 1, increasing=True)
    return np.linalg.pinv(v)[0]


def savitzky_golay_pass(xy: FloatArray, coeffs: FloatArray) -> FloatArray:
    """One filter pass over ``(n, 2)`` points, ends fixed, index clamped at the ends."""
    n = len(xy)
    h = (len(coeffs) - 1) // 2
    padded = np.concatenate((np.repeat(xy[:1], h, axis=0), xy, np.repeat(xy[-1:], h, axis=0)))
    out = np.zeros_like(xy)
    for k, c in enumerate(coeffs):  # few taps, vectorised over the points
        out += c * padded[k:k + n]
    out[0], out[-1] = xy[0], xy[-1]
    return out


@register_smoother("SavitzkyGolaySmoother", nav2="nav2_smoother::SavitzkyGolaySmoother")
class SavitzkyGolaySmoother(Smoother):
    """``smooth(path, costmap=None, max_time=None) -> Path`` (module docstring)."""

    params_model = SavitzkyGolaySmootherParams
    params: SavitzkyGolaySmootherParams

    def __init__(self, params: SavitzkyGolaySmootherParams | Mapping[str, Any] | None = None
                 ) -> None:
        super().__init__(params if isinstance(params, SavitzkyGolaySmootherParams)
                         else SavitzkyGolaySmootherParams.from_mapping(params))
        self.coefficients = savitzky_golay_coefficients(self.params.window_size,
                                                        self.params.poly_order)
        self.reverted_passes = 0
        """Passes of the last call discarded by the collision rule."""

    def _smooth_segment(self, seg: FloatArray, costmap: Costmap2D | None) -> FloatArray:
        p = self.params
        xy = np.ascontiguousarray(seg[:, :2])
        guard = CollisionGuard(costmap, xy) if costmap is not None else None
        passes = 1 + (p.refinement_num if p.do_refinement else 0)
        for _ in range(passes):
            nxt = savitzky_golay_pass(xy, self.coefficients)
            if guard is not None and guard.introduces_collision(nxt):
                self.reverted_passes += 1
                break
            xy = nxt
        out = seg.copy()
        out[:, :2] = xy
        return out

    def smooth(self, path: Path, costmap: Costmap2D | None = None,
               max_time: float | None = None) -> Path:
        """The smoothed path (same poses count, same frame); end points and cusps fixed.

        ``costmap`` enables the collision rule; ``max_time`` [s] raises
        ``SmootherTimedOut`` when the budget runs out between segments.
        """
        t0 = time.perf_counter()
        xyt = np.array(path.as_array(), dtype=np.float64)
        self.reverted_passes = 0
        if len(xyt) < 3:
            return path
        segments = (find_directional_path_segments(xyt) if self.params.enforce_path_inversion
                    else [(0, len(xyt) - 1)])
        minimum = self.params.window_size + 2
        for start, end in segments:
            if end - start <= minimum:
                continue
            if max_time is not None and time.perf_counter() - t0 > max_time:
                raise SmootherTimedOut(
                    f"SavitzkyGolaySmoother exceeded max_time {max_time:.3f} s; raise the "
                    f"smoothing duration")
            seg = self._smooth_segment(xyt[start:end + 1], costmap)
            update_approximate_path_orientations(seg)
            xyt[start:end + 1] = seg
        return Path.from_array(xyt, frame_id=path.header.frame_id, stamp=path.header.stamp)
