"""Virtual obstacles for objects the lidar cannot see (TurtleBot course packages).

A package found by the camera becomes a ring of points around its position -- the course
used 25 points on a circle 0.3 m across at z = 0.05 m (0.1 m was above the obstacle
layer's height band, 0.0 on its edge) -- published as a PointCloud2 on ``/package_cloud``
and fed to the costmap's obstacle layer as a marking observation source, so planners
route around packages lower than the lidar plane.  The ring, not a disc, is what the
course published: the obstacle layer marks each point's cell and inflation fills the
inside.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
RING_POINTS = 25
RING_DIAMETER = 0.3
RING_HEIGHT = 0.05


def ring_points(x: float, y: float, diameter: float = RING_DIAMETER, count: int = RING_POINTS,
                z: float = RING_HEIGHT) -> FloatArray:
    """``(count, 3)`` points evenly spaced on a circle of ``diameter`` centred at ``(x, y)``."""
    if count < 3 or not diameter > 0.0:
        raise ValueError(f"a ring needs >= 3 points and a positive diameter, got {count}, "
                         f"{diameter}")
    a = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
    r = 0.5 * diameter
    return np.column_stack((x + r * np.cos(a), y + r * np.sin(a), np.full(count, z)))


def package_cloud(centres: FloatArray | list[tuple[float, float]],
                  diameter: float = RING_DIAMETER, count: int = RING_POINTS,
                  z: float = RING_HEIGHT) -> FloatArray:
    """All rings ``(len(centres) * count, 3)`` for package centres ``(n, 2)``."""
    c = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    if len(c) == 0:
        return np.zeros((0, 3))
    return np.vstack([ring_points(float(px), float(py), diameter, count, z) for px, py in c])


__all__ = ["RING_DIAMETER", "RING_HEIGHT", "RING_POINTS", "package_cloud", "ring_points"]
