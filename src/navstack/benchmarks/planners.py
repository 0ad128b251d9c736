"""Planner suite: MovingAI optimality and per-query speed against a C++ grid A* peer.

For each of the seven MovingAI maps ``movingai/<map>.map`` (shipped in ``navstack/data``,
or from ``--data-dir``/``NAVSTACK_DATA``: :func:`~navstack.benchmarks.common.data_file`)
every scenario (quick
mode: every 20th, still covering all maps and buckets) is solved with the numba kernel
in MovingAI mode (:class:`navstack.planning.movingai.MovingAISolver`: octile costs, no
corner cutting) and checked against the published optimal length.  A length counts as
optimal when ``|length - optimal| <= 1e-4 + print_tolerance`` (the dao ``.scen`` files
print 6 significant digits, so ``1006.71`` is only known to +-0.005).

Speed is compared with the peer ``pyastar2d`` (C++ A* over a float32 weight grid, here
1 for free and inf for blocked cells, diagonal moves allowed), falling back to
``tcod.path.AStar`` (python-tcod, C) if pyastar2d cannot be imported.  The peers use
their own movement rules (pyastar2d: a diagonal costs the same as a straight step and
may cut corners), so only the query *time* on the same start/goal problems is compared,
not the lengths.  Both are timed per query, interleaved query by query on each map, with
the order of the two calls alternating, in the same process.

Metrics: ``optimal_rate_<map>``, ``optimal_rate`` (the minimum over maps),
``median_query_ms`` (ours, pooled over all timed queries), ``median_query_ms_<peer>``,
``ratio_vs_<peer>`` = ours / peer medians (budget <= 1.0).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.benchmarks.common import BenchDataMissing, BenchResult, data_file
from navstack.planning.movingai import MovingAISolver, Scenario, load_map, load_scen

MAPS = ("arena", "den101d", "lak303d", "brc202d", "8room_000", "maze512-4-0",
        "random512-20-0")
QUICK_STRIDE = 20
RATIO_BUDGET = 1.0

PeerQuery = Callable[[int, int, int, int], object]


def _pyastar2d_peer(passable: NDArray[np.bool_]) -> PeerQuery:
    import pyastar2d

    weights = np.where(passable, np.float32(1.0), np.float32(np.inf)).astype(np.float32)

    def query(sx: int, sy: int, gx: int, gy: int) -> object:
        return pyastar2d.astar_path(weights, (sy, sx), (gy, gx), allow_diagonal=True)

    return query


def _tcod_peer(passable: NDArray[np.bool_]) -> PeerQuery:
    import tcod.path

    astar = tcod.path.AStar(passable.astype(np.int8), diagonal=math.sqrt(2.0))

    def query(sx: int, sy: int, gx: int, gy: int) -> object:
        return astar.get_path(sy, sx, gy, gx)  # tcod indexes the array as [i, j]

    return query


def select_peer() -> tuple[str, Callable[[NDArray[np.bool_]], PeerQuery]]:
    """``("pyastar2d", factory)``, or ``("tcod", factory)`` if pyastar2d is missing."""
    try:
        import pyastar2d  # noqa: F401
    except ImportError:
        return "tcod", _tcod_peer
    return "pyastar2d", _pyastar2d_peer


def run_map(path: Path, quick: bool,
            peer_factory: Callable[[NDArray[np.bool_]], PeerQuery]
            ) -> tuple[dict[str, Any], list[float], list[float]]:
    """Solve one map's scenarios; return its case row and our / peer query times [ms]."""
    passable = load_map(path)
    scens: list[Scenario] = load_scen(path.with_name(path.name + ".scen"))
    if quick:
        scens = scens[::QUICK_STRIDE]
    solver = MovingAISolver(passable)
    peer = peer_factory(passable)
    first = scens[0]
    solver.solve(first.start_x, first.start_y, first.goal_x, first.goal_y)  # warm-up
    peer(first.start_x, first.start_y, first.goal_x, first.goal_y)
    ours_ms: list[float] = []
    peer_ms: list[float] = []
    optimal = 0
    worst = 0.0
    for i, sc in enumerate(scens):
        sx, sy, gx, gy = sc.start_x, sc.start_y, sc.goal_x, sc.goal_y
        tp = 0.0
        if i % 2:  # alternate who goes first so cache effects do not favour one side
            t0 = time.perf_counter()
            peer(sx, sy, gx, gy)
            tp = time.perf_counter() - t0
        t0 = time.perf_counter()
        length, _cells = solver.solve(sx, sy, gx, gy)
        to = time.perf_counter() - t0
        if not i % 2:
            t0 = time.perf_counter()
            peer(sx, sy, gx, gy)
            tp = time.perf_counter() - t0
        ours_ms.append(to * 1e3)
        peer_ms.append(tp * 1e3)
        err = abs(length - sc.optimal_length)
        worst = max(worst, err if math.isfinite(err) else math.inf)
        if err <= 1e-4 + sc.print_tolerance:
            optimal += 1
    name = path.name.removesuffix(".map")
    row = {"map": name, "size": f"{passable.shape[1]}x{passable.shape[0]}",
           "scenarios": len(scens), "optimal": optimal,
           "optimal_rate": optimal / len(scens), "max_abs_error": worst,
           "median_query_ms": statistics.median(ours_ms),
           "median_query_ms_peer": statistics.median(peer_ms),
           "ratio_vs_peer": statistics.median(ours_ms) / statistics.median(peer_ms)}
    return row, ours_ms, peer_ms


def run(quick: bool, data_dir: Path | None = None) -> BenchResult:
    """Run the planner suite over the MovingAI maps (found by :func:`data_file`)."""
    paths = {name: data_file(f"movingai/{name}.map", data_dir) for name in MAPS}
    for path in paths.values():  # fail before any work
        scen = path.with_name(path.name + ".scen")
        if not scen.is_file():
            raise BenchDataMissing(f"{scen} not found: the scenarios of {path.name} must lie "
                                   "beside it (see navstack/data/README.md)")
    peer_name, peer_factory = select_peer()
    result = BenchResult("planners")
    all_ours: list[float] = []
    all_peer: list[float] = []
    rates: list[float] = []
    for name, path in paths.items():
        row, ours, peer = run_map(path, quick, peer_factory)
        row["peer"] = peer_name
        result.cases.append(row)
        result.metrics[f"optimal_rate_{name}"] = row["optimal_rate"]
        rates.append(row["optimal_rate"])
        all_ours.extend(ours)
        all_peer.extend(peer)
    ours_med = statistics.median(all_ours)
    peer_med = statistics.median(all_peer)
    result.metrics["optimal_rate"] = min(rates)
    result.metrics["median_query_ms"] = ours_med
    result.metrics[f"median_query_ms_{peer_name}"] = peer_med
    result.metrics[f"ratio_vs_{peer_name}"] = ours_med / peer_med
    scope = f"quick: every {QUICK_STRIDE}th scenario" if quick else "full: every scenario"
    peer_desc = ("C++ A*, float32 weights 1 free / inf blocked, allow_diagonal"
                 if peer_name == "pyastar2d" else "python-tcod AStar, diagonal sqrt(2)")
    result.notes += [
        f"{scope} of {len(MAPS)} MovingAI maps; {len(all_ours)} queries timed",
        "optimal when |length - optimal| <= 1e-4 + half a unit of the .scen print precision",
        f"peer: {peer_name} ({peer_desc}); it uses its own movement rules, so only query "
        "time on the same start/goal problems is compared, not path length",
        f"ratio_vs_{peer_name} = median_query_ms / median_query_ms_{peer_name} over all "
        f"queries, interleaved per query; budget <= {RATIO_BUDGET}",
    ]
    return result
