"""``navstack bench slam-robust``: SLAM on logs made hard on purpose, and on simulated
worlds against ground truth.

Built from the shared CARMEN logs:

* ``<log>_no_odom_ate_m`` -- :func:`without_odometry`: every second scan has no odometry
  (the reading is gone, the odometry stream goes on);
* ``<log>_heading_jump_ate_m`` -- :func:`heading_jump`: the scans and ODOM lines of a
  turn are cut out of the text so that two consecutive scans differ by ~80 degrees with
  no odometry between them;
* ``<log>_odom_gaps_ate_m`` -- :func:`drop_odometry`: the ODOM lines of every second
  interval are removed from the text, so the odometry stream itself has a gap before
  every second scan (the reader flags it) -- harder than either: half the steps rest on
  the motion prediction and the wide search alone.

Simulated (:mod:`navstack.benchmarks.sim_logs`, true poses as reference):

* ``dense_*`` -- the warehouse loop driven twice with a scan every ~0.1 m (thousands of
  scans, every one offered to SLAM): ``dense_ate_m``, ``dense_speedup`` (log duration /
  SLAM wall time, > 1: faster than the log's real time), ``dense_ms_growth`` (mean ms per
  scan of the last tenth over the first);
* ``warehouse_*`` / ``campus_*`` -- one loop with a scan per lidar period (10 Hz, every
  ~0.04 m; the log profile's gates make nodes): ``_ate_m``, ``_map_iou`` (the SLAM map
  against the world raster, :func:`~navstack.mapping.map_metrics.occupancy_iou`),
  ``_loop_trans_m`` (no doubled walls: the loop relation error);
* ``warehouse_lds_*`` -- the warehouse's open areas driven by the TurtleBot3 with its
  3.5 m LDS and mapped with its own SLAM parameters (:mod:`navstack.benchmarks.slam_lds`):
  ``_ate_m``, ``_online_max_m`` (the online estimate's largest error, no alignment),
  ``_odometry_max_m``.

Budgets (issue 15): ATE <= 0.15 m for ``_no_odom`` (acceptance 2a) and ``_heading_jump``
(2b); ``_odom_gaps`` is a stress row held to 0.15 m as a target, reported apart and not
counted in ``over_budget``; ATE <= 0.10 m and ``dense_ms_growth`` <= 2 and
``dense_speedup`` >= 1 for the dense loop, ATE <= 0.10 m,
IoU >= 0.90 and loop relations <= 0.05 m for the worlds, ATE <= 0.25 m and an online
error never above the odometry's for the LDS drive.  ``--quick`` runs the edited
logs on their first 200 scans and the worlds' loops only.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from navstack.benchmarks.common import BenchResult
from navstack.benchmarks.sim_logs import SimLog, record_route
from navstack.benchmarks.slam import log_path
from navstack.benchmarks.slam_lds import BUDGET_ATE_M as BUDGET_LDS_ATE_M
from navstack.benchmarks.slam_lds import (
    lds_metrics,
    lds_over_budget,
    lds_params,
    map_online,
    record_lds,
)
from navstack.core.errors import NavstackError
from navstack.core.geometry import FloatArray, se2_compose
from navstack.mapping.carmen import LASER_KINDS, read_carmen
from navstack.mapping.map_metrics import MapScore, occupancy_iou
from navstack.mapping.occupancy import LogOddsGrid
from navstack.mapping.offline import (
    OfflineResult,
    ScanLog,
    log_params,
    read_scan_log,
    score_run,
    warm_up,
)
from navstack.mapping.slam_outputs import metrics
from navstack.sim.worlds import load_world

__all__ = ["HeadingJump", "drop_odometry", "heading_jump", "map_world", "run",
           "without_odometry"]

LOGS = ("intel", "aces", "csail")
QUICK_SCANS = 200
BUDGETS: dict[str, float] = {"dense_ate_m": 0.10, "dense_ms_growth": 2.0,
                             "warehouse_ate_m": 0.10, "warehouse_loop_trans_m": 0.05,
                             "campus_ate_m": 0.10, "campus_loop_trans_m": 0.05}
FLOORS: dict[str, float] = {"dense_speedup": 1.0, "warehouse_map_iou": 0.90,
                            "campus_map_iou": 0.90}
EDITED_ATE = 0.15
#: ``_odom_gaps`` is a stress row beyond acceptance 2(a) (which drops the odometry *of*
#: every second scan: ``_no_odom``): whole odometry intervals are lost, not just readings.
#: It is held to the same 0.15 m as a target, reported apart and not counted in
#: ``over_budget`` (docs/decisions.md, "Odometry gaps: acceptance row and stress row")
STRESS_SUFFIXES = ("_odom_gaps_ate_m",)


class LogEditError(NavstackError):
    """A log cannot be edited as asked (no turn of that size in it)."""


def _tag(line: str) -> str:
    return line.split(maxsplit=1)[0] if line.strip() else ""


def without_odometry(scan_log: ScanLog, every: int = 2) -> ScanLog:
    """The log with no odometry for scans 1, 3, 5, ... (``every`` 2): their odometry
    reading is gone (NaN) while the odometry stream goes on, so the next scan's odometry
    still continues from the scan before the dropped one."""
    odometry = scan_log.odometry.copy()
    odometry[1::every] = np.nan
    return replace(scan_log, odometry=odometry)


def drop_odometry(text: str, every: int = 2) -> str:
    """The log with the ODOM lines between laser line ``k`` and ``k + 1`` removed for
    every ``k`` divisible by ``every``: scans 1, 3, 5, ... (``every`` 2) have no odometry
    since the scan before them."""
    out: list[str] = []
    k = -1
    for line in text.splitlines():
        tag = _tag(line)
        if tag in LASER_KINDS:
            k += 1
        elif tag == "ODOM" and k >= 0 and k % every == 0:
            continue
        out.append(line)
    return "\n".join(out) + "\n"


@dataclass(frozen=True)
class HeadingJump:
    """Where :func:`heading_jump` cut: the scans before and after the cut (indices in
    the edited log), the reference turn [deg] and distance [m] between them and how
    many scans were removed."""

    before: int
    after: int
    turn_deg: float
    distance_m: float
    removed_scans: int


def heading_jump(text: str, turn_deg: float = 80.0, tolerance_deg: float = 5.0,
                 max_distance: float = 1.5, start_fraction: float = 0.1
                 ) -> tuple[str, HeadingJump]:
    """Cut a turn out of the log: the first pair of scans ``k < j`` (after
    ``start_fraction`` of the log, at most 8 apart) whose reference poses differ by
    ``turn_deg +- tolerance_deg`` of heading and less than ``max_distance`` metres loses
    every scan between them and every ODOM line from scan ``k`` to scan ``j``: the robot
    turns ~80 degrees between two consecutive scans with no odometry."""
    import tempfile

    with tempfile.NamedTemporaryFile("w", suffix=".log", delete=False) as fh:
        fh.write(text)
        name = fh.name
    try:
        scans = read_carmen(name).scans
    finally:
        Path(name).unlink()
    ref = np.array([s.reference for s in scans])
    found = None
    for k in range(int(start_fraction * len(scans)), len(scans) - 2):
        for j in range(k + 2, min(k + 9, len(scans))):
            turn = abs(math.degrees(math.remainder(ref[j, 2] - ref[k, 2], 2 * math.pi)))
            dist = math.hypot(*(ref[j, :2] - ref[k, :2]))
            if abs(turn - turn_deg) <= tolerance_deg and dist <= max_distance:
                found = (k, j, turn, dist)
                break
        if found:
            break
    if found is None:
        raise LogEditError(f"no turn of {turn_deg} +- {tolerance_deg} deg within "
                           f"{max_distance} m and 8 scans in the log")
    k, j, turn, dist = found
    first_line, last_line = scans[k].line_no, scans[j].line_no
    out = []
    for n, line in enumerate(text.splitlines(), start=1):
        if first_line < n < last_line and _tag(line) in (*LASER_KINDS, "ODOM"):
            continue
        out.append(line)
    return "\n".join(out) + "\n", HeadingJump(k, k + 1, turn, dist, j - k - 1)


def _run_text(text: str, name: str, max_scans: int | None,
              overrides: dict[str, object] | None = None) -> OfflineResult:
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{name}.log"
        path.write_text(text, encoding="utf-8")
        scan_log, skipped, ignored, in_log, _ = read_scan_log(path, max_scans)
        return score_run(scan_log, log_params(overrides), skipped=skipped, ignored=ignored,
                         scans_in_log=in_log, path=path)


def _read_text(path: Path) -> str:
    import gzip

    data = path.read_bytes()
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    return data.decode("utf-8", errors="replace")


def route_returns(sim: SimLog, mapper_points: Callable[[NDArray[np.floating]], FloatArray],
                  scans: NDArray[np.int64] | None = None) -> FloatArray:
    """``(N, 2)`` the laser returns of the log's scans (``scans``: those indices, e.g.
    the scans that became the map's nodes) drawn at their true poses (world frame): what
    the laser hit, for :func:`occupancy_iou`'s ``observed_points``."""
    assert sim.log.reference is not None
    index = np.arange(len(sim.log.ranges)) if scans is None else np.asarray(scans)
    parts = []
    for k in index:
        x, y, th = sim.log.reference[k]
        pts = mapper_points(sim.log.ranges[k])
        c, s = math.cos(th), math.sin(th)
        parts.append(pts @ np.array([[c, s], [-s, c]]) + (x, y))
    return np.vstack(parts) if parts else np.zeros((0, 2))


def map_world(sim: SimLog) -> tuple[OfflineResult, MapScore]:
    """SLAM on a simulated log with the map frame at the first true pose, and the map
    scored against the world raster (0.05 m, one cell of tolerance) after the SE(2)
    alignment of the ATE (a SLAM map's frame is its own: only its shape is scored), on
    the walls the route's laser hit (:func:`route_returns`)."""
    assert sim.log.reference is not None
    params = log_params({"map_start_pose": [float(v) for v in sim.log.reference[0]]})
    result = score_run(sim.log, params)
    mapper = result.mapper
    shift = np.zeros(3) if result.scores is None else np.array(result.scores.ate.alignment)
    aligned = se2_compose(shift, mapper.poses())
    grid = LogOddsGrid(mapper.params.resolution)
    mapper.integrate_into(grid, aligned)
    truth = load_world(sim.world).to_occupancy_grid()
    # the map holds the node scans: score it on the walls they hit from their true poses
    node_scans = np.flatnonzero(np.diff(np.r_[-1, result.node_index]) > 0)
    estimate = grid.to_occupancy_grid(crop=True, free_thresh=params.map_free_thresh)
    return result, occupancy_iou(estimate, truth,
                                 observed_points=route_returns(sim, mapper.scan_points,
                                                               node_scans))


def run(quick: bool, data_dir: Path | None = None) -> BenchResult:
    """The edited logs and the simulated worlds; metrics as in the module docstring."""
    paths = {name: log_path(data_dir, name) for name in LOGS}  # fail before any work
    warm_up()
    result = BenchResult("slam-robust")
    m = result.metrics
    for name, path in paths.items():
        text = _read_text(path)
        limit = QUICK_SCANS if quick else None
        scan_log, *_ = read_scan_log(path, limit)
        no_odom = score_run(without_odometry(scan_log), log_params(None))
        gaps = _run_text(drop_odometry(text), f"{name}-odom-gaps", limit)
        jumped_text, jump = heading_jump(text)
        jumped = _run_text(jumped_text, f"{name}-heading-jump",
                           jump.after + QUICK_SCANS // 2 if quick else None)
        for kind, res in (("no_odom", no_odom), ("heading_jump", jumped),
                          ("odom_gaps", gaps)):
            mm = metrics(res)
            m[f"{name}_{kind}_ate_m"] = mm.get("ate_m", math.nan)
            result.cases.append({
                "log": f"{name} {kind.replace('_', ' ')}", "scans": res.scans,
                "odometry_gaps": res.odometry_gaps, "ate_m": mm.get("ate_m"),
                "odometry_ate_m": mm.get("odometry_ate_m"),
                "trans_err_m": mm.get("trans_err_m"), "loop_trans_m": mm.get("loop_trans_m"),
                "odometry_events": mm["odometry_events"],
                "recovered_scans": mm["recovered_scans"],
                "ambiguous_scans": mm["ambiguous_scans"], "ms_per_scan": mm.get("ms_per_scan"),
                "wall_s": res.wall_s})
        result.notes.append(f"{name} heading jump: scans {jump.before} -> {jump.after} turn "
                            f"{jump.turn_deg:.0f} deg over {jump.distance_m:.2f} m, "
                            f"{jump.removed_scans} scans cut")
    if not quick:
        t0 = time.perf_counter()
        dense = record_route("warehouse", spacing=0.1, laps=2)
        record_s = time.perf_counter() - t0
        res = score_run(dense.log, log_params(None))
        mm = metrics(res)
        m["dense_ate_m"] = mm["ate_m"]
        m["dense_speedup"] = dense.duration_s / res.wall_s
        m["dense_ms_growth"] = mm["ms_growth"]
        result.cases.append({"log": "dense warehouse loop x2", "scans": res.scans,
                             "nodes": mm["nodes"], "ate_m": mm["ate_m"],
                             "loop_trans_m": mm.get("loop_trans_m"),
                             "ms_first_10": mm["ms_first_10"], "ms_last_10": mm["ms_last_10"],
                             "log_s": dense.duration_s, "wall_s": res.wall_s,
                             "record_s": record_s})
    for world in ("warehouse", "campus"):
        sim = record_route(world, spacing=0.0)
        res, score = map_world(sim)
        mm = metrics(res)
        m[f"{world}_ate_m"] = mm["ate_m"]
        m[f"{world}_map_iou"] = score.iou
        m[f"{world}_loop_trans_m"] = mm.get("loop_trans_m", math.nan)
        result.cases.append({"log": f"{world} loop", "scans": res.scans, "nodes": mm["nodes"],
                             "distance_m": sim.distance_m, "ate_m": mm["ate_m"],
                             "odometry_ate_m": mm.get("odometry_ate_m"),
                             "map_iou": score.iou, "loop_trans_m": mm.get("loop_trans_m"),
                             "loop_closures": mm["loop_closures"],
                             "ms_per_scan": mm.get("ms_per_scan"), "wall_s": res.wall_s})
    lds = record_lds()
    assert lds.log.reference is not None
    lds_run = map_online(lds.log, lds_params(lds.log.reference[0]))
    m.update(lds_metrics(lds_run))
    result.cases.append({"log": "warehouse TurtleBot3 LDS drive", "scans": len(lds.log.ranges),
                         "nodes": len(lds_run.mapper.nodes), "distance_m": lds.distance_m,
                         "ate_m": lds_run.ate_m, "online_max_m": lds_run.online_max_m,
                         "odometry_max_m": lds_run.odometry_max_m,
                         "loop_closures": lds_run.mapper.stats.loop_closures,
                         "sparse_nodes": lds_run.mapper.stats.sparse_nodes,
                         "wall_s": lds_run.wall_s})
    budgets = {**BUDGETS, **{k: EDITED_ATE for k in m if k.endswith(
        ("_no_odom_ate_m", "_heading_jump_ate_m"))}}
    over = [k for k, v in budgets.items() if k in m
            and not (math.isfinite(m[k]) and m[k] <= v)]
    stress_over = [k for k in m if k.endswith(STRESS_SUFFIXES)
                   and not (math.isfinite(m[k]) and m[k] <= EDITED_ATE)]
    over += [k for k, v in FLOORS.items() if k in m and not (math.isfinite(m[k]) and m[k] >= v)]
    over += lds_over_budget(m)
    m["over_budget"] = float(len(over))
    result.notes.append("budgets: <log>_no_odom / _heading_jump ATE <= 0.15 m; "
                        + ", ".join(
        [f"{k} <= {v:g}" for k, v in BUDGETS.items()]
        + [f"{k} >= {v:g}" for k, v in FLOORS.items()]
        + [f"warehouse_lds_ate_m <= {BUDGET_LDS_ATE_M:g}",
           "warehouse_lds_online_max_m <= warehouse_lds_odometry_max_m"]))
    if quick:
        result.notes.append(f"quick: edited logs on their first {QUICK_SCANS} scans (the "
                            f"heading jump up to {QUICK_SCANS // 2} scans after it), no "
                            "dense loop")
    result.notes.append("stress rows (target <log>_odom_gaps ATE <= 0.15 m, not a budget): "
                        + ("over target: " + ", ".join(stress_over) if stress_over
                           else "all within target"))
    result.notes.append("over budget: " + ", ".join(over) if over else "all budgets met")
    return result
