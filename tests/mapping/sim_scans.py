"""Scans drawn in a built-in world for the mapping tests: a 360-beam, 12 m lidar."""

from __future__ import annotations

import math

import numpy as np

from navstack.mapping.slam import LaserGeometry

ANGLES = np.linspace(-math.pi, math.pi, 360, endpoint=False)
LASER = LaserGeometry(ANGLES, 0.1, 12.0)


def ranges_at(world, pose) -> np.ndarray:
    """The noise-free ranges ``world`` gives at ``pose`` (x, y, yaw)."""
    return world.cast_rays(pose[0], pose[1], pose[2], ANGLES, 0.1, 12.0, 0.0)
