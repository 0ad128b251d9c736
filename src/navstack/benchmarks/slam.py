"""``navstack bench slam``: SLAM accuracy and speed on the Intel, ACES and CSAIL logs.

Each "corrected" CARMEN log ``carmen/<name>-corrected.log.gz`` (shipped in
``navstack/data``; :func:`~navstack.benchmarks.common.data_file` says where else it is
looked for) is run through
:func:`navstack.mapping.offline.run_carmen` (the log profile: every scan becomes a node,
batch optimisation at the end) and the final trajectory is scored against the log's
corrected FLASER poses with the relative pose error of Kümmerle et al. 2009 over
consecutive scan pairs.

Metrics per log ``<name>`` in ``intel``, ``aces``, ``csail``: ``<name>_trans_err_m`` /
``<name>_trans_err_std_m`` (mean / std of the translational error [m]),
``<name>_rot_err_deg`` / ``<name>_rot_err_std_deg`` ([deg]), ``<name>_ms_per_scan``
(median time of one ``process_scan`` call) and ``<name>_speedup`` (log duration / wall
time of the run; left out when the log's timestamps cannot time it -- CSAIL prints them
with 6 significant digits).  Budgets: :data:`BUDGETS`.

Peer: Cartographer (Hess et al., "Real-time loop closure in 2D LIDAR SLAM", ICRA 2016)
reports 13 ms per scan on Intel (13,631 scans in 179 s) and 0.0229 m / 0.453 deg against
the original ground truth.  No peer SLAM library can be installed in this environment, so
the figure is printed for context only; our RPE is against the corrected poses of the
Radish release, and our scans are the ~0.7 m subsampled ones of that release.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from navstack.benchmarks.common import (
    BenchDataMissing,
    BenchResult,
    Progress,
    data_file,
    no_progress,
)
from navstack.mapping.offline import run_carmen

LOGS = ("intel", "aces", "csail")
#: metric -> upper bound
BUDGETS: dict[str, float] = {"intel_trans_err_m": 0.03, "intel_rot_err_deg": 1.0,
                             "aces_trans_err_m": 0.05, "csail_trans_err_m": 0.05,
                             "intel_ms_per_scan": 13.0}
#: metric -> lower bound
FLOORS: dict[str, float] = {"sim_map_iou": 0.90}
SIM_BUDGETS: dict[str, float] = {"sim_ate_m": 0.05}
#: the waypoint route of the simulated mapping run (``--quick``: the first two goals)
SIM_ROUTE = ("Goal_3", "Goal_4", "Goal_2", "Goal_1")
#: scans per log in ``--quick`` mode (budgets apply to full runs only)
QUICK_SCANS = 150
PEER_NOTE = ("peer (context only, not run): Cartographer 13 ms/scan on Intel (13,631 scans "
             "in 179 s), RPE 0.0229 m / 0.453 deg against the original ground truth; no peer "
             "SLAM library is installable here")


def log_path(data_dir: Path | None, name: str) -> Path:
    """``carmen/<name>-corrected.log.gz`` from the data folders (:func:`data_file`);
    raises :class:`BenchDataMissing` naming the file and the folders searched."""
    return data_file(f"carmen/{name}-corrected.log.gz", data_dir)


def _prefixed(progress: Progress, prefix: str) -> Progress:
    def report(stage: str, done: int, total: int) -> None:
        progress(f"{prefix} {stage}", done, total)

    return report


def run(quick: bool, data_dir: Path | None = None,
        progress: Progress = no_progress) -> BenchResult:
    """Run SLAM on the three logs; metrics as in the module docstring."""
    paths = {name: log_path(data_dir, name) for name in LOGS}  # fail before any work
    result = BenchResult("slam")
    for name, path in paths.items():
        res = run_carmen(path, max_scans=QUICK_SCANS if quick else None,
                         progress=_prefixed(progress, name))
        if res.rpe is None:
            raise BenchDataMissing(f"{path}: no reference poses (not an anchored 'corrected' "
                                   "log), cannot score it")
        m = result.metrics
        m[f"{name}_trans_err_m"] = res.rpe.trans_mean_m
        m[f"{name}_trans_err_std_m"] = res.rpe.trans_std_m
        m[f"{name}_rot_err_deg"] = res.rpe.rot_mean_deg
        m[f"{name}_rot_err_std_deg"] = res.rpe.rot_std_deg
        m[f"{name}_ms_per_scan"] = res.ms_per_scan
        if res.speedup is not None:
            m[f"{name}_speedup"] = res.speedup
        odo = res.odometry_rpe
        result.cases.append({
            "log": name, "scans": res.scans, "nodes": len(res.mapper.nodes),
            "loop_closures": res.mapper.stats.loop_closures,
            "match_failures": res.mapper.stats.match_failures,
            "trans_err_m": res.rpe.trans_mean_m, "trans_err_std_m": res.rpe.trans_std_m,
            "rot_err_deg": res.rpe.rot_mean_deg, "rot_err_std_deg": res.rpe.rot_std_deg,
            "odometry_trans_err_m": odo.trans_mean_m if odo else None,
            "odometry_rot_err_deg": odo.rot_mean_deg if odo else None,
            "ms_per_scan": res.ms_per_scan, "wall_s": res.wall_s,
            "log_duration_s": res.log_duration_s, "speedup": res.speedup,
            "skipped_lines": len(res.skipped)})
        if res.speedup is None:
            result.notes.append(f"{name}: timestamps too coarse to give the log duration "
                                f"({name}_speedup left out)")
    progress("simulated mapping", 0, 1)
    _run_sim(result, quick)
    progress("simulated mapping", 1, 1)
    scope = (f"quick: first {QUICK_SCANS} scans of each log, budgets not checked" if quick
             else "full logs, every scan a node (log profile), batch optimisation at the end")
    result.notes += [
        scope,
        "RPE (Kümmerle et al. 2009) over consecutive scans against the corrected FLASER "
        "poses; mean and std of the translation [m] and rotation [deg] errors",
        "budgets: " + ", ".join([f"{k} <= {v:g}" for k, v in {**BUDGETS,
                                                                **SIM_BUDGETS}.items()]
                                + [f"{k} >= {v:g}" for k, v in FLOORS.items()]),
        PEER_NOTE,
    ]
    if not quick:
        over = [k for k, v in {**BUDGETS, **SIM_BUDGETS}.items()
                if not (math.isfinite(result.metrics[k]) and result.metrics[k] <= v)]
        over += [k for k, v in FLOORS.items()
                 if not (math.isfinite(result.metrics[k]) and result.metrics[k] >= v)]
        result.notes.append("over budget: " + ", ".join(over) if over
                            else "all budgets met")
    return result


def _run_sim(result: BenchResult, quick: bool) -> None:
    """The office mapped while following the waypoints, loop closure on and off.

    ``sim_ate_m`` (RMS, no alignment: the SLAM map starts at the spawn pose) and
    ``sim_map_iou`` (occupied cells vs the world raster at 0.05 m, one cell of tolerance;
    :func:`navstack.mapping.map_metrics.occupancy_iou`), and the same with
    ``do_loop_closing: false`` (``*_no_loop``) to show what the closures are worth."""
    from navstack.benchmarks.sim_mapping import run_sim_mapping

    route = SIM_ROUTE[:2] if quick else SIM_ROUTE
    for suffix, overrides in (("", {}), ("_no_loop", {"do_loop_closing": False})):
        t0 = time.perf_counter()
        run = run_sim_mapping(overrides, goals=route)
        m = result.metrics
        m[f"sim_ate_m{suffix}"] = run.ate_m
        m[f"sim_map_iou{suffix}"] = run.map.iou
        result.cases.append({
            "log": f"sim office{suffix}", "route": " -> ".join(route),
            "goals": {name: status for name, status, _ in run.goals},
            "ate_m": run.ate_m, "ate_max_m": run.ate_max_m, "map_iou": run.map.iou,
            "map_precision": run.map.precision, "map_recall": run.map.recall,
            "completeness": run.map.completeness, "loop_closures": run.stats.loop_closures,
            "nodes": run.stats.scans_processed, "collisions": run.collisions,
            "sim_time_s": run.sim_time_s, "wall_s": time.perf_counter() - t0})
        failed = [f"{name} ({reason})" for name, status, reason in run.goals
                  if status != "SUCCEEDED"]
        if failed:
            result.notes.append(f"sim office{suffix}: goals not reached: " + "; ".join(failed))
