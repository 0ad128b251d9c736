"""``navstack bench hybrid``: Smac Hybrid-A* speed, success and path guarantees.

Maps (real MovingAI game maps, rows flipped so north is +y, nearest-neighbour scaled to
0.05 m cells and inflated by :mod:`navstack.costmap.inflation_kernel` with Nav2's
InflationLayer costs):

* ``147k``: ``lak303d`` columns 0-95, rows 72-167 (from the bottom), 4x -> 384 x 384
  cells = 19.2 m square: rooms with pillars off a curved corridor;
* ``344k``: ``brc202d`` columns 0-146, rows 249-395, 3.99x -> 587 x 587 cells = 29.35 m
  square: a pillared hall, side rooms and a long corridor.

Robot: a 0.5 m x 0.4 m rectangle about ``base_link``, ``minimum_turning_radius`` 0.5 m,
REEDS_SHEPP (random goal headings in 1-2 m rooms often need a reversal, which a
forward-only car cannot make: with DUBIN about half of the random pairs are infeasible),
inflation radius 0.55 m with ``cost_scaling_factor`` 5, every other parameter at its Nav2
default (72 bins, 20 m lookup table, 3 m analytic expansions, smoothing on).  The lookup
table is filled before timing, as Nav2 does when the plugin is configured.

Campus: the golf cart (``sim/robots/golf_cart.yaml`` footprint with its padding) with
:func:`~navstack.planning.hybrid_astar.golf_cart_hybrid_params` plans from the spawn
point to the six campus waypoints on the 0.1 m campus world (1000 x 1000 cells),
inflated to 4 m (``cost_scaling_factor`` 1; beyond the cart's 2.8 m circumscribed radius
so the centre-cost shortcut applies), with ``downsample_costmap`` (factor 2), Nav2's
advice for large spaces.

Cases: start and goal poses are drawn uniformly among cells of cost <= 100 (about
0.4 m clear of walls) with uniform random headings, in the largest 8-connected region of
cells cheaper than INSCRIBED (2D reachability for the inscribed circle), at least 2 m
apart, with the footprint collision-free at both.  A pair is *feasible* when the planner
finds a path either under the Nav2 budget (``max_planning_time`` 5 s) or, failing that,
under a 30 s / unlimited-iteration reference budget; pairs the reference cannot solve
are kinematically infeasible for the footprint and radius (a doorway too narrow, a
pocket too tight to turn in) and are redrawn, and counted in the notes.  Every returned
path is checked with the exact references of :mod:`navstack.planning.hybrid_astar.checks`:
footprint overlap along the path densified to a quarter cell, and curvature (circle
through three consecutive poses, per direction segment) <= 1 / R, for the unsmoothed
lattice path and the smoothed output.

Metrics: ``hybrid_p95_ms_147k``, ``hybrid_median_ms_147k``, ``hybrid_p95_ms_344k``,
``hybrid_median_ms_344k`` (wall time of ``plan()``: search, smoothing and the Path
message; per pair the median of :data:`REPEATS` runs, each planning from scratch, since
``cache_obstacle_heuristic`` is off and only the distance table, filled before timing,
carries over), ``hybrid_success_rate`` (feasible pairs planned under the Nav2 budget),
``hybrid_min_turning_radius_ok`` and ``hybrid_collision_free`` (fractions of successful
plans; the returned, smoothed path), with ``_raw`` variants for the unsmoothed path;
``hybrid_campus_success_rate`` and ``hybrid_campus_median_ms`` for the golf cart.
"""

from __future__ import annotations

import contextlib
import math
import statistics
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from navstack.benchmarks.common import BenchResult, data_file
from navstack.core.errors import PlannerError
from navstack.core.msgs import Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    Costmap2D,
)
from navstack.costmap.footprint import make_footprint
from navstack.costmap.inflation_kernel import cell_distance, cost_lut, inflate
from navstack.planning.hybrid_astar import (
    HybridAStar,
    HybridAStarParams,
    golf_cart_hybrid_params,
    max_curvature,
    path_collision,
    pose_collision,
)
from navstack.planning.movingai import load_map
from navstack.sim.worlds import load_world

RESOLUTION = 0.05
ROBOT = Footprint.from_polygon([[0.25, 0.2], [0.25, -0.2], [-0.25, -0.2], [-0.25, 0.2]])
RADIUS = 0.5
INFLATION = (0.55, 5.0)
MAX_POSE_COST = 100
MIN_SEPARATION = 2.0
REFERENCE_TIME = 30.0
CASES = 50
QUICK_CASES = 10
CURVATURE_TOL = 1e-6
REPEATS = 3
"""Runs per pair; a pair's time is their median (the machines are noisy)."""


@dataclass(frozen=True)
class MapSpec:
    """A square window of a MovingAI map scaled to ``size`` cells."""

    name: str
    x0: int
    y0: int
    span: int
    size: int


MAPS = {"147k": MapSpec("lak303d", 0, 72, 96, 384), "344k": MapSpec("brc202d", 0, 249, 147, 587)}


def build_costmap(data_dir: Path | None, spec: MapSpec) -> Costmap2D:
    """The inflated 0.05 m costmap of a :class:`MapSpec` (origin at 0, 0); the map file
    comes from :func:`data_file` (``data_dir`` first, then the shipped data)."""
    path = data_file(f"movingai/{spec.name}.map", data_dir)
    passable = np.flipud(load_map(path))[spec.y0:spec.y0 + spec.span,
                                         spec.x0:spec.x0 + spec.span]
    idx = (np.arange(spec.size) * spec.span / spec.size).astype(int)
    data = np.where(passable[np.ix_(idx, idx)], 0, LETHAL_OBSTACLE).astype(np.uint8)
    r = cell_distance(INFLATION[0], RESOLUTION)
    lut = cost_lut(r, RESOLUTION, ROBOT.inscribed_radius, INFLATION[1])
    n = spec.size
    inflate(data, (0, 0, n, n), (0, 0, n, n), r, lut)
    return Costmap2D.from_array(data, RESOLUTION)


def planner(model: str = "REEDS_SHEPP", **overrides: Any) -> HybridAStar:
    params = HybridAStarParams.from_mapping({"minimum_turning_radius": RADIUS,
                                             "motion_model_for_search": model, **overrides})
    return HybridAStar(params, ROBOT, inflation=INFLATION)


class PoseSampler:
    """Random start/goal poses in the largest 2D-reachable region (see module doc)."""

    def __init__(self, costmap: Costmap2D, seed: int) -> None:
        self.costmap = costmap
        free = costmap.data < INSCRIBED_INFLATED_OBSTACLE
        labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        ok = (labels == int(sizes.argmax())) & (costmap.data <= MAX_POSE_COST)
        self.cells = np.argwhere(ok)
        self.rng = np.random.default_rng(seed)

    def pose(self) -> Pose2D:
        while True:
            my, mx = self.cells[self.rng.integers(len(self.cells))]
            x, y = self.costmap.map_to_world(int(mx), int(my))
            p = Pose2D(x, y, float(self.rng.uniform(-math.pi, math.pi)))
            if pose_collision(self.costmap, ROBOT.polygon, (p.x, p.y, p.theta)) is None:
                return p

    def pair(self) -> tuple[Pose2D, Pose2D]:
        while True:
            s, g = self.pose(), self.pose()
            if s.distance_to(g) >= MIN_SEPARATION:
                return s, g


def _check(plan_raw: NDArray[np.float64], plan_out: NDArray[np.float64],
           direction: NDArray[np.int8], costmap: Costmap2D, radius: float = RADIUS,
           footprint: Footprint = ROBOT) -> dict[str, bool]:
    limit = (1.0 / radius) * (1.0 + CURVATURE_TOL)
    return {"curv_raw": max_curvature(plan_raw, direction) <= limit,
            "curv": max_curvature(plan_out, direction) <= limit,
            "free_raw": path_collision(plan_raw, costmap, footprint.polygon) == -1,
            "free": path_collision(plan_out, costmap, footprint.polygon) == -1}


def run_map(key: str, costmap: Costmap2D, n_cases: int, model: str, seed: int
            ) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Plan ``n_cases`` feasible random pairs on one map; the summary row and cases."""
    pl = planner(model)
    ref = planner(model, max_planning_time=REFERENCE_TIME, max_iterations=-1)
    t0 = time.perf_counter()
    pl.prepare(costmap)
    ref.prepare(costmap)
    prepare_s = time.perf_counter() - t0
    sampler = PoseSampler(costmap, seed)
    warm_s, warm_g = sampler.pair()
    for p in (pl, ref):  # compile / load the kernels and touch every buffer once
        with contextlib.suppress(PlannerError):
            p.plan(warm_s, warm_g, costmap)
    cases: list[dict[str, Any]] = []
    rejected = 0
    while len(cases) < n_cases:
        start, goal = sampler.pair()
        row: dict[str, Any] = {"map": key, "model": model, "start": [start.x, start.y, start.theta],
                               "goal": [goal.x, goal.y, goal.theta]}
        t = time.perf_counter()
        try:
            plan = pl.plan_detailed(start, goal, costmap)
            runs = [(time.perf_counter() - t) * 1e3]
            for _ in range(REPEATS - 1):
                t = time.perf_counter()
                pl.plan_detailed(start, goal, costmap)
                runs.append((time.perf_counter() - t) * 1e3)
            row["ms"] = statistics.median(runs)
            row["ok"] = True
        except PlannerError as exc:
            row["ms"] = (time.perf_counter() - t) * 1e3
            row["ok"] = False
            row["error"] = f"{type(exc).__name__}: {exc}"
            try:
                plan = ref.plan_detailed(start, goal, costmap)
            except PlannerError:
                rejected += 1  # infeasible for the footprint and radius: draw another pair
                continue
        row.update(_check(plan.raw, plan.smoothed, plan.direction, costmap))
        row.update(iterations=plan.iterations, length_m=plan.path.length(),
                   reverse_poses=int(np.sum(plan.direction < 0)), analytic=plan.analytic)
        cases.append(row)
    ok = [c for c in cases if c["ok"]]
    times = [c["ms"] for c in ok] or [math.inf]
    summary = {"map": key, "model": model, "cells": costmap.size_x * costmap.size_y,
               "cases": len(cases), "succeeded": len(ok), "rejected_infeasible": rejected,
               "median_ms": statistics.median(times),
               "p95_ms": float(np.percentile(times, 95)), "max_ms": max(times),
               "prepare_s": prepare_s,
               "curv_ok": _frac(ok, "curv"), "curv_ok_raw": _frac(ok, "curv_raw"),
               "collision_free": _frac(ok, "free"), "collision_free_raw": _frac(ok, "free_raw")}
    return summary, cases


def _frac(rows: list[dict[str, Any]], key: str) -> float:
    return sum(bool(r[key]) for r in rows) / len(rows) if rows else 0.0


CAMPUS_INFLATION = (4.0, 1.0)
CAMPUS_FOOTPRINT = "[[2.65, 0.6], [2.65, -0.6], [-0.25, -0.6], [-0.25, 0.6]]"


def run_campus(quick: bool) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The golf cart from the campus spawn point to its waypoints (module docstring)."""
    world = load_world("campus")
    cart = make_footprint(CAMPUS_FOOTPRINT, footprint_padding=0.05)
    data = np.where(world.occupied, LETHAL_OBSTACLE, 0).astype(np.uint8)
    res = world.resolution
    r = cell_distance(CAMPUS_INFLATION[0], res)
    lut = cost_lut(r, res, cart.inscribed_radius, CAMPUS_INFLATION[1])
    h, w = data.shape
    inflate(data, (0, 0, w, h), (0, 0, w, h), r, lut)
    x0, y0, _, _ = world.bounds
    costmap = Costmap2D.from_array(data, res, x0, y0)
    section = golf_cart_hybrid_params()
    section.pop("plugin")
    section.update(downsample_costmap=True, downsampling_factor=2)
    params = HybridAStarParams.from_mapping(section)
    with warnings.catch_warnings():  # reverse_penalty 0.9 -> 1.0, as documented
        warnings.simplefilter("ignore", UserWarning)
        pl = HybridAStar(params, cart, inflation=CAMPUS_INFLATION)
    pl.prepare(costmap)
    start = world.spawn
    goals = list(world.waypoints.items())[:3 if quick else None]
    cases: list[dict[str, Any]] = []
    for name, goal in goals:
        row: dict[str, Any] = {"map": "campus", "model": params.motion_model_for_search,
                               "goal_name": name, "start": [start.x, start.y, start.theta],
                               "goal": [goal.x, goal.y, goal.theta]}
        t = time.perf_counter()
        try:
            plan = pl.plan_detailed(start, goal, costmap)
        except PlannerError as exc:
            row.update(ms=(time.perf_counter() - t) * 1e3, ok=False,
                       error=f"{type(exc).__name__}: {exc}")
            cases.append(row)
            continue
        row.update(ms=(time.perf_counter() - t) * 1e3, ok=True, iterations=plan.iterations,
                   length_m=plan.path.length(), reverse_poses=int(np.sum(plan.direction < 0)),
                   **_check(plan.raw, plan.smoothed, plan.direction, costmap,
                            params.minimum_turning_radius, cart))
        cases.append(row)
    ok = [c for c in cases if c["ok"]]
    times = [c["ms"] for c in ok] or [math.inf]
    summary = {"map": "campus", "model": params.motion_model_for_search, "cases": len(cases),
               "succeeded": len(ok), "median_ms": statistics.median(times),
               "max_ms": max(times), "curv_ok": _frac(ok, "curv"),
               "collision_free": _frac(ok, "free")}
    return summary, cases


def run(quick: bool, data_dir: Path | None = None) -> BenchResult:
    """Run the hybrid suite (``quick``: 10 pairs per map, 3 campus goals)."""
    n = QUICK_CASES if quick else CASES
    result = BenchResult("hybrid", show_cases=False)
    rows: list[dict[str, Any]] = []
    for i, (key, spec) in enumerate(MAPS.items()):
        costmap = build_costmap(data_dir, spec)
        summary, cases = run_map(key, costmap, n, "REEDS_SHEPP", seed=11 + i)
        rows.append(summary)
        result.cases.extend(cases)
        result.metrics[f"hybrid_p95_ms_{key}"] = summary["p95_ms"]
        result.metrics[f"hybrid_median_ms_{key}"] = summary["median_ms"]
    main = [c for c in result.cases if c["model"] == "REEDS_SHEPP"]
    ok = [c for c in main if c["ok"]]
    result.metrics["hybrid_success_rate"] = len(ok) / len(main)
    result.metrics["hybrid_min_turning_radius_ok"] = _frac(ok, "curv")
    result.metrics["hybrid_min_turning_radius_ok_raw"] = _frac(ok, "curv_raw")
    result.metrics["hybrid_collision_free"] = _frac(ok, "free")
    result.metrics["hybrid_collision_free_raw"] = _frac(ok, "free_raw")
    campus, ccases = run_campus(quick)
    result.cases.extend(ccases)
    result.metrics["hybrid_campus_success_rate"] = campus["succeeded"] / campus["cases"]
    result.metrics["hybrid_campus_median_ms"] = campus["median_ms"]
    result.notes.append(
        f"campus golf cart: {campus['succeeded']}/{campus['cases']} waypoints planned, median "
        f"{campus['median_ms']:.0f} ms, max {campus['max_ms']:.0f} ms, curvature ok "
        f"{campus['curv_ok']:.2f}, collision-free {campus['collision_free']:.2f}")
    for r in rows:
        result.notes.append(
            f"{r['map']} {r['model']}: {r['succeeded']}/{r['cases']} feasible pairs planned "
            f"under the Nav2 budget, {r['rejected_infeasible']} infeasible pairs redrawn; "
            f"median {r['median_ms']:.1f} ms, p95 {r['p95_ms']:.1f} ms, max "
            f"{r['max_ms']:.1f} ms; tables prepared in {r['prepare_s']:.1f} s")
    return result
