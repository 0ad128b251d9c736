"""Footprints and footprint collision cost (Nav2 ``footprint.cpp``, ``FootprintCollisionChecker``).

Footprint parameters follow ``Costmap2DROS``: ``footprint`` (a Nav2 string
``"[[x, y], ...]"`` or a list of pairs; ``"[]"`` means "not set") takes precedence over
``robot_radius``; the chosen shape is then grown by ``footprint_padding`` (Nav2
``padFootprint``: every vertex moves ``padding`` outward along the signs of x and y; a
radius simply grows by ``padding``).

:func:`footprint_cost` is the collision check that controllers and behaviors use: the
maximum cost over every cell under the footprint, outline *and* interior (Nav2's
checker only walks the outline; the interior matters when an obstacle is smaller than
the robot, e.g. a freshly marked point under a large base).  Rules, in order:

* a footprint vertex outside the costmap -> ``LETHAL_OBSTACLE`` (Nav2: off the map is a
  collision);
* any ``LETHAL_OBSTACLE`` cell -> ``LETHAL_OBSTACLE``;
* otherwise any ``NO_INFORMATION`` cell -> ``NO_INFORMATION`` (255).  Since 255 >= 254,
  the usual test ``cost >= LETHAL_OBSTACLE`` treats unknown space as a collision; callers
  that may drive through unknown space (``allow_unknown``) test ``== NO_INFORMATION``;
* otherwise the maximum cost (``INSCRIBED_INFLATED_OBSTACLE`` 253 is returned as is).

Cells are rasterised in map coordinates: the outline with Bresenham lines between the
vertex cells, the interior as every cell whose centre lies inside the polygon (scanline
fill).  Both kernels are ``numba.njit``; :func:`footprint_costs` checks many poses in one
call (trajectory rollouts).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np
from numpy.typing import NDArray
from pydantic import field_validator

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.core.params import Params
from navstack.core.polygon import Footprint, parse_footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D

FloatArray = NDArray[np.float64]
PoseLike = Pose2D | Sequence[float] | FloatArray
FootprintLike = Footprint | FloatArray | Sequence[Sequence[float]]


class FootprintError(ConfigError):
    """The ``footprint`` parameter cannot be parsed into a polygon."""


class FootprintParams(Params):
    """Costmap2DROS footprint parameters (Nav2 names and defaults)."""

    footprint: str | list[list[float]] = "[]"
    robot_radius: float = 0.1
    footprint_padding: float = 0.01

    @field_validator("robot_radius")
    @classmethod
    def _positive_radius(cls, v: float) -> float:
        if v <= 0.0:
            raise ValueError("robot_radius must be > 0")
        return v


def make_footprint(footprint: str | Sequence[Sequence[float]] | FloatArray | None = None,
                   robot_radius: float = 0.1, footprint_padding: float = 0.01) -> Footprint:
    """The padded robot footprint from Nav2 parameters (polygon wins over radius)."""
    if isinstance(footprint, str):
        text = footprint.strip()
        if text and text != "[]":
            try:
                poly = parse_footprint(text)
            except ValueError as exc:
                raise FootprintError(str(exc), key_path="footprint",
                                     suggestion="use e.g. '[[0.2, 0.15], [0.2, -0.15], "
                                                "[-0.2, -0.15], [-0.2, 0.15]]'") from None
            return Footprint.from_polygon(poly, footprint_padding)
    elif footprint is not None and len(footprint) > 0:
        try:
            return Footprint.from_polygon(np.asarray(footprint, dtype=np.float64),
                                          footprint_padding)
        except ValueError as exc:
            raise FootprintError(str(exc), key_path="footprint") from None
    if robot_radius <= 0.0:
        raise FootprintError(f"robot_radius must be > 0, got {robot_radius}",
                             key_path="robot_radius")
    return Footprint.from_radius(robot_radius, footprint_padding)


def footprint_from_params(params: FootprintParams) -> Footprint:
    return make_footprint(params.footprint, params.robot_radius, params.footprint_padding)


def _as_pose(pose: PoseLike) -> tuple[float, float, float]:
    if isinstance(pose, Pose2D):
        return pose.x, pose.y, pose.theta
    a = np.asarray(pose, dtype=np.float64)
    return float(a[0]), float(a[1]), float(a[2])


def _as_polygon(footprint: FootprintLike) -> FloatArray:
    if isinstance(footprint, Footprint):
        return np.ascontiguousarray(footprint.polygon, dtype=np.float64)
    poly = np.ascontiguousarray(footprint, dtype=np.float64)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
        raise ValueError(f"footprint needs at least 3 [x, y] vertices, got shape {poly.shape}")
    return poly


def transform_footprint(footprint: FootprintLike, pose: PoseLike) -> FloatArray:
    """Footprint vertices placed at ``pose`` (x, y, yaw) in the costmap frame, ``(N, 2)``."""
    x, y, th = _as_pose(pose)
    poly = _as_polygon(footprint)
    c, s = math.cos(th), math.sin(th)
    return np.column_stack((x + c * poly[:, 0] - s * poly[:, 1],
                            y + s * poly[:, 0] + c * poly[:, 1]))


# --- numba kernels (map coordinates: u = (x - origin_x) / resolution) ---------------------
@numba.njit(cache=True)
def _raster_polygon(u: FloatArray, v: FloatArray, size_x: int, size_y: int,
                    out_x: NDArray[np.int64], out_y: NDArray[np.int64],
                    xs: FloatArray) -> int:
    """Write the cells under the polygon (outline + interior, clipped) into out; count.

    ``xs`` is scratch space of at least ``len(u)`` floats (scanline crossings).
    """
    n = u.shape[0]
    count = 0
    cap = out_x.shape[0]
    for k in range(n):  # outline: Bresenham between consecutive vertex cells
        x0 = math.floor(u[k])
        y0 = math.floor(v[k])
        x1 = math.floor(u[(k + 1) % n])
        y1 = math.floor(v[(k + 1) % n])
        dx = abs(x1 - x0)
        dy = -abs(y1 - y0)
        sx = 1 if x0 < x1 else -1
        sy = 1 if y0 < y1 else -1
        err = dx + dy
        while True:
            if 0 <= x0 < size_x and 0 <= y0 < size_y and count < cap:
                out_x[count] = x0
                out_y[count] = y0
                count += 1
            if x0 == x1 and y0 == y1:
                break
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                x0 += sx
            if e2 <= dx:
                err += dx
                y0 += sy
    vmin = v.min()
    vmax = v.max()
    j0 = max(0, math.floor(vmin))
    j1 = min(size_y - 1, math.floor(vmax))
    for j in range(j0, j1 + 1):  # interior: scanline through cell centres
        yc = j + 0.5
        m = 0
        for k in range(n):
            va = v[k]
            vb = v[(k + 1) % n]
            if (va <= yc < vb) or (vb <= yc < va):
                ua = u[k]
                ub = u[(k + 1) % n]
                xs[m] = ua + (yc - va) * (ub - ua) / (vb - va)
                m += 1
        for a in range(1, m):  # insertion sort: m is tiny (2 for a convex footprint)
            key = xs[a]
            b = a - 1
            while b >= 0 and xs[b] > key:
                xs[b + 1] = xs[b]
                b -= 1
            xs[b + 1] = key
        for p in range(0, m - 1, 2):
            i0 = max(0, math.ceil(xs[p] - 0.5))
            i1 = min(size_x - 1, math.floor(xs[p + 1] - 0.5))
            for i in range(i0, i1 + 1):
                if count < cap:
                    out_x[count] = i
                    out_y[count] = j
                    count += 1
    return count


@numba.njit(cache=True)
def _raster_capacity(u: FloatArray, v: FloatArray) -> int:
    n = u.shape[0]
    outline = n
    for k in range(n):
        outline += int(max(abs(u[(k + 1) % n] - u[k]), abs(v[(k + 1) % n] - v[k]))) + 2
    area = (int(u.max() - u.min()) + 3) * (int(v.max() - v.min()) + 3)
    return outline + area


@numba.njit(cache=True)
def _cells_cost(data: NDArray[np.uint8], xs: NDArray[np.int64], ys: NDArray[np.int64],
                count: int) -> int:
    best = 0
    unknown = False
    for k in range(count):
        c = data[ys[k], xs[k]]
        if c == 254:
            return 254
        if c == 255:
            unknown = True
        elif c > best:
            best = c
    return 255 if unknown else best


@numba.njit(cache=True)
def _poses_cost(data: NDArray[np.uint8], poly: FloatArray, poses: FloatArray, origin_x: float,
                origin_y: float, resolution: float) -> NDArray[np.int32]:
    size_y, size_x = data.shape
    n = poly.shape[0]
    out = np.empty(poses.shape[0], np.int32)
    u = np.empty(n, np.float64)
    v = np.empty(n, np.float64)
    scratch = np.empty(n, np.float64)
    buf_x = np.empty(0, np.int64)
    buf_y = np.empty(0, np.int64)
    for p in range(poses.shape[0]):
        c = math.cos(poses[p, 2])
        s = math.sin(poses[p, 2])
        outside = False
        for k in range(n):
            wx = poses[p, 0] + c * poly[k, 0] - s * poly[k, 1]
            wy = poses[p, 1] + s * poly[k, 0] + c * poly[k, 1]
            u[k] = (wx - origin_x) / resolution
            v[k] = (wy - origin_y) / resolution
            if not (0.0 <= u[k] < size_x and 0.0 <= v[k] < size_y):
                outside = True
        if outside:
            out[p] = 254
            continue
        cap = _raster_capacity(u, v)
        if cap > buf_x.shape[0]:
            buf_x = np.empty(cap, np.int64)
            buf_y = np.empty(cap, np.int64)
        cnt = _raster_polygon(u, v, size_x, size_y, buf_x, buf_y, scratch)
        out[p] = _cells_cost(data, buf_x, buf_y, cnt)
    return out


def footprint_costs(costmap: Costmap2D, poses: FloatArray, footprint: FootprintLike
                    ) -> NDArray[np.int32]:
    """:func:`footprint_cost` for each of ``poses`` ``(K, 3)`` (x, y, yaw); int32 ``(K,)``."""
    p = np.ascontiguousarray(np.atleast_2d(np.asarray(poses, dtype=np.float64)))
    if p.shape[1] != 3:
        raise ValueError(f"poses must have shape (K, 3), got {p.shape}")
    return _poses_cost(costmap.data, _as_polygon(footprint), p, costmap.origin_x,
                       costmap.origin_y, costmap.resolution)


def footprint_cost(costmap: Costmap2D, pose: PoseLike, footprint: FootprintLike) -> int:
    """Max cost under ``footprint`` placed at ``pose`` (rules in the module docstring)."""
    x, y, th = _as_pose(pose)
    return int(footprint_costs(costmap, np.array([[x, y, th]]), footprint)[0])


def polygon_cells(costmap: Costmap2D, polygon: FloatArray) -> tuple[NDArray[np.int64],
                                                                     NDArray[np.int64]]:
    """``(mx, my)`` of the cells under a world-frame polygon (outline + interior, clipped)."""
    poly = _as_polygon(polygon)
    u = (poly[:, 0] - costmap.origin_x) / costmap.resolution
    v = (poly[:, 1] - costmap.origin_y) / costmap.resolution
    cap = _raster_capacity(u, v)
    xs = np.empty(cap, np.int64)
    ys = np.empty(cap, np.int64)
    cnt = _raster_polygon(u, v, costmap.size_x, costmap.size_y, xs, ys,
                          np.empty(len(u), np.float64))
    return xs[:cnt], ys[:cnt]


def set_polygon_cost(costmap: Costmap2D, polygon: FloatArray, value: int) -> None:
    """Nav2 ``setConvexPolygonCost``: set every cell under ``polygon`` to ``value``."""
    xs, ys = polygon_cells(costmap, polygon)
    costmap.data[ys, xs] = value


__all__ = [
    "LETHAL_OBSTACLE", "NO_INFORMATION", "FootprintError", "FootprintParams",
    "footprint_cost", "footprint_costs", "footprint_from_params", "make_footprint",
    "polygon_cells", "set_polygon_cost", "transform_footprint",
]
