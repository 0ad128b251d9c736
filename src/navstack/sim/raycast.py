"""Lidar ray casting against an occupancy grid plus analytic circles and segments.

Grid traversal is the exact voxel walk of Amanatides & Woo, "A Fast Voxel Traversal
Algorithm for Ray Tracing" (Eurographics 1987): from the sensor's cell the ray steps to
whichever cell boundary (x or y) it crosses next, so every cell the ray passes through
is visited once and the reported range is the exact distance to the boundary of the
first occupied cell.  Beams that leave the grid stop there (nothing is hit); a sensor
outside the grid first clips its beam to the grid rectangle.  Moving obstacles are
circles ``(cx, cy, r)`` and line segments ``(x1, y1, x2, y2)`` intersected in closed
form; the nearest hit wins.

Range semantics follow ``sensor_msgs/LaserScan``: the true distance is returned, also
when it is below ``range_min`` (a sensor inside an obstacle reads 0); consumers discard
readings outside ``[range_min, range_max]``.  Nothing within ``range_max`` -> ``inf``.

The kernel is ``numba.njit(cache=True)`` and loops over beams itself; a call allocates
only its output array.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
_NO_CIRCLES = np.zeros((0, 3), dtype=np.float64)
_NO_SEGMENTS = np.zeros((0, 4), dtype=np.float64)


@njit(cache=True, nogil=True)
def _grid_hit(flat: NDArray[np.bool_], w: int, h: int, gx: float, gy: float, dx: float,
              dy: float, max_t: float) -> float:
    """Distance in cells from grid point ``(gx, gy)`` along unit ``(dx, dy)`` to the first
    occupied cell of the row-major ``flat`` grid (``h`` rows of ``w``), or ``inf`` if none
    within ``max_t`` cells / before the ray leaves the grid."""
    t = 0.0
    # Clip to the grid rectangle [0, w] x [0, h] (slab method) when starting outside it.
    if not (0.0 <= gx < w and 0.0 <= gy < h):
        t0, t1 = 0.0, math.inf
        if dx != 0.0:
            a, b = (0.0 - gx) / dx, (w - gx) / dx
            t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
        elif not 0.0 <= gx <= w:
            return math.inf
        if dy != 0.0:
            a, b = (0.0 - gy) / dy, (h - gy) / dy
            t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
        elif not 0.0 <= gy <= h:
            return math.inf
        if t0 >= t1 or t0 > max_t:
            return math.inf
        t = t0
    px, py = gx + t * dx, gy + t * dy
    ix = min(max(math.floor(px), 0), w - 1)
    iy = min(max(math.floor(py), 0), h - 1)
    # Per axis: index step, t of the next boundary, t between boundaries, and how many
    # more cells exist in that direction before the grid edge.
    if dx > 0.0:
        step_x, t_max_x, t_dx, left_x = 1, t + (ix + 1 - px) / dx, 1.0 / dx, w - 1 - ix
    elif dx < 0.0:
        step_x, t_max_x, t_dx, left_x = -1, t + (ix - px) / dx, -1.0 / dx, ix
    else:
        step_x, t_max_x, t_dx, left_x = 0, math.inf, math.inf, 0
    if dy > 0.0:
        step_y, t_max_y, t_dy, left_y = w, t + (iy + 1 - py) / dy, 1.0 / dy, h - 1 - iy
    elif dy < 0.0:
        step_y, t_max_y, t_dy, left_y = -w, t + (iy - py) / dy, -1.0 / dy, iy
    else:
        step_y, t_max_y, t_dy, left_y = 0, math.inf, math.inf, 0
    idx = iy * w + ix
    while True:
        if flat[idx]:
            return t
        if t_max_x < t_max_y:
            if left_x == 0:
                return math.inf
            t = t_max_x
            t_max_x += t_dx
            idx += step_x
            left_x -= 1
        else:
            if left_y == 0:
                return math.inf
            t = t_max_y
            t_max_y += t_dy
            idx += step_y
            left_y -= 1
        if t > max_t:
            return math.inf


@njit(cache=True, nogil=True)
def _circle_hit(x: float, y: float, dx: float, dy: float, circles: FloatArray,
                best: float) -> float:
    """Nearest ``t >= 0`` where the ray meets a circle (0 if it starts inside one)."""
    for k in range(circles.shape[0]):
        ex, ey, r = x - circles[k, 0], y - circles[k, 1], circles[k, 2]
        b = ex * dx + ey * dy
        c = ex * ex + ey * ey - r * r
        if c <= 0.0:
            return 0.0
        disc = b * b - c
        if disc < 0.0 or b > 0.0:  # misses, or circle is behind the sensor
            continue
        t = -b - math.sqrt(disc)
        if t < best:
            best = t
    return best


@njit(cache=True, nogil=True)
def _segment_hit(x: float, y: float, dx: float, dy: float, segments: FloatArray,
                 best: float) -> float:
    """Nearest ``t >= 0`` where the ray crosses a segment (parallel overlaps ignored)."""
    for k in range(segments.shape[0]):
        ax, ay = segments[k, 0], segments[k, 1]
        ex, ey = segments[k, 2] - ax, segments[k, 3] - ay
        den = dx * ey - dy * ex
        if den == 0.0:
            continue
        qx, qy = ax - x, ay - y
        t = (qx * ey - qy * ex) / den
        u = (qx * dy - qy * dx) / den
        if t >= 0.0 and 0.0 <= u <= 1.0 and t < best:
            best = t
    return best


@njit(cache=True, nogil=True)
def _cast_kernel(occ: NDArray[np.bool_], origin_x: float, origin_y: float, resolution: float,
                 x: float, y: float, theta: float, angles: FloatArray, range_max: float,
                 circles: FloatArray, segments: FloatArray, out: FloatArray) -> None:
    h, w = occ.shape
    flat = occ.reshape(h * w)
    gx, gy = (x - origin_x) / resolution, (y - origin_y) / resolution
    max_t = range_max / resolution
    for i in range(angles.shape[0]):
        a = theta + angles[i]
        dx, dy = math.cos(a), math.sin(a)
        best = _grid_hit(flat, w, h, gx, gy, dx, dy, max_t) * resolution
        if circles.shape[0] > 0:
            best = _circle_hit(x, y, dx, dy, circles, best)
        if segments.shape[0] > 0:
            best = _segment_hit(x, y, dx, dy, segments, best)
        out[i] = best if best <= range_max else math.inf


def cast_rays(occupied: NDArray[np.bool_], origin_x: float, origin_y: float, resolution: float,
              x: float, y: float, theta: float, angles: FloatArray, range_min: float,
              range_max: float, circles: FloatArray | None = None,
              segments: FloatArray | None = None, out: FloatArray | None = None) -> FloatArray:
    """Ranges ``float64[n]`` [m] from sensor ``(x, y)`` heading ``theta`` along
    ``theta + angles[i]``.

    ``occupied`` is ``bool[H, W]`` with row 0 at ``origin_y``; ``circles`` is ``(k, 3)``
    ``(cx, cy, r)`` and ``segments`` ``(m, 4)`` ``(x1, y1, x2, y2)`` in the same frame.
    ``inf`` where nothing is hit within ``range_max``.  ``range_min`` is *not* applied
    (LaserScan semantics: consumers discard ``r < range_min``); it is only checked.
    Pass ``out`` to reuse an output buffer; ``occupied`` should be C-contiguous (it is
    copied otherwise).
    """
    if not 0.0 <= range_min <= range_max:
        raise ValueError(f"need 0 <= range_min <= range_max, got {range_min}, {range_max}")
    if out is None:
        out = np.empty(angles.shape[0], dtype=np.float64)
    if not occupied.flags.c_contiguous:
        occupied = np.ascontiguousarray(occupied)
    _cast_kernel(occupied, float(origin_x), float(origin_y), float(resolution), float(x),
                 float(y), float(theta), angles, float(range_max),
                 _NO_CIRCLES if circles is None else circles,
                 _NO_SEGMENTS if segments is None else segments, out)
    return out
