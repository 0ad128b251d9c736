"""How deep a footprint reaches into lethal cells: the escape rule for a robot that is
already "in collision" on its costmap.

A map can put an obstacle inside the robot's footprint while the real robot touches
nothing: SLAM drift moves a wall by a few centimetres, a grid cell bloats an obstacle
edge by up to one cell, a person walked past.  Nav2's collision checks (Regulated Pure
Pursuit, ``DriveOnHeading``/``BackUp``) then refuse *every* motion -- the first projected
pose already collides -- and the robot can never leave.  Nav2's own remedies are
footprint clearing (``footprint_clearing_enabled``) and the clear-costmap recovery; both
erase information.  navstack keeps the map and judges a motion that starts in collision
by whether it goes *deeper*:

* :func:`penetration_depth` -- for a convex footprint at a pose, the largest distance
  by which a lethal cell reaches inside it (cell centre's inside distance to the
  footprint outline plus half a cell, so a cell the rasteriser counts as touching has a
  positive depth); 0 when no lethal cell is under it.
* :func:`escape_allowed` -- a motion from a pose with depth ``d0 > 0`` is allowed when
  no pose along it has depth above ``d0 + tolerance``: driving along a wall that grazes
  the footprint keeps the depth, backing out of it lowers it, turning into it raises it.

Non-convex footprints are judged by their convex hull (a conservative superset).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D

FloatArray = NDArray[np.float64]

__all__ = ["escape_allowed", "inward_edges", "penetration_depth"]


def inward_edges(polygon: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(points, normals)`` of the convex hull's edges; normals point inwards, unit."""
    poly = np.asarray(polygon, dtype=np.float64)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
        raise ValueError(f"footprint needs at least 3 [x, y] vertices, got shape {poly.shape}")
    hull = _convex_hull(poly)
    nxt = np.roll(hull, -1, axis=0)
    edge = nxt - hull
    length = np.hypot(edge[:, 0], edge[:, 1])
    keep = length > 1e-12
    hull, edge, length = hull[keep], edge[keep], length[keep]
    normals = np.column_stack((-edge[:, 1], edge[:, 0])) / length[:, None]  # CCW: left = in
    return hull, normals


def _convex_hull(points: FloatArray) -> FloatArray:
    """Andrew's monotone chain, counter-clockwise."""
    pts = sorted({(float(x), float(y)) for x, y in points})
    if len(pts) < 3:
        raise ValueError("footprint has fewer than 3 distinct vertices")

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=np.float64)


def penetration_depth(costmap: Costmap2D, pose: Pose2D | Iterable[float],
                      footprint: FloatArray, lethal: int = LETHAL_OBSTACLE) -> float:
    """Largest depth [m] of a cell with cost ``>= lethal`` inside ``footprint`` (body
    frame vertices) at ``pose`` (costmap frame); 0.0 when none is under it."""
    if isinstance(pose, Pose2D):
        x, y, th = pose.x, pose.y, pose.theta
    else:
        x, y, th = (float(v) for v in pose)
    points, normals = inward_edges(footprint)
    res = costmap.resolution
    reach = float(np.hypot(points[:, 0], points[:, 1]).max()) + res
    i0 = max(0, math.floor((x - reach - costmap.origin_x) / res))
    i1 = min(costmap.size_x, math.floor((x + reach - costmap.origin_x) / res) + 1)
    j0 = max(0, math.floor((y - reach - costmap.origin_y) / res))
    j1 = min(costmap.size_y, math.floor((y + reach - costmap.origin_y) / res) + 1)
    if i0 >= i1 or j0 >= j1:
        return 0.0
    window = costmap.data[j0:j1, i0:i1]
    rows, cols = np.nonzero((window >= lethal) & (window != 255))
    if rows.size == 0:
        return 0.0
    wx = costmap.origin_x + (cols + i0 + 0.5) * res - x
    wy = costmap.origin_y + (rows + j0 + 0.5) * res - y
    c, s = math.cos(th), math.sin(th)
    bx = c * wx + s * wy  # cell centres in the body frame
    by = -s * wx + c * wy
    inside = ((bx[:, None] - points[:, 0]) * normals[:, 0]
              + (by[:, None] - points[:, 1]) * normals[:, 1]).min(axis=1)
    depth = float(inside.max()) + 0.5 * res
    return depth if depth > 0.0 else 0.0


def escape_allowed(costmap: Costmap2D, start: Pose2D | Iterable[float],
                   poses: Iterable[Iterable[float]], footprint: FloatArray,
                   tolerance: float = 0.005) -> tuple[bool, FloatArray | None]:
    """Is a motion from ``start`` through ``poses`` allowed by the escape rule (module
    docstring)?  Returns ``(allowed, first pose that goes deeper or None)``; from a pose
    with no penetration any penetration refuses."""
    d0 = penetration_depth(costmap, start, footprint)
    limit = d0 + tolerance if d0 > 0.0 else 0.0
    for row in poses:
        p = np.asarray(row, dtype=np.float64)
        if penetration_depth(costmap, p, footprint) > limit:
            return False, p
    return True, None
