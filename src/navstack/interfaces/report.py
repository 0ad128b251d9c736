"""``navstack report BAG --out DIR``: what happened in a recorded run, from the bag alone.

Writes ``report.md`` (tables), ``report.json`` (the same numbers) and ``speed.png``,
``angular_speed.png``, ``trajectory.png``.  Definitions (see also docs/recording.md):

* **Trajectory** from ``/ground_truth`` if recorded, else ``/odom`` (the report says which;
  :mod:`.report_data`).  **Path length** is measured on the trajectory sampled every
  ``sample_period`` s (0.1 s, on multiples of the period) -- the demo's
  ``TrajectoryRecorder`` -- for the whole recording and for each goal's window
  ``[accepted, ended]``, so a recorded demo reproduces its ``report.json``.
* **Speed / |w|**: the trajectory's body twist, all samples; **curvature** ``|w| / v``
  over the samples moving faster than ``moving_speed``.  ``/cmd_vel`` gets the same
  statistics.  Statistics are mean, median, 95th percentile and max.
* **Clearance** (the demo's definition; whole run and per goal): distance from the
  robot's footprint outline to the nearest static obstacle -- an occupied ``/map`` cell
  (its square; occupancy >= 65, Nav2's ``occupied_thresh``) -- and, separately, to the
  nearest moving obstacle (``/sim/obstacles``, the walkers), at the trajectory samples;
  0 on contact, capped at 3 m.  The footprint is ``/sim/footprint`` when recorded, else a
  circle of ``robot_radius``.
* **Per goal**: status, time to goal (accepted -> terminal status), path length, minimum
  distance to the goal, minimum clearances.
* **Latency-aware safe speed** ``v_max = -a L + sqrt(a^2 L^2 + 2 a d_free)``: ``a`` the
  braking deceleration (default 2.5 m/s², Nav2 ``velocity_smoother`` ``max_decel``),
  ``L`` the measured end-to-end latency's 95th percentile (scan stamp -> first
  ``/cmd_vel`` logged after the scan, scans taken while commands flow) unless given,
  ``d_free`` the free distance ahead: per scan the shortest return within
  ``forward_half_angle`` of straight ahead minus ``robot_radius``, over the scans taken
  while moving; ``v_max`` is given at its 5th percentile (tight spots, the headline) and
  its median, and every moving command is checked against the bound of the scan before it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from navstack.core.params import Params
from navstack.interfaces.report_data import BagData, load_bag
from navstack.interfaces.report_metrics import (
    curvature,
    grid_path,
    grid_times,
    interpolate_xy,
    interpolate_yaw,
    moving_clearances,
    path_length,
    safe_speed,
    scan_to_cmd_latency,
    static_clearances,
    stats,
)
from navstack.interfaces.report_plots import plot_map, plot_series


class ReportParams(Params):
    """Options of ``navstack report`` (module docstring)."""

    braking_decel: float = Field(default=2.5, gt=0.0)
    latency: float | None = Field(default=None, ge=0.0)
    sample_period: float = Field(default=0.1, gt=0.0)
    forward_half_angle: float = Field(default=math.radians(15.0), gt=0.0, le=math.pi)
    robot_radius: float = Field(default=0.0, ge=0.0)
    moving_speed: float = Field(default=0.05, ge=0.0)
    trajectory_topic: str | None = None


def _r(x: float, nd: int = 4) -> float | None:
    return round(float(x), nd) if math.isfinite(x) else None


def _rs(s: dict[str, float]) -> dict[str, float | None]:
    return {k: _r(v) for k, v in s.items()}


@dataclass(frozen=True)
class Clearances:
    """Clearance at the trajectory samples ``t``: to static obstacles (NaN without a map)
    and to moving ones (NaN without ``/sim/obstacles``)."""

    t: np.ndarray
    static: np.ndarray
    moving: np.ndarray

    def minima(self, t0: float = -math.inf, t1: float = math.inf) -> dict[str, float | None]:
        inside = (self.t >= t0 - 1e-6) & (self.t <= t1 + 1e-6)
        out: dict[str, float | None] = {}
        for key, values in (("min_clearance_static_m", self.static[inside]),
                            ("min_clearance_moving_m", self.moving[inside])):
            out[key] = _r(float(np.nanmin(values))) if np.isfinite(values).any() else None
        both = [v for v in out.values() if v is not None]
        return {"min_clearance_m": min(both) if both else None, **out}


def clearances(data: BagData, p: ReportParams) -> Clearances | None:
    """Clearance on the ``sample_period`` grid (module docstring); ``None`` without a
    trajectory."""
    traj = data.trajectory
    if traj is None or not len(traj.t):
        return None
    t = grid_times(data.start, data.end, p.sample_period)
    xy = interpolate_xy(traj.t, traj.xy, t)
    yaw = interpolate_yaw(traj.t, traj.yaw, t)
    if data.footprint is None:
        data.notes.append(f"no /sim/footprint in the bag: clearance is measured from a "
                          f"circle of robot_radius {p.robot_radius:g} m")
    static = (static_clearances(data.grid, xy, yaw, data.footprint, p.robot_radius)
              if data.grid is not None else np.full(len(t), np.nan))
    moving = (moving_clearances(t, xy, yaw, data.footprint, p.robot_radius,
                                data.obstacle_t, data.obstacles)
              if data.obstacles else np.full(len(t), np.nan))
    return Clearances(t, static, moving)


def _goal_rows(data: BagData, p: ReportParams, clear: Clearances | None
               ) -> list[dict[str, Any]]:
    traj = data.trajectory
    rows = []
    for g in data.goals:
        end = g.end if g.end is not None else data.end
        row: dict[str, Any] = {"index": g.index, "status": g.status,
                               "x": _r(g.xy[0]) if g.xy else None,
                               "y": _r(g.xy[1]) if g.xy else None,
                               "start_s": _r(g.start, 3), "end_s": _r(end, 3),
                               "time_s": _r(end - g.start, 3), "path_length_m": None,
                               "min_goal_dist_m": None, "min_clearance_m": None,
                               "min_clearance_static_m": None,
                               "min_clearance_moving_m": None}
        if traj is not None and len(traj.t):
            samples = grid_path(traj.t, traj.xy, g.start, end, p.sample_period)
            row["path_length_m"] = _r(path_length(samples))
            if g.xy is not None and len(samples):
                d = np.hypot(samples[:, 0] - g.xy[0], samples[:, 1] - g.xy[1])
                row["min_goal_dist_m"] = _r(float(d.min()))
        if clear is not None:
            row.update(clear.minima(g.start, end))
        rows.append(row)
    return rows


def _safety(data: BagData, p: ReportParams) -> dict[str, Any]:
    measured = scan_to_cmd_latency(data.scan_log_t, data.scan_stamp, data.cmd_t)
    lat_stats = stats(measured)
    if p.latency is not None:
        latency, source = p.latency, "given (--latency)"
    elif measured.size:
        latency, source = lat_stats["p95"], "measured, 95th percentile"
    else:
        latency, source = 0.0, "unknown (no scan followed by a command): 0 used"
    free = data.scan_free - p.robot_radius
    traj = data.trajectory
    if traj is not None and len(traj.t) and free.size:
        moving = np.interp(data.scan_log_t, traj.t, traj.speed) > p.moving_speed
        used = free[moving] if moving.any() else free
    else:
        used = free
    out: dict[str, Any] = {
        "braking_decel_m_s2": p.braking_decel, "latency_s": _r(latency),
        "latency_source": source, "latency_measured_s": _rs(lat_stats),
        "scans": int(free.size), "scans_used": int(used.size),
        "forward_half_angle_deg": _r(math.degrees(p.forward_half_angle), 2),
        "d_free_p5_m": None, "d_free_median_m": None, "v_max_p5_m_s": None,
        "v_max_median_m_s": None, "cmd_over_bound_fraction": None,
        "cmd_over_bound_max_ratio": None}
    if used.size:
        d5, d50 = float(np.percentile(used, 5)), float(np.median(used))
        out.update(d_free_p5_m=_r(d5), d_free_median_m=_r(d50),
                   v_max_p5_m_s=_r(float(safe_speed(p.braking_decel, latency, d5))),
                   v_max_median_m_s=_r(float(safe_speed(p.braking_decel, latency, d50))))
        idx = np.searchsorted(data.scan_log_t, data.cmd_t, side="right") - 1
        fwd = (idx >= 0) & (data.cmd_vx > p.moving_speed)
        if fwd.any():
            bound = safe_speed(p.braking_decel, latency, free[idx[fwd]])
            ratio = data.cmd_vx[fwd] / np.maximum(bound, 1e-9)
            out.update(cmd_over_bound_fraction=_r(float(np.mean(ratio > 1.0))),
                       cmd_over_bound_max_ratio=_r(float(ratio.max())))
    return out


def compute_report(data: BagData, params: ReportParams | None = None) -> dict[str, Any]:
    """All report numbers as a JSON-ready dict (``report.json``)."""
    p = params or ReportParams()
    traj = data.trajectory
    clear = clearances(data, p)
    rep: dict[str, Any] = {
        "bag": str(data.path), "start_s": _r(data.start, 3), "end_s": _r(data.end, 3),
        "duration_s": _r(data.end - data.start, 3),
        "topics": {k: {"type": t, "count": n} for k, (t, n) in data.topics.items()},
        "trajectory": None, "speed_m_s": None, "angular_speed_rad_s": None,
        "curvature_1_m": None,
        "cmd_vel": {"count": int(data.cmd_t.size), "vx_m_s": _rs(stats(data.cmd_vx)),
                    "wz_abs_rad_s": _rs(stats(np.abs(data.cmd_wz)))},
        "min_clearance_m": None, "min_clearance_static_m": None,
        "min_clearance_moving_m": None, "min_scan_range_m": None, "notes": list(data.notes)}
    if traj is not None and len(traj.t):
        samples = grid_path(traj.t, traj.xy, data.start, data.end, p.sample_period)
        rep["trajectory"] = {"topic": traj.topic, "frame": traj.frame,
                             "messages": int(traj.t.size),
                             "sample_period_s": p.sample_period,
                             "path_length_m": _r(path_length(samples))}
        rep["speed_m_s"] = _rs(stats(traj.speed))
        rep["angular_speed_rad_s"] = _rs(stats(np.abs(traj.wz)))
        rep["curvature_1_m"] = _rs(stats(curvature(traj.speed, traj.wz, p.moving_speed)))
        if data.grid is not None and traj.frame != data.grid.header.frame_id:
            rep["notes"].append(f"trajectory in '{traj.frame}', map in "
                                f"'{data.grid.header.frame_id}': clearance assumes "
                                f"they coincide")
    if clear is not None:
        rep.update(clear.minima())
    if data.scan_min.size:
        rep["min_scan_range_m"] = _r(float(data.scan_min.min()))
    rep["goals"] = _goal_rows(data, p, clear)
    rep["safety"] = _safety(data, p)
    rep["params"] = p.model_dump()
    return rep


def _fmt(v: Any, nd: int = 3) -> str:
    return "–" if v is None else (f"{v:.{nd}f}" if isinstance(v, float) else str(v))


def _stat_row(name: str, s: dict[str, Any] | None) -> str:
    s = s or {}
    return (f"| {name} | {_fmt(s.get('mean'))} | {_fmt(s.get('median'))} | "
            f"{_fmt(s.get('p95'))} | {_fmt(s.get('max'))} |")


def to_markdown(rep: dict[str, Any]) -> str:
    traj = rep["trajectory"]
    src = (f"`{traj['topic']}` (frame `{traj['frame']}`, {traj['messages']} messages, "
           f"sampled every {traj['sample_period_s']} s)" if traj else "none")
    lines = [f"# navstack report — `{Path(rep['bag']).name}`", "",
             f"- recording: {_fmt(rep['duration_s'], 1)} s "
             f"({_fmt(rep['start_s'], 3)} → {_fmt(rep['end_s'], 3)})",
             f"- trajectory source: {src}",
             f"- path length: {_fmt(traj['path_length_m']) if traj else '–'} m",
             f"- minimum clearance (footprint to obstacle): to static obstacles "
             f"{_fmt(rep['min_clearance_static_m'])} m, to walkers "
             f"{_fmt(rep['min_clearance_moving_m'])} m; nearest scan return: "
             f"{_fmt(rep['min_scan_range_m'])} m", "",
             "## Motion", "", "| quantity | mean | median | p95 | max |",
             "|---|---:|---:|---:|---:|",
             _stat_row("speed [m/s]", rep["speed_m_s"]),
             _stat_row("\\|w\\| [rad/s]", rep["angular_speed_rad_s"]),
             _stat_row("curvature [1/m] (moving)", rep["curvature_1_m"]),
             _stat_row("commanded vx [m/s]", rep["cmd_vel"]["vx_m_s"]),
             _stat_row("commanded \\|wz\\| [rad/s]", rep["cmd_vel"]["wz_abs_rad_s"]), ""]
    if rep["goals"]:
        lines += ["## Goals", "", "| goal | x | y | status | time [s] | path length [m] | "
                  "min goal distance [m] | min clearance static [m] | "
                  "min clearance walkers [m] |",
                  "|---|---:|---:|---|---:|---:|---:|---:|---:|"]
        for g in rep["goals"]:
            lines.append(f"| {g['index']} | {_fmt(g['x'], 2)} | {_fmt(g['y'], 2)} | "
                         f"{g['status']} | {_fmt(g['time_s'], 1)} | "
                         f"{_fmt(g['path_length_m'])} | {_fmt(g['min_goal_dist_m'])} | "
                         f"{_fmt(g['min_clearance_static_m'])} | "
                         f"{_fmt(g['min_clearance_moving_m'])} |")
        lines.append("")
    s = rep["safety"]
    lat = s["latency_measured_s"]
    lines += ["## Latency-aware safe speed", "",
              "v_max = −a·L + √(a²L² + 2·a·d_free)", "",
              f"- a = {s['braking_decel_m_s2']} m/s² (braking deceleration)",
              f"- L = {_fmt(s['latency_s'])} s ({s['latency_source']}); measured scan → "
              f"cmd_vel latency: median {_fmt(lat['median'])} s, p95 {_fmt(lat['p95'])} s, "
              f"max {_fmt(lat['max'])} s",
              f"- d_free: shortest return within ±{s['forward_half_angle_deg']}° ahead, "
              f"{s['scans_used']} of {s['scans']} scans (taken while moving): 5th percentile "
              f"{_fmt(s['d_free_p5_m'])} m, median {_fmt(s['d_free_median_m'])} m",
              f"- **v_max at the 5th-percentile d_free: {_fmt(s['v_max_p5_m_s'])} m/s**; at "
              f"the median: {_fmt(s['v_max_median_m_s'])} m/s",
              f"- commands above the bound of the preceding scan: "
              f"{_fmt(s['cmd_over_bound_fraction'])} of moving commands (max ratio "
              f"{_fmt(s['cmd_over_bound_max_ratio'], 2)})", "",
              "## Plots", "", "![speed](speed.png)", "", "![angular speed](angular_speed.png)",
              "", "![trajectory](trajectory.png)", ""]
    if rep["notes"]:
        lines += ["## Notes", ""] + [f"- {n}" for n in rep["notes"]] + [""]
    return "\n".join(lines)


def write_report(bag: str | Path, out: str | Path,
                 params: ReportParams | None = None) -> dict[str, Any]:
    """Read ``bag``, write report.md / report.json / the plots into ``out``; returns the
    report dict."""
    p = params or ReportParams()
    data = load_bag(bag, p.forward_half_angle, p.trajectory_topic)
    rep = compute_report(data, p)
    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    plot_series(data, out_dir / "speed.png", angular=False)
    plot_series(data, out_dir / "angular_speed.png", angular=True)
    plot_map(data, out_dir / "trajectory.png")
    (out_dir / "report.json").write_text(json.dumps(rep, indent=2) + "\n")
    (out_dir / "report.md").write_text(to_markdown(rep))
    return rep
