"""What Nav2's smoothers share (``nav2_smoother`` / ``smoother_utils``), plus the
collision rule navstack's smoothers apply.

* :func:`find_directional_path_segments` (Nav2 ``findDirectionalPathSegments``): the
  path is cut at cusps (consecutive displacement vectors with a negative dot product)
  and at in-place rotations (two poses at the same point with different headings); each
  segment is smoothed on its own, so a cusp point never moves and a reversing manoeuvre
  keeps its shape.  The cusp index ends one segment and starts the next.
* :func:`update_approximate_path_orientations` (Nav2 ``updateApproximatePathOrientations``):
  after smoothing, every pose but the last of a segment points along the next
  displacement; a segment whose second pose faces away (> 90 deg) from its direction of
  travel is a reversing segment and its headings are flipped by pi.
* Collision rule (navstack): a cell blocks when its cost is ``INSCRIBED_INFLATED_OBSTACLE``
  (253) or ``LETHAL_OBSTACLE`` (254), or when it lies outside the costmap; unknown cells
  (255) do not block (Nav2's SimpleSmoother skips NO_INFORMATION).  Smoothing must never
  *introduce* a collision: a pose whose cell, or a segment between poses ``i`` and
  ``i + 1`` whose traversed cells (exact grid traversal), were free in the input must stay
  free.  When an update would break that, the smoother returns its last iterate before the
  update (Nav2's SimpleSmoother rule, here extended from pose cells to the segments
  between them and to the Savitzky-Golay passes).  Poses or segments already blocked in
  the input are left to the caller (:func:`navstack.planning.path_validity.is_path_valid`).
"""

from __future__ import annotations

import itertools
import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import PlannerTimeout
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION, Costmap2D
from navstack.planning.theta_star import segment_cost

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


class SmootherTimedOut(PlannerTimeout):
    """Smoothing exceeded its time budget (``nav2_core::SmootherTimedOut``)."""


def find_directional_path_segments(xyt: FloatArray) -> list[tuple[int, int]]:
    """``[(start, end), ...]`` index pairs (inclusive) of the directional segments."""
    n = len(xyt)
    if n < 3:
        return [(0, max(0, n - 1))]
    d = np.diff(xyt[:, :2], axis=0)
    oa, ab = d[:-1], d[1:]
    cusp = (oa[:, 0] * ab[:, 0] + oa[:, 1] * ab[:, 1]) < 0.0
    dtheta = np.angle(np.exp(1j * (xyt[2:, 2] - xyt[1:-1, 2])))
    rotation = (np.abs(ab[:, 0]) < 1e-4) & (np.abs(ab[:, 1]) < 1e-4) & (np.abs(dtheta) > 1e-4)
    # Nav2 appends a split for each rule separately (one index can split twice)
    cuts = np.repeat(np.arange(1, n - 1), cusp.astype(np.int64) + rotation.astype(np.int64))
    bounds = [0, *cuts.tolist(), n - 1]
    return list(itertools.pairwise(bounds))


def update_approximate_path_orientations(xyt: FloatArray) -> bool:
    """Set headings of one segment in place from its geometry; return "is reversing".

    ``xyt`` needs at least 3 poses.  Overlapping poses (< 1e-4 m apart in x and y) keep
    their heading; the last pose keeps its heading.
    """
    d = np.diff(xyt[:, :2], axis=0)
    theta = np.arctan2(d[:, 1], d[:, 0])
    reversing = abs(math.remainder(float(theta[1] - xyt[1, 2]), 2.0 * math.pi)) > math.pi / 2
    if reversing:
        theta = theta + math.pi
    moving = ~((np.abs(d[:, 0]) < 1e-4) & (np.abs(d[:, 1]) < 1e-4))
    idx = np.nonzero(moving)[0]
    xyt[idx, 2] = np.angle(np.exp(1j * theta[idx]))
    return reversing


def blocked_weights(costmap: Costmap2D) -> FloatArray:
    """Flat per-cell weights for :func:`segment_cost`: -1 where the collision rule blocks."""
    c = costmap.data.reshape(-1)
    blocked = (c >= INSCRIBED_INFLATED_OBSTACLE) & (c != NO_INFORMATION)
    return np.where(blocked, -1.0, 1.0)


@nb.njit(cache=True)
def point_blocked(x: float, y: float, weight: FloatArray, ox: float, oy: float, res: float,
                  width: int, height: int) -> bool:
    """True if world point ``(x, y)`` lies in a blocked cell or outside the grid."""
    cx = math.floor((x - ox) / res)
    cy = math.floor((y - oy) / res)
    if cx < 0 or cy < 0 or cx >= width or cy >= height:
        return True
    return weight[cy * width + cx] < 0.0


@nb.njit(cache=True)
def seg_blocked(x0: float, y0: float, x1: float, y1: float, weight: FloatArray, ox: float,
                oy: float, res: float, width: int, height: int) -> bool:
    """True if the world segment passes through a blocked cell (or leaves the grid)."""
    return segment_cost((x0 - ox) / res, (y0 - oy) / res, (x1 - ox) / res, (y1 - oy) / res,
                        weight, width, height) < 0.0


@nb.njit(cache=True)
def collision_flags(xy: FloatArray, weight: FloatArray, ox: float, oy: float, res: float,
                    width: int, height: int) -> tuple[BoolArray, BoolArray]:
    """``(pose_blocked[n], segment_blocked[n - 1])`` of an ``(n, 2)`` world polyline."""
    n = xy.shape[0]
    pts = np.zeros(n, dtype=np.bool_)
    segs = np.zeros(max(n - 1, 0), dtype=np.bool_)
    for i in range(n):
        pts[i] = point_blocked(xy[i, 0], xy[i, 1], weight, ox, oy, res, width, height)
    for i in range(n - 1):
        segs[i] = seg_blocked(xy[i, 0], xy[i, 1], xy[i + 1, 0], xy[i + 1, 1], weight, ox, oy,
                              res, width, height)
    return pts, segs


class CollisionGuard:
    """The collision rule for one path segment against one costmap (module docstring)."""

    def __init__(self, costmap: Costmap2D, reference_xy: FloatArray) -> None:
        self.weight = blocked_weights(costmap)
        self.geo = (costmap.origin_x, costmap.origin_y, costmap.resolution, costmap.size_x,
                    costmap.size_y)
        self.pts0, self.segs0 = collision_flags(np.ascontiguousarray(reference_xy),
                                                self.weight, *self.geo)

    def introduces_collision(self, xy: FloatArray) -> bool:
        """True if ``xy`` blocks a pose or segment that was free in the reference."""
        pts, segs = collision_flags(np.ascontiguousarray(xy), self.weight, *self.geo)
        return bool(np.any(pts & ~self.pts0) or np.any(segs & ~self.segs0))
