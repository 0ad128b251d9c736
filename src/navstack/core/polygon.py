"""Polygons and robot footprints (Nav2 ``footprint`` / ``robot_radius`` semantics).

A footprint is an ``(N, 2)`` float array of vertices in ``base_link`` [m], in order
(either winding).  A circular robot is represented by a regular polygon approximating
its radius, plus the exact radius where callers can use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import se2_apply

FloatArray = NDArray[np.float64]


def circle_polygon(radius: float, n: int = 16) -> FloatArray:
    """Regular ``n``-gon circumscribing a circle of ``radius`` (so it never under-covers)."""
    if radius <= 0.0:
        raise ValueError(f"radius must be positive, got {radius}")
    r = radius / math.cos(math.pi / n)
    a = np.arange(n) * (2.0 * math.pi / n)
    return np.column_stack((r * np.cos(a), r * np.sin(a)))


def parse_footprint(text: str) -> FloatArray:
    """Parse Nav2's footprint string ``"[[x1, y1], [x2, y2], ...]"``."""
    import ast

    try:
        pts = np.asarray(ast.literal_eval(text), dtype=np.float64)
    except (ValueError, SyntaxError) as exc:
        raise ValueError(f"footprint '{text}' is not a list of [x, y] pairs") from exc
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise ValueError(f"footprint needs at least 3 [x, y] points, got {text}")
    return pts


def pad_polygon(poly: FloatArray, padding: float) -> FloatArray:
    """Nav2 ``footprint_padding``: move each vertex ``padding`` outward along x and y signs."""
    return poly + padding * np.sign(poly)


def polygon_area(poly: FloatArray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def point_segment_distance(points: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Distance from each of ``points`` (N, 2) to segment ``a``-``b``."""
    ab = b - a
    denom = float(ab @ ab)
    t = np.zeros(len(points)) if denom == 0.0 else np.clip((points - a) @ ab / denom, 0.0, 1.0)
    proj = a + t[:, None] * ab
    return np.hypot(points[:, 0] - proj[:, 0], points[:, 1] - proj[:, 1])


def points_in_polygon(points: FloatArray, poly: FloatArray) -> NDArray[np.bool_]:
    """Even-odd rule containment test for ``points`` (N, 2), vectorised over points."""
    x, y = points[:, 0], points[:, 1]
    inside = np.zeros(len(points), dtype=bool)
    n = len(poly)
    for i in range(n):  # loop over vertices (few), vectorised over points (many)
        x1, y1 = poly[i]
        x2, y2 = poly[(i + 1) % n]
        crosses = (y1 > y) != (y2 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (x < xint)
    return inside


@dataclass(frozen=True)
class Footprint:
    """A robot footprint: polygon in ``base_link`` plus derived radii.

    ``inscribed_radius`` is the largest circle about the origin inside the polygon and
    ``circumscribed_radius`` the smallest containing it (Nav2 costmap_2d semantics).
    """

    polygon: FloatArray
    radius: float | None = None  # set when built from robot_radius

    @staticmethod
    def from_radius(radius: float, padding: float = 0.0) -> Footprint:
        r = radius + padding
        return Footprint(circle_polygon(r), r)

    @staticmethod
    def from_polygon(poly: FloatArray | list[list[float]], padding: float = 0.0) -> Footprint:
        p = np.asarray(poly, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3:
            raise ValueError(f"footprint needs at least 3 [x, y] points, got shape {p.shape}")
        return Footprint(pad_polygon(p, padding) if padding else p)

    @property
    def inscribed_radius(self) -> float:
        if self.radius is not None:
            return self.radius
        n = len(self.polygon)
        origin = np.zeros((1, 2))
        return float(min(point_segment_distance(origin, self.polygon[i],
                                                self.polygon[(i + 1) % n])[0]
                         for i in range(n)))

    @property
    def circumscribed_radius(self) -> float:
        if self.radius is not None:
            return self.radius
        return float(np.max(np.hypot(self.polygon[:, 0], self.polygon[:, 1])))

    def at(self, pose: FloatArray | tuple[float, float, float]) -> FloatArray:
        """The polygon placed at ``pose`` (x, y, theta) in the parent frame."""
        return se2_apply(np.asarray(pose, dtype=np.float64), self.polygon)
