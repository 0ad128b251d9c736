"""Shared scenes for the control tests: empty/obstacle costmaps and simple plans."""

from __future__ import annotations

import math

import numpy as np

from navstack.core.msgs import Path
from navstack.costmap.costmap_2d import Costmap2D


def straight_path(length: float = 3.0, y: float = 0.0, frame: str = "odom") -> Path:
    xs = np.arange(0.0, length + 1e-9, 0.05)
    return Path.from_array(np.column_stack((xs, np.full_like(xs, y), np.zeros_like(xs))),
                           frame_id=frame)


def left_arc(radius: float = 1.0, angle: float = math.pi / 2) -> Path:
    th = np.linspace(0.0, angle, 40)
    return Path.from_array(np.column_stack((radius * np.sin(th), radius - radius * np.cos(th),
                                            th)), frame_id="odom")


def empty_costmap(size: int = 100, resolution: float = 0.05) -> Costmap2D:
    half = size * resolution / 2.0
    return Costmap2D(size, size, resolution, -half, -half, frame_id="odom")
