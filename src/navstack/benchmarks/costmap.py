"""Costmap benchmark: full-map inflation and one rolling local costmap update.

Metrics (medians, milliseconds):

* ``inflation_2000_ms`` - InflationLayer.update_costs over a 2000 x 2000 grid at 0.05 m
  with 50 % of the cells LETHAL at random, ``inflation_radius`` 2.0 m (budget 50 ms);
* ``local_update_ms`` - ``LayeredCostmap.update_map`` of a 200 x 200 rolling costmap at
  0.05 m (obstacle layer marking + ray-trace clearing of one 360-beam scan, inflation
  0.55 m), the robot moving 2 cm per cycle with a fresh scan each cycle (budget 5 ms).

In the full (non-quick) run the case list also records ``scipy.ndimage.
distance_transform_edt`` on the same 2000 x 2000 mask, the alternative the inflation
kernel was measured against.
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from navstack.benchmarks.common import BenchResult
from navstack.core.msgs import Header, LaserScan, Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.costmap.inflation_layer import InflationLayer, InflationLayerParams
from navstack.costmap.layer import CellWindow
from navstack.costmap.layered_costmap import LayeredCostmap
from navstack.costmap.observation_buffer import ObservationSourceParams
from navstack.costmap.obstacle_layer import ObstacleLayer, ObstacleLayerParams

INFLATION_BUDGET_MS = 50.0
LOCAL_UPDATE_BUDGET_MS = 5.0


def _inflation_case(repeats: int, seed: int = 0) -> tuple[float, NDArray[np.uint8]]:
    n = 2000
    rng = np.random.default_rng(seed)
    base = np.where(rng.random((n, n)) < 0.5, LETHAL_OBSTACLE, 0).astype(np.uint8)
    lc = LayeredCostmap(n, n, 0.05, footprint=Footprint.from_radius(0.22))
    layer = InflationLayer("inflation_layer",
                           InflationLayerParams(inflation_radius=2.0, cost_scaling_factor=3.0))
    lc.add_plugin(layer)
    window = CellWindow(0, 0, n, n)
    times = []
    for i in range(repeats + 1):  # first call: warm-up (numba cache load)
        lc.costmap.data[:] = base
        t0 = time.perf_counter()
        layer.update_costs(lc.costmap, window)
        if i:
            times.append((time.perf_counter() - t0) * 1e3)
    return float(statistics.median(times)), base


def _scan(n: int, t: float) -> LaserScan:
    """A 360-beam scan of a room-like scene: ranges 0.8-2.8 m, a few beams with no return."""
    ang = -math.pi + np.arange(n) * (2 * math.pi / n)
    r = 1.8 + 0.7 * np.sin(3 * ang + t) + 0.3 * np.cos(7 * ang)
    r[::17] = np.inf
    return LaserScan(Header(t, "laser"), -math.pi, math.pi - 2 * math.pi / n, 2 * math.pi / n,
                     0.0, 0.1, 0.05, 12.0, r.astype(np.float32))


def _local_case(repeats: int) -> float:
    lc = LayeredCostmap(200, 200, 0.05, frame_id="odom", rolling_window=True,
                        footprint=Footprint.from_radius(0.22))
    src = ObservationSourceParams(max_obstacle_height=2.0, clearing=True, marking=True,
                                  inf_is_valid=True, obstacle_max_range=2.5,
                                  raytrace_max_range=3.0)
    obstacle = ObstacleLayer("obstacle_layer", ObstacleLayerParams(observation_sources="scan"),
                             {"scan": src})
    lc.add_plugin(obstacle)
    lc.add_plugin(InflationLayer("inflation_layer",
                                 InflationLayerParams(inflation_radius=0.55,
                                                      cost_scaling_factor=3.0)))
    times = []
    for i in range(repeats + 3):
        x = 0.02 * i
        scan = _scan(360, 0.1 * i)
        t0 = time.perf_counter()
        obstacle.add_scan(scan, Pose2D(x + 0.1, 0.0, 0.0), 0.2, "scan")
        lc.update_map(x, 0.0, 0.0, now=0.1 * i)
        if i >= 3:  # first cycles warm up (numba cache load, full-window first update)
            times.append((time.perf_counter() - t0) * 1e3)
    return float(statistics.median(times))


def run(quick: bool, data_dir: Path | None = None) -> BenchResult:
    """Run the costmap suite (``data_dir`` is unused: inputs are synthetic)."""
    result = BenchResult("costmap")
    infl_ms, base = _inflation_case(5 if quick else 15)
    result.metrics["inflation_2000_ms"] = infl_ms
    result.cases.append({"case": "inflation_2000", "median_ms": infl_ms,
                         "budget_ms": INFLATION_BUDGET_MS, "cells": 2000 * 2000,
                         "occupied_fraction": 0.5, "inflation_radius_m": 2.0,
                         "within_budget": infl_ms <= INFLATION_BUDGET_MS})
    local_ms = _local_case(30 if quick else 200)
    result.metrics["local_update_ms"] = local_ms
    result.cases.append({"case": "local_update", "median_ms": local_ms,
                         "budget_ms": LOCAL_UPDATE_BUDGET_MS, "cells": 200 * 200,
                         "beams": 360, "within_budget": local_ms <= LOCAL_UPDATE_BUDGET_MS})
    if not quick:
        from scipy.ndimage import distance_transform_edt

        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            distance_transform_edt(base != LETHAL_OBSTACLE)
            times.append((time.perf_counter() - t0) * 1e3)
        result.cases.append({"case": "scipy_edt_2000_reference",
                             "median_ms": float(statistics.median(times))})
        result.notes.append("scipy_edt_2000_reference: distance transform only, no costs")
    return result
