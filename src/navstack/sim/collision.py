"""Footprint collision and obstacle clearance in a simulated :class:`World`.

``footprint_collides`` is exact for the static grid: a footprint (any simple polygon)
collides with an occupied cell when the closed polygon and the closed cell square
intersect — some polygon edge meets the square (Liang-Barsky segment clipping) or the
square lies inside the polygon.  Only occupied cells inside the polygon's bounding box
are examined.  Moving obstacles are tested exactly as well: polygon-circle (centre
inside, or an edge within the radius) and polygon-polygon (an edge pair crosses, or a
vertex of one lies inside the other).  Touching counts as collision.  Space outside
the grid is free, as for the lidar.

``clearance`` is the exact Euclidean distance from a point to the nearest occupied cell
square, found by searching square rings of cells outwards until no nearer cell can
exist, combined with the distances to the moving obstacles at time ``t``.
``footprint_clearance`` is the same for a footprint polygon (0 when it touches): the
nearest vertex-edge pair between the polygon and each occupied cell square or moving
shape near it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from navstack.sim.world import MovingTime, World

FloatArray = NDArray[np.float64]

CLEARANCE_CAP = 3.0
"""Clearances beyond this [m] are reported as this value (demo and ``navstack report``)."""


@njit(cache=True, nogil=True)
def _point_in_polygon(px: float, py: float, poly: FloatArray) -> bool:
    """Even-odd rule; points on the boundary may go either way (callers test edges)."""
    inside = False
    n = poly.shape[0]
    j = n - 1
    for i in range(n):
        xi, yi, xj, yj = poly[i, 0], poly[i, 1], poly[j, 0], poly[j, 1]
        if (yi > py) != (yj > py) and px < xi + (py - yi) * (xj - xi) / (yj - yi):
            inside = not inside
        j = i
    return inside


@njit(cache=True, nogil=True)
def _segment_meets_box(x0: float, y0: float, x1: float, y1: float, bx0: float, by0: float,
                       bx1: float, by1: float) -> bool:
    """Liang-Barsky: does the closed segment meet the closed axis-aligned box?"""
    dx, dy = x1 - x0, y1 - y0
    u0, u1 = 0.0, 1.0
    for k in range(4):
        if k == 0:
            p, q = -dx, x0 - bx0
        elif k == 1:
            p, q = dx, bx1 - x0
        elif k == 2:
            p, q = -dy, y0 - by0
        else:
            p, q = dy, by1 - y0
        if p == 0.0:
            if q < 0.0:
                return False
        else:
            r = q / p
            if p < 0.0:
                u0 = max(u0, r)
            else:
                u1 = min(u1, r)
            if u0 > u1:
                return False
    return True


@njit(cache=True, nogil=True)
def polygon_hits_grid(occ: NDArray[np.bool_], origin_x: float, origin_y: float,
                      resolution: float, poly: FloatArray) -> bool:
    """True if the closed polygon ``(N, 2)`` intersects any occupied cell square."""
    h, w = occ.shape
    xmin, ymin = poly[:, 0].min(), poly[:, 1].min()
    xmax, ymax = poly[:, 0].max(), poly[:, 1].max()
    c0 = max(math.floor((xmin - origin_x) / resolution) - 1, 0)
    c1 = min(math.floor((xmax - origin_x) / resolution) + 1, w - 1)
    r0 = max(math.floor((ymin - origin_y) / resolution) - 1, 0)
    r1 = min(math.floor((ymax - origin_y) / resolution) + 1, h - 1)
    n = poly.shape[0]
    for r in range(r0, r1 + 1):
        by0 = origin_y + r * resolution
        by1 = by0 + resolution
        if by0 > ymax or by1 < ymin:
            continue
        for c in range(c0, c1 + 1):
            if not occ[r, c]:
                continue
            bx0 = origin_x + c * resolution
            bx1 = bx0 + resolution
            if bx0 > xmax or bx1 < xmin:
                continue
            for i in range(n):
                j = (i + 1) % n
                if _segment_meets_box(poly[i, 0], poly[i, 1], poly[j, 0], poly[j, 1],
                                      bx0, by0, bx1, by1):
                    return True
            if _point_in_polygon(bx0 + 0.5 * resolution, by0 + 0.5 * resolution, poly):
                return True
    return False


@njit(cache=True, nogil=True)
def _point_segment_dist(px: float, py: float, ax: float, ay: float, bx: float,
                        by: float) -> float:
    ex, ey = bx - ax, by - ay
    den = ex * ex + ey * ey
    u = 0.0 if den == 0.0 else min(max(((px - ax) * ex + (py - ay) * ey) / den, 0.0), 1.0)
    return math.hypot(px - ax - u * ex, py - ay - u * ey)


@njit(cache=True, nogil=True)
def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True, nogil=True)
def _segments_meet(a: FloatArray, i: int, j: int, b: FloatArray, k: int, m: int) -> bool:
    """Closed segments a[i]-a[j] and b[k]-b[m] intersect (collinear overlaps included)."""
    ax, ay, bx, by = a[i, 0], a[i, 1], a[j, 0], a[j, 1]
    cx, cy, dx, dy = b[k, 0], b[k, 1], b[m, 0], b[m, 1]
    d1 = _orient(cx, cy, dx, dy, ax, ay)
    d2 = _orient(cx, cy, dx, dy, bx, by)
    d3 = _orient(ax, ay, bx, by, cx, cy)
    d4 = _orient(ax, ay, bx, by, dx, dy)
    if ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and \
            ((d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0)):
        return True
    eps = 1e-12
    return ((abs(d1) <= eps and _point_segment_dist(ax, ay, cx, cy, dx, dy) <= eps)
            or (abs(d2) <= eps and _point_segment_dist(bx, by, cx, cy, dx, dy) <= eps)
            or (abs(d3) <= eps and _point_segment_dist(cx, cy, ax, ay, bx, by) <= eps)
            or (abs(d4) <= eps and _point_segment_dist(dx, dy, ax, ay, bx, by) <= eps))


@njit(cache=True, nogil=True)
def polygon_hits_moving(poly: FloatArray, circles: FloatArray, boxes: FloatArray) -> bool:
    """Closed polygon vs circles ``(k, 3)`` and convex/simple polygons ``(b, 4, 2)``."""
    n = poly.shape[0]
    for k in range(circles.shape[0]):
        cx, cy, r = circles[k, 0], circles[k, 1], circles[k, 2]
        if _point_in_polygon(cx, cy, poly):
            return True
        for i in range(n):
            j = (i + 1) % n
            if _point_segment_dist(cx, cy, poly[i, 0], poly[i, 1], poly[j, 0], poly[j, 1]) <= r:
                return True
    for b in range(boxes.shape[0]):
        box = boxes[b]
        m = box.shape[0]
        if _point_in_polygon(box[0, 0], box[0, 1], poly) or \
                _point_in_polygon(poly[0, 0], poly[0, 1], box):
            return True
        for i in range(n):
            for k in range(m):
                if _segments_meet(poly, i, (i + 1) % n, box, k, (k + 1) % m):
                    return True
    return False


@njit(cache=True, nogil=True)
def grid_clearance(occ: NDArray[np.bool_], origin_x: float, origin_y: float,
                   resolution: float, x: float, y: float, max_dist: float) -> float:
    """Exact distance [m] from ``(x, y)`` to the nearest occupied cell square, capped at
    ``max_dist`` (0 inside an occupied cell).  Searches rings of cells outwards."""
    h, w = occ.shape
    gx, gy = (x - origin_x) / resolution, (y - origin_y) / resolution
    ci, cj = math.floor(gx), math.floor(gy)
    best = max_dist / resolution
    max_ring = math.ceil(best) + 1
    lim = max(abs(ci), abs(ci - w), abs(cj), abs(cj - h)) + 1
    max_ring = min(max_ring, lim)
    for k in range(max_ring + 1):
        if k - 1 >= best:
            break
        for r in range(cj - k, cj + k + 1):
            if r < 0 or r >= h:
                continue
            edge_row = r == cj - k or r == cj + k
            step = 1 if edge_row else 2 * k
            c = ci - k
            while c <= ci + k:
                if 0 <= c < w and occ[r, c]:
                    ddx = max(c - gx, 0.0, gx - c - 1.0)
                    ddy = max(r - gy, 0.0, gy - r - 1.0)
                    d = math.hypot(ddx, ddy)
                    if d < best:
                        best = d
                if step == 0:
                    break
                c += step
    return min(best * resolution, max_dist)


def footprint_collides(world: World, polygon_world: FloatArray, t: MovingTime) -> bool:
    """True if the footprint polygon ``(N, 2)`` (world frame) touches an occupied cell or
    a moving obstacle at time ``t``."""
    poly = np.ascontiguousarray(polygon_world, dtype=np.float64)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
        raise ValueError(f"footprint polygon must have shape (N >= 3, 2), got {poly.shape}")
    if polygon_hits_grid(world.occupied, world.origin_x, world.origin_y, world.resolution, poly):
        return True
    if not world.moving_obstacles:
        return False
    circles, boxes = world.moving_shapes_at(t)
    return bool(polygon_hits_moving(poly, circles, boxes))


def clearance(world: World, x: float, y: float, t: MovingTime, max_dist: float) -> float:
    """Distance [m] from ``(x, y)`` to the nearest static or moving obstacle at time
    ``t``, capped at ``max_dist``; 0 when the point is inside an obstacle."""
    if not max_dist > 0.0 or not math.isfinite(max_dist):
        raise ValueError(f"max_dist must be positive and finite, got {max_dist}")
    d = float(grid_clearance(world.occupied, world.origin_x, world.origin_y, world.resolution,
                             float(x), float(y), float(max_dist)))
    if world.moving_obstacles and d > 0.0:
        circles, boxes = world.moving_shapes_at(t)
        if len(circles):
            dc = np.hypot(circles[:, 0] - x, circles[:, 1] - y) - circles[:, 2]
            d = min(d, max(0.0, float(dc.min())))
        for box in boxes:
            if _point_in_polygon(float(x), float(y), box):
                return 0.0
            for i in range(len(box)):
                a, b = box[i], box[(i + 1) % len(box)]
                d = min(d, float(_point_segment_dist(float(x), float(y), a[0], a[1], b[0], b[1])))
    return d


@njit(cache=True, nogil=True)
def _polygons_distance(a: FloatArray, b: FloatArray) -> float:
    """Distance between two disjoint closed polygons: the nearest vertex-edge pair."""
    best = math.inf
    for p, q in ((a, b), (b, a)):
        n = q.shape[0]
        for i in range(p.shape[0]):
            for k in range(n):
                m = (k + 1) % n
                d = _point_segment_dist(p[i, 0], p[i, 1], q[k, 0], q[k, 1], q[m, 0], q[m, 1])
                if d < best:
                    best = d
    return best


@njit(cache=True, nogil=True)
def grid_polygon_clearance(occ: NDArray[np.bool_], origin_x: float, origin_y: float,
                           resolution: float, poly: FloatArray, max_dist: float) -> float:
    """Exact distance [m] from the polygon to the nearest occupied cell square, capped at
    ``max_dist``, for a polygon that touches no occupied cell (test that first with
    :func:`polygon_hits_grid`).  Cells in the polygon's bounding box grown by
    ``max_dist`` are visited outwards from the box's centre, row by row and each row
    from the centre column out, and a direction stops at the first cell whose gap to
    the bounding box is already no nearer than the best distance so far (the gap only
    grows further out): the same minimum as visiting them all, a few rows instead of
    ``(2 max_dist / resolution)^2`` cells."""
    h, w = occ.shape
    x0 = math.floor((poly[:, 0].min() - max_dist - origin_x) / resolution)
    x1 = math.floor((poly[:, 0].max() + max_dist - origin_x) / resolution)
    y0 = math.floor((poly[:, 1].min() - max_dist - origin_y) / resolution)
    y1 = math.floor((poly[:, 1].max() + max_dist - origin_y) / resolution)
    r_lo, r_hi = max(y0, 0), min(y1, h - 1)
    c_lo, c_hi = max(x0, 0), min(x1, w - 1)
    best = max_dist
    if r_lo > r_hi or c_lo > c_hi:
        return best
    square = np.empty((4, 2))
    px0, px1 = poly[:, 0].min(), poly[:, 0].max()
    py0, py1 = poly[:, 1].min(), poly[:, 1].max()
    r_mid = min(max(math.floor((0.5 * (py0 + py1) - origin_y) / resolution), r_lo), r_hi)
    c_mid = min(max(math.floor((0.5 * (px0 + px1) - origin_x) / resolution), c_lo), c_hi)
    for r_step in (1, -1):
        r = r_mid if r_step == 1 else r_mid - 1
        while r_lo <= r <= r_hi:
            by0 = origin_y + r * resolution
            # the gap between the polygon's bounding box and a square bounds the
            # distance from below: a square that far cannot be the nearest
            gy = max(by0 - py1, py0 - (by0 + resolution), 0.0)
            if gy * gy >= best * best:
                break
            for c_step in (1, -1):
                c = c_mid if c_step == 1 else c_mid - 1
                while c_lo <= c <= c_hi:
                    bx0 = origin_x + c * resolution
                    gx = max(bx0 - px1, px0 - (bx0 + resolution), 0.0)
                    if gx * gx + gy * gy >= best * best:
                        break
                    if occ[r, c]:
                        square[0, 0], square[0, 1] = bx0, by0
                        square[1, 0], square[1, 1] = bx0 + resolution, by0
                        square[2, 0], square[2, 1] = bx0 + resolution, by0 + resolution
                        square[3, 0], square[3, 1] = bx0, by0 + resolution
                        best = min(best, _polygons_distance(poly, square))
                    c += c_step
            r += r_step
    return best


def footprint_clearances(world: World, polygon_world: FloatArray, t: MovingTime,
                         max_dist: float) -> tuple[float, float | None]:
    """``(static, moving)``: distance [m] from the footprint polygon ``(N, 2)`` (world
    frame) to the nearest static obstacle (occupied cell square) and to the nearest moving
    obstacle at time ``t`` (``None`` when the world has none), each capped at ``max_dist``
    and 0 when touching.  The one definition of clearance: the body's outline, not a circle
    about its reference point (which undercounts a long vehicle by metres)."""
    if not max_dist > 0.0 or not math.isfinite(max_dist):
        raise ValueError(f"max_dist must be positive and finite, got {max_dist}")
    poly = np.ascontiguousarray(polygon_world, dtype=np.float64)
    if polygon_hits_grid(world.occupied, world.origin_x, world.origin_y, world.resolution,
                         poly):
        static = 0.0
    else:
        static = float(grid_polygon_clearance(world.occupied, world.origin_x, world.origin_y,
                                              world.resolution, poly, float(max_dist)))
    if not world.moving_obstacles:
        return static, None
    circles, boxes = world.moving_shapes_at(t)
    return static, moving_clearance(poly, circles, boxes, max_dist)


def moving_clearance(poly: FloatArray, circles: FloatArray, boxes: FloatArray,
                     max_dist: float) -> float:
    """Distance [m] from the polygon to circles ``(k, 3)`` and boxes ``(b, 4, 2)``,
    capped at ``max_dist``; 0 when touching one."""
    poly = np.ascontiguousarray(poly, dtype=np.float64)
    circles = np.ascontiguousarray(circles, dtype=np.float64).reshape(-1, 3)
    boxes = np.ascontiguousarray(boxes, dtype=np.float64).reshape(-1, 4, 2)
    if polygon_hits_moving(poly, circles, boxes):
        return 0.0
    d = float(max_dist)
    for circle in circles:  # centre outside the polygon (no collision): edge distance
        centre = np.ascontiguousarray(circle[None, :2], dtype=np.float64)
        d = min(d, max(0.0, float(_polygons_distance(poly, centre)) - float(circle[2])))
    for box in boxes:
        d = min(d, float(_polygons_distance(poly, np.ascontiguousarray(box, np.float64))))
    return d


def footprint_clearance(world: World, polygon_world: FloatArray, t: MovingTime,
                        max_dist: float) -> float:
    """Distance [m] from the footprint polygon to the nearest static or moving obstacle
    (the smaller of :func:`footprint_clearances`)."""
    static, moving = footprint_clearances(world, polygon_world, t, max_dist)
    return static if moving is None else min(static, moving)


def polygons_distance(a: FloatArray, b: FloatArray, max_dist: float = math.inf) -> float:
    """Distance [m] between two closed simple polygons ``(N, 2)`` and ``(M, 2)`` (any vertex
    counts), 0 when they touch or overlap, capped at ``max_dist`` (robot-robot clearance
    in a fleet)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    if polygon_hits_moving(a, np.zeros((0, 3)), b[None]):
        return 0.0
    return min(float(max_dist), float(_polygons_distance(a, b)))
