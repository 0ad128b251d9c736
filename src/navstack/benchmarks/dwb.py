"""DWB cycle-time benchmark: one ``compute`` on a 200x200 local costmap.

The scene is a 10 m x 10 m rolling-window costmap (0.05 m cells, robot at the centre)
with three boxes inflated by Nav2's exponential inflation (``cost_scaling_factor`` 3,
inflation radius 0.55 m, inscribed radius 0.18 m), a curved plan threading between them,
and the robot already moving (0.2 m/s, 0.1 rad/s) so the dynamic window is the usual
in-motion one.  Default sampling: 20 vx x 20 vtheta samples, ``sim_time`` 1.7 s,
0.05 m / 0.025 rad granularity.  Budget: 5 ms median (``navstack bench dwb``, metric
``dwb_cycle_ms``).
"""

from __future__ import annotations

import math
from pathlib import Path as FsPath

import numpy as np
from scipy import ndimage

from navstack.benchmarks.common import BenchResult, median_ms
from navstack.control.dwb.dwb_controller import DWBLocalPlanner
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    MAX_NON_OBSTACLE,
    Costmap2D,
)

DWB_CYCLE_BUDGET_MS = 5.0


def benchmark_scene(size: int = 200, resolution: float = 0.05) -> tuple[Costmap2D, Path, Pose2D,
                                                                        Twist2D]:
    """The benchmark's costmap (frame ``odom``), plan, robot pose and velocity."""
    half = size * resolution / 2.0
    lethal = np.zeros((size, size), dtype=bool)
    for x0, y0, x1, y1 in ((1.0, 0.6, 1.6, 1.6), (2.2, -1.5, 2.8, -0.5), (-2.0, -0.5, -1.2, 0.5)):
        i0, i1 = int((y0 + half) / resolution), int((y1 + half) / resolution)
        j0, j1 = int((x0 + half) / resolution), int((x1 + half) / resolution)
        lethal[i0:i1, j0:j1] = True
    dist = ndimage.distance_transform_edt(~lethal) * resolution
    inscribed, inflation, k = 0.18, 0.55, 3.0
    cost = np.where(dist <= inscribed, INSCRIBED_INFLATED_OBSTACLE,
                    np.where(dist <= inflation,
                             MAX_NON_OBSTACLE * np.exp(-k * (dist - inscribed)), 0.0))
    cost = np.where(lethal, LETHAL_OBSTACLE, cost).astype(np.uint8)
    costmap = Costmap2D.from_array(cost, resolution, -half, -half, frame_id="odom")
    s = np.linspace(0.0, 4.5, 91)
    xy = np.column_stack((s, 0.35 * np.sin(s * math.pi / 3.0)))
    yaw = np.arctan2(np.gradient(xy[:, 1]), np.gradient(xy[:, 0]))
    path = Path.from_array(np.column_stack((xy, yaw)), frame_id="odom")
    return costmap, path, Pose2D(0.0, 0.0, 0.3), Twist2D(0.2, 0.0, 0.1)


def measure_dwb_cycle_ms(repeats: int = 200) -> float:
    """Median wall time [ms] of one default-parameter DWB ``compute`` after warm-up."""
    costmap, path, pose, velocity = benchmark_scene()
    dwb = DWBLocalPlanner()
    dwb.set_plan(path)

    def cycle() -> Twist2D:
        return dwb.compute(pose, velocity, path, costmap, 0.0)

    return median_ms(cycle, repeats, warmup=5)


def run(quick: bool, data_dir: FsPath | None = None) -> BenchResult:
    """The ``dwb`` suite: ``dwb_cycle_ms`` (``data_dir`` is unused: the scene is synthetic)."""
    repeats = 30 if quick else 200
    ms = measure_dwb_cycle_ms(repeats)
    result = BenchResult("dwb")
    result.metrics["dwb_cycle_ms"] = ms
    result.cases.append({"case": "dwb_cycle", "median_ms": ms, "repeats": repeats,
                         "budget_ms": DWB_CYCLE_BUDGET_MS, "cells": 200 * 200,
                         "samples": 20 * 20, "within_budget": ms <= DWB_CYCLE_BUDGET_MS})
    return result
