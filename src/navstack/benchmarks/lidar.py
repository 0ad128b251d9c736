"""Lidar ray-casting benchmark (metric ``lidar_scan_ms``, budget 1.0 ms).

A 2000 x 2000 grid at 0.05 m (100 m x 100 m) is filled with realistic content —
boundary walls, long interior walls with gaps, and a few hundred boxes and pillars placed
by a seeded RNG — and a 360-beam scan (1 degree, range_max 30 m, two moving circles and a
moving box in view) is timed from several free poses.  The metric is the median over all
timed scans after numba warm-up.
"""

from __future__ import annotations

import math
import statistics
from typing import Any

import numpy as np

from navstack.benchmarks.common import time_ms
from navstack.sim.raycast import cast_rays
from navstack.sim.world_io import WorldSpec, rasterize

GRID_CELLS = 2000
RESOLUTION = 0.05
N_BEAMS = 360
RANGE_MAX = 30.0
BUDGET_MS = 1.0


def benchmark_spec(seed: int = 7) -> WorldSpec:
    """The benchmark world: 100 m square with walls, boxes and pillars (seeded)."""
    rng = np.random.default_rng(seed)
    size = GRID_CELLS * RESOLUTION
    walls = []
    for k in range(1, 6):  # a coarse grid of long walls with door gaps
        pos = k * size / 6.0
        for lo, hi in ((2.0, 30.0), (33.0, 64.0), (67.0, 98.0)):
            walls.append({"from": [pos, lo], "to": [pos, hi], "thickness": 0.2})
            walls.append({"from": [lo, pos], "to": [hi, pos], "thickness": 0.2})
    boxes = [{"center": rng.uniform(2.0, size - 2.0, 2).tolist(),
              "size": rng.uniform(0.4, 3.0, 2).tolist(),
              "yaw": float(rng.uniform(-math.pi, math.pi))} for _ in range(250)]
    circles = [{"center": rng.uniform(2.0, size - 2.0, 2).tolist(),
                "radius": float(rng.uniform(0.1, 0.6))} for _ in range(150)]
    return WorldSpec.model_validate({"name": "lidar_bench", "resolution": RESOLUTION,
                                     "size": [size, size], "boundary": True, "walls": walls,
                                     "boxes": boxes, "circles": circles})


def measure_lidar_scan_ms(quick: bool) -> tuple[float, dict[str, Any]]:
    """Median wall time [ms] of one 360-beam scan on the 2000x2000 benchmark grid.

    Returns ``(median_ms, details)``; details hold per-pose medians, the grid size, the
    mean measured range and the budget.
    """
    occ = rasterize(benchmark_spec())
    rng = np.random.default_rng(11)
    free = np.argwhere(~occ)
    n_poses, repeats = (4, 30) if quick else (12, 200)
    picks = free[rng.choice(len(free), n_poses, replace=False)]
    angles = np.linspace(-math.pi, math.pi, N_BEAMS, endpoint=False)
    out = np.empty(N_BEAMS)
    all_times: list[float] = []
    per_pose: list[dict[str, float]] = []
    mean_ranges: list[float] = []
    for r, c in picks:
        x, y = (c + 0.5) * RESOLUTION, (r + 0.5) * RESOLUTION
        theta = float(rng.uniform(-math.pi, math.pi))
        circles = np.array([[x + 3.0, y + 1.0, 0.3], [x - 4.0, y - 2.0, 0.4]])
        segments = np.array([[x + 1.0, y - 5.0, x + 2.0, y - 5.0],
                             [x + 2.0, y - 5.0, x + 2.0, y - 4.0],
                             [x + 2.0, y - 4.0, x + 1.0, y - 4.0],
                             [x + 1.0, y - 4.0, x + 1.0, y - 5.0]])

        def scan(x: float = x, y: float = y, theta: float = theta,
                 circles: np.ndarray = circles, segments: np.ndarray = segments) -> None:
            cast_rays(occ, 0.0, 0.0, RESOLUTION, x, y, theta, angles, 0.1, RANGE_MAX,
                      circles, segments, out)

        times = time_ms(scan, repeats, warmup=3)
        all_times.extend(times)
        finite = out[np.isfinite(out)]
        mean_ranges.append(float(finite.mean()) if finite.size else math.inf)
        per_pose.append({"x": x, "y": y, "theta": theta,
                         "median_ms": float(statistics.median(times))})
    median = float(statistics.median(all_times))
    details: dict[str, Any] = {
        "grid": [int(occ.shape[1]), int(occ.shape[0])], "resolution": RESOLUTION,
        "beams": N_BEAMS, "range_max": RANGE_MAX, "poses": per_pose,
        "mean_range_m": float(np.mean(mean_ranges)), "occupied_fraction": float(occ.mean()),
        "budget_ms": BUDGET_MS, "scans_timed": len(all_times),
    }
    return median, details
