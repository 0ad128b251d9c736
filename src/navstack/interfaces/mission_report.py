"""Report files of a mission run: ``report.json``, ``report.md`` and the figures.

Also the mission-specific figures computed from the truth: the coverage cells visited
(on the true trajectory) and the map-by-poses completeness after each pose and its
reload checks (:mod:`.mission_reload`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import NDArray

from navstack.interfaces.plots import plot_trajectory

if TYPE_CHECKING:
    from navstack.interfaces.mission_run import MissionRun

__all__ = ["coverage_figures", "map_poses_figures", "write_report"]


def coverage_figures(report: dict[str, Any], traj: NDArray[np.float64]) -> dict[str, Any]:
    """Cells visited according to the *true* trajectory: it entered the cell's square
    (``cell_size`` wide, centred on the cell) -- the plan's goal may sit off-centre,
    where the robot can turn."""
    cov = report["coverage"]
    half = cov["cell_size"] / 2.0
    xy = traj[:, 1:3]
    visited = 0
    for c in cov["cells"]:
        cx, cy = c["centre"]
        if len(xy):
            d = np.maximum(np.abs(xy[:, 0] - cx), np.abs(xy[:, 1] - cy))
            inside = float(np.min(d))
        else:
            inside = math.inf
        c["true_min_chebyshev_m"] = round(inside, 3)
        c["visited_by_trajectory"] = bool(inside <= half)
        visited += c["visited_by_trajectory"]
    return {"cells_total": len(cov["cells"]), "cells_visited": visited}


def map_poses_figures(run: MissionRun, report: dict[str, Any]) -> dict[str, Any]:
    """Completeness after each pose and the reload checks."""
    from navstack.interfaces.mission_reload import check_reload

    out: dict[str, Any] = {}
    cov = run.coverage
    poses = report["map_poses"]["poses"]
    if cov is not None:
        for p in poses:
            before = [f for t, f in zip(cov.times, cov.fractions, strict=True)
                      if t <= p["time"] + 1.0]
            p["completeness_after"] = round(before[-1], 4) if before else 0.0
        out["completeness"] = round(cov.final, 4)
    files = report["map_poses"].get("saved", {})
    reached = [p for p in poses if p["status"] == "REACHED"]
    if files and reached and run.runner.result is not None \
            and run.runner.result.status.value == "SUCCEEDED":
        from navstack.core.msgs import Pose2D

        goal = Pose2D(*reached[0]["pose"])
        slam_map = run.stack.slam.saved_map() if run.stack.slam is not None else None
        slam_params = run.setup.section("slam_toolbox")
        out["reload"] = check_reload(run.stack.world.name if run.stack.world.source is None
                                     else str(run.stack.world.source),
                                     run.stack.robot.name, run.setup.nav2_file, files,
                                     slam_map, slam_params, goal, run.stack.description.seed)
    return out


def _fmt(value: Any, digits: int = 2) -> str:
    if isinstance(value, float):
        return "n/a" if math.isnan(value) else ("never" if math.isinf(value)
                                                 else f"{value:.{digits}f}")
    return str(value)


def _markdown(r: dict[str, Any]) -> str:
    verdict = "SUCCESS" if r["success"] else "FAILURE"
    lines = [f"# navstack mission `{r['mission']}` — {verdict}", "",
             f"{r['description']}.  World `{r['world']}`, robot `{r['robot']}`, seed "
             f"{r['seed']}, localization `{r['localization']}`.", "",
             f"**{r['status']}**" + (f": {r['reason']}" if r["reason"] else ""), "",
             "| figure | value |", "|---|---:|"]
    rows = [("duration [s]", r["duration_s"]), ("path length [m]", r["path_length_m"]),
            ("collisions", r["collisions"]), ("min clearance [m]", r["min_clearance_m"]),
            ("true distance to home at the end [m]", r["home_distance_m"]),
            ("longest spin in place [s]", r["max_spin_in_place_s"])]
    for key, label in (("time_to_90_s", "time to 90 % observed [s]"),
                       ("time_to_95_s", "time to 95 % observed [s]"),
                       ("observed_fraction", "reachable free space observed"),
                       ("map_iou", "map IoU"),
                       ("slam_map_latency_p95_s", "SLAM map update latency p95 [s]"),
                       ("goal_to_first_motion_p95_s", "goal to first motion p95 [s]"),
                       ("cells_visited", "coverage cells visited"),
                       ("cells_total", "coverage cells"),
                       ("completeness", "map completeness")):
        if key in r:
            rows.append((label, r[key]))
    lines += [f"| {label} | {_fmt(value)} |" for label, value in rows]
    lines += ["", f"Simulated {r['sim_time_s']:.0f} s in {r['wall_time_s']:.0f} s wall time "
              f"(real-time factor {r['real_time_factor']:.1f}).", ""]
    if "explore" in r:
        e = r["explore"]
        lines += ["## Exploration", "", f"- strategy `{e['strategy']}`: {e['goals_sent']} goals "
                  f"({e['goals_succeeded']} reached, {e['goals_failed']} failed), "
                  f"{e['blacklisted']} blacklisted, {e['retries']} retried",
                  f"- ended: {e['done_reason']}", "", "![exploration](exploration.png)", ""]
    if "map_poses" in r:
        lines += ["## Poses", "", "| pose | status | completeness after |", "|---|---|---:|"]
        lines += [f"| {p['name']} | {p['status']} | {_fmt(p.get('completeness_after', 0.0), 3)} |"
                  for p in r["map_poses"]["poses"]]
        if "reload" in r:
            rl = r["reload"]
            lines += ["", f"- map_server reload: {rl.get('map_server_goal')}, AMCL error "
                      f"{_fmt(rl.get('map_server_amcl_error_m', math.nan), 3)} m, cells agree "
                      f"{_fmt(rl.get('map_server_cells_agree', 0.0), 3)}",
                      f"- SLAM localization reload: {rl.get('slam_localization_goal')}, error "
                      f"{_fmt(rl.get('slam_localization_error_m', math.nan), 3)} m"]
        lines.append("")
    lines += ["![trajectory](trajectory.png)", "", "## Events", ""]
    lines += [f"- {t:.1f} s: {text}" for t, text in r["events"][-60:]]
    return "\n".join(lines) + "\n"


def write_report(report: dict[str, Any], out: Path, run: MissionRun) -> None:
    from navstack.interfaces.mission_run import final_map

    (out / "report.json").write_text(json.dumps(report, indent=2, default=float) + "\n")
    (out / "report.md").write_text(_markdown(report))
    traj = run.trajectory.array()
    goals: dict[str, tuple[float, float]] = {"home": (run.stack.description.spawn.x,
                                                      run.stack.description.spawn.y)}
    for i, c in enumerate(report.get("coverage", {}).get("cells", [])):
        goals[f"c{i + 1}"] = (c["centre"][0], c["centre"][1])
    for p in report.get("map_poses", {}).get("poses", []):
        goals[p["name"]] = (p["pose"][0], p["pose"][1])
    plot_trajectory(final_map(run), traj[:, 1:3], run.plans[-300:], goals,
                    out / "trajectory.png",
                    title=f"navstack mission {report['mission']}: {report['world']}, "
                          f"{report['status']}")
    trace = report.get("coverage_trace")
    if trace:
        t = np.array(trace)
        fig, ax = plt.subplots(figsize=(8, 4))
        ax.plot(t[:, 0], 100 * t[:, 1], "-", color="tab:blue", label="observed")
        for level in (90, 95):
            ax.axhline(level, color="grey", lw=0.8, ls="--")
        ax.set_xlabel("time since the mission started [s]")
        ax.set_ylabel("reachable free space observed [%]")
        ax.set_ylim(0, 101)
        ax.set_title(f"{report['world']}: time to 90 % {_fmt(report.get('time_to_90_s'), 0)} "
                     f"s, to 95 % {_fmt(report.get('time_to_95_s'), 0)} s")
        fig.tight_layout()
        fig.savefig(out / "exploration.png", dpi=100)
        plt.close(fig)
