"""``navstack bench slam-params``: how SLAM and costmap parameters change a mapping run.

The Nav2 lab's parameter study (chapter 3): one fixed simulated mapping run -- the office,
the diff-drive robot, seed 1, the waypoint route ``Goal_3 -> Goal_4`` with SLAM on and
navigation on the live map -- repeated while one parameter at a time moves away from its
default:

* slam_toolbox: ``minimum_travel_distance``, ``minimum_travel_heading``, ``resolution``,
  ``transform_publish_period``;
* costmaps (both): ``inflation_layer.inflation_radius``, ``inflation_layer.cost_scaling_factor``.

Each row reports the *mapping time* (simulated seconds to drive the route, and the wall
time of the run), *map completeness* (share of the world's free cells the map observed),
and *map error* (``1 - IoU`` of occupied cells vs the world raster, and the RMS absolute
trajectory error).  ``--quick`` drives ``Goal_3`` only and tries one value per parameter.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from navstack.benchmarks.common import BenchResult, Progress, no_progress

ROUTE = ("Goal_3", "Goal_4")
#: parameter -> values tried (the default is the baseline row)
SLAM_SWEEP: dict[str, tuple[float, ...]] = {
    "minimum_travel_distance": (0.2, 1.0),
    "minimum_travel_heading": (0.2, 1.0),
    "resolution": (0.025, 0.1),
    "transform_publish_period": (0.1, 0.5),
}
COSTMAP_SWEEP: dict[str, tuple[float, ...]] = {
    "inflation_layer.inflation_radius": (0.55, 1.0),
    "inflation_layer.cost_scaling_factor": (1.0, 5.0),
}


def run(quick: bool, data_dir: Path | None = None,
        progress: Progress = no_progress) -> BenchResult:
    """One baseline run plus one run per swept value (``data_dir`` is not used)."""
    from navstack.benchmarks.sim_mapping import run_sim_mapping

    route = ROUTE[:1] if quick else ROUTE
    result = BenchResult("slam-params", show_cases=True)
    runs: list[tuple[str, Any, dict[str, Any], dict[str, Any]]] = [("baseline", "", {}, {})]
    for name, values in SLAM_SWEEP.items():
        runs += [(name, v, {name: v}, {}) for v in values[: 1 if quick else None]]
    for name, values in COSTMAP_SWEEP.items():
        runs += [(name, v, {}, {name: v}) for v in values[: 1 if quick else None]]
    for i, (name, value, slam, costmap) in enumerate(runs):
        progress("parameter runs", i, len(runs))
        t0 = time.perf_counter()
        run_ = run_sim_mapping(slam, goals=route, costmap_overrides=costmap)
        wall = time.perf_counter() - t0
        reached = sum(status == "SUCCEEDED" for _, status, _ in run_.goals)
        result.cases.append({
            "parameter": name, "value": value, "mapping_time_s": round(run_.sim_time_s, 1),
            "wall_s": round(wall, 1), "completeness": round(run_.map.completeness, 3),
            "map_error": round(1.0 - run_.map.iou, 3), "ate_m": round(run_.ate_m, 4),
            "goals_reached": f"{reached}/{len(route)}", "nodes": run_.stats.scans_processed,
            "loop_closures": run_.stats.loop_closures, "collisions": run_.collisions})
        key = "baseline" if name == "baseline" else f"{name}={value:g}"
        result.metrics[f"{key}:map_error"] = 1.0 - run_.map.iou
        result.metrics[f"{key}:mapping_time_s"] = run_.sim_time_s
    progress("parameter runs", len(runs), len(runs))
    result.notes += [
        f"route {' -> '.join(route)} in the office, seed 1; one parameter changed per row",
        "map_error = 1 - IoU of occupied cells (0.05 m, 1 cell tolerance); completeness = "
        "share of the world's free cells observed; mapping_time_s = simulated seconds",
    ]
    return result
