"""Simple smoother (Nav2 ``nav2_smoother::SimpleSmoother``).

Gradient descent on each directional segment (cusps split the path, see
:mod:`navstack.planning.smoothers.common`): every interior pose moves toward its input
position (``w_data``) and toward the midpoint of its neighbours (``w_smooth``),

    y_i <- y_i + w_data (x_i - y_i) + w_smooth (y_{i+1} + y_{i-1} - 2 y_i),

updated in place (Gauss-Seidel, as Nav2), until the summed absolute change of an iteration
drops below ``tolerance``.  End points never move.  Then, with ``do_refinement``, the
result is smoothed again ``refinement_num`` times, each pass anchored to the previous
result.  As in Nav2, an iteration that reaches ``max_its`` or introduces a collision ends
the segment's smoothing with the last iterate before it (no refinement); the collision
rule is in :mod:`navstack.planning.smoothers.common`.  Segments of fewer than 5 poses are
left as they are (Nav2: ``end - start > 3``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.core.interfaces import Smoother
from navstack.core.msgs import Path
from navstack.core.plugins import register_smoother
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning import path_utils
from navstack.planning.smoothers.common import (
    CollisionGuard,
    SmootherTimedOut,
    find_directional_path_segments,
    point_blocked,
    seg_blocked,
    update_approximate_path_orientations,
)

FloatArray = NDArray[np.float64]

CONVERGED = 0
"""Kernel status: the change fell below ``tolerance``."""
MAX_ITS = 1
"""Kernel status: ``max_its`` reached; the last iterate is returned."""
COLLISION = 2
"""Kernel status: an update would introduce a collision; the last iterate is returned."""


class SimpleSmootherParams(path_utils.SimpleSmootherParams):
    """Nav2 ``SimpleSmoother`` parameters (names and defaults): ``tolerance``, ``max_its``,
    ``w_data``, ``w_smooth``, ``do_refinement``, ``refinement_num`` and
    ``enforce_path_inversion`` (smooth each directional segment on its own)."""

    enforce_path_inversion: bool = True


@nb.njit(cache=True)
def simple_smooth_kernel(orig: FloatArray, w_data: float, w_smooth: float, tolerance: float,
                         max_its: int, check: bool, weight: FloatArray,
                         pts0: NDArray[np.bool_], segs0: NDArray[np.bool_], ox: float,
                         oy: float, res: float, width: int,
                         height: int) -> tuple[FloatArray, int, int]:
    """One smoothing pass over ``orig`` ``(n, 2)``: ``(result, status, iterations)``.

    With ``check`` a pose entering a blocked cell, or a segment ``(i-1, i)`` entering one,
    that was free in the reference flags ``pts0``/``segs0`` stops the pass (COLLISION).
    """
    n = orig.shape[0]
    new = orig.copy()
    last = orig.copy()
    its = 0
    change = tolerance
    while change >= tolerance:
        its += 1
        change = 0.0
        if its >= max_its:
            return last, MAX_ITS, its
        for i in range(1, n - 1):
            for d in range(2):
                y = new[i, d]
                upd = y + w_data * (orig[i, d] - y) + w_smooth * (
                    new[i + 1, d] + new[i - 1, d] - 2.0 * y)
                new[i, d] = upd
                change += abs(upd - y)
            if check:
                if not pts0[i] and point_blocked(new[i, 0], new[i, 1], weight, ox, oy, res,
                                                 width, height):
                    return last, COLLISION, its
                if not segs0[i - 1] and seg_blocked(new[i - 1, 0], new[i - 1, 1], new[i, 0],
                                                    new[i, 1], weight, ox, oy, res, width,
                                                    height):
                    return last, COLLISION, its
        if check and not segs0[n - 2] and seg_blocked(
                new[n - 2, 0], new[n - 2, 1], new[n - 1, 0], new[n - 1, 1], weight, ox, oy,
                res, width, height):
            return last, COLLISION, its
        last[:, :] = new
    return new, CONVERGED, its


@register_smoother("SimpleSmoother", nav2="nav2_smoother::SimpleSmoother")
class SimpleSmoother(Smoother):
    """``smooth(path, costmap=None, max_time=None) -> Path`` (module docstring)."""

    params_model = SimpleSmootherParams
    params: SimpleSmootherParams

    def __init__(self, params: SimpleSmootherParams | Mapping[str, Any] | None = None) -> None:
        super().__init__(params if isinstance(params, SimpleSmootherParams)
                         else SimpleSmootherParams.from_mapping(params))
        self.last_status: list[int] = []
        """Kernel status of each pass of the last call (CONVERGED, MAX_ITS, COLLISION)."""

    def _smooth_segment(self, seg: FloatArray, costmap: Costmap2D | None) -> FloatArray:
        p = self.params
        xy = np.ascontiguousarray(seg[:, :2])
        if costmap is not None:
            guard = CollisionGuard(costmap, xy)
            weight, pts0, segs0, geo = guard.weight, guard.pts0, guard.segs0, guard.geo
        else:
            weight = np.zeros(1)
            pts0 = np.zeros(len(xy), dtype=np.bool_)
            segs0 = np.zeros(len(xy) - 1, dtype=np.bool_)
            geo = (0.0, 0.0, 1.0, 1, 1)
        passes = 1 + (p.refinement_num if p.do_refinement else 0)
        for _ in range(passes):
            xy, status, _its = simple_smooth_kernel(xy, p.w_data, p.w_smooth, p.tolerance,
                                                    p.max_its, costmap is not None, weight,
                                                    pts0, segs0, *geo)
            self.last_status.append(int(status))
            if status != CONVERGED:  # Nav2: no refinement after max_its or a collision
                break
        out = seg.copy()
        out[:, :2] = xy
        return out

    def smooth(self, path: Path, costmap: Costmap2D | None = None,
               max_time: float | None = None) -> Path:
        """The smoothed path (same poses count, same frame); end points and cusps fixed.

        ``costmap`` enables the collision rule; ``max_time`` [s] raises
        ``SmootherTimedOut`` when the budget runs out between segments or passes.
        """
        t0 = time.perf_counter()
        xyt = np.array(path.as_array(), dtype=np.float64)
        self.last_status = []
        if len(xyt) < 3:
            return path
        segments = (find_directional_path_segments(xyt) if self.params.enforce_path_inversion
                    else [(0, len(xyt) - 1)])
        for start, end in segments:
            if end - start <= 3:
                continue
            if max_time is not None and time.perf_counter() - t0 > max_time:
                raise SmootherTimedOut(
                    f"SimpleSmoother exceeded max_time {max_time:.3f} s after "
                    f"{len(self.last_status)} passes; raise the smoothing duration")
            seg = self._smooth_segment(xyt[start:end + 1], costmap)
            update_approximate_path_orientations(seg)
            xyt[start:end + 1] = seg
        return Path.from_array(xyt, frame_id=path.header.frame_id, stamp=path.header.stamp)
