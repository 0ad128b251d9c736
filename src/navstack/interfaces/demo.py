"""The flagship demo: visit named waypoints in order in the office world.

``navstack demo`` builds the default stack (simulator with a walking person in the
corridor, costmaps, NavFn planner, DWB controller, BT navigator with recoveries), sends
one NavigateToPose goal per waypoint in the order of the waypoint file, shows live
progress, and writes ``report.json``, ``report.md`` and ``trajectory.png`` to ``--out``.
Success means every goal SUCCEEDED, the robot never touched anything and, when the Nav2
parameters declare costmap filter zones (the golf cart's campus does), no plan and no part
of the body entered a keepout zone and the true speed in each speed zone stayed within its
cap + 5 % (:mod:`navstack.interfaces.zones`).

``link`` ("udp" for the rover, "serial" for the golf cart) runs the same mission through
the robot's vehicle link: the stack drives a simulated vehicle over a real socket / pty
(:mod:`navstack.interfaces.hil`), and the report adds the link's figures (command
latency, packets, malformed, losses).
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from navstack.core.msgs import Path, Pose2D, PoseStamped
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.hil import LinkKind, hil_stack
from navstack.interfaces.motion_quality import (
    length_ratio,
    self_crossings,
    sign_changes_per_10m,
)
from navstack.interfaces.plots import plot_trajectory
from navstack.interfaces.stack import NavStack
from navstack.interfaces.zones import ZoneMonitor, zone_lines, zone_overlays, zones_respected
from navstack.navigation.waypoint_follower import load_waypoints
from navstack.sim.collision import CLEARANCE_CAP, footprint_clearances


def _config(name: str) -> FsPath:
    return FsPath(str(resources.files("navstack") / "config" / name))


def default_waypoints_path() -> FsPath:
    return _config("office_waypoints.yaml")


@dataclass(frozen=True)
class DemoSetup:
    """What ``navstack demo --robot NAME`` runs when world, waypoints and Nav2 parameters
    are not given: the flagship office mission for indoor robots, the campus route with
    Hybrid-A* + MPPI for the golf cart, a campus route with NavFn + DWB for the rover."""

    world: str
    waypoints: FsPath
    nav2_params: FsPath | None


def demo_setup(robot: str) -> DemoSetup:
    if robot == "golf_cart":
        return DemoSetup("campus", _config("campus_waypoints.yaml"),
                         _config("golf_cart_nav2_params.yaml"))
    if robot == "rover":
        return DemoSetup("campus", _config("rover_campus_waypoints.yaml"),
                         _config("rover_nav2_params.yaml"))
    return DemoSetup("office", default_waypoints_path(), None)


@dataclass
class GoalRecord:
    name: str
    status: str = "PENDING"
    time_s: float = 0.0
    path_length_m: float = 0.0
    min_goal_dist_m: float = math.inf
    recoveries: int = 0
    reason: str = ""


@dataclass
class TrajectoryRecorder:
    """Samples the true robot pose and its clearances at a fixed rate.

    Clearance (one definition with ``navstack report``, see docs/recording.md): the
    distance from the body's footprint outline to the nearest static obstacle (wall,
    furniture: occupied map cells) and, separately, to the nearest moving obstacle
    (walker); 0 on contact.  A circle about the reference point would undercount a long
    vehicle by metres."""

    stack: NavStack
    rows: list[tuple[float, float, float, float]] = field(default_factory=list)
    min_static: float = math.inf
    min_moving: float | None = None

    def sample(self) -> None:
        sim = self.stack.sim
        sim.advance()
        p = sim.sim.pose
        self.rows.append((self.stack.now, p.x, p.y, p.theta))
        body = sim.sim.footprint.at((p.x, p.y, p.theta))  # the physical body's outline
        static, moving = footprint_clearances(self.stack.world, body,
                                              sim.sim.obstacle_clocks, CLEARANCE_CAP)
        self.min_static = min(self.min_static, static)
        if moving is not None:
            self.min_moving = moving if self.min_moving is None else min(self.min_moving,
                                                                         moving)

    @property
    def min_clearance(self) -> float:
        """The smaller of the static and moving clearances [m]."""
        return self.min_static if self.min_moving is None else min(self.min_static,
                                                                   self.min_moving)

    def array(self) -> np.ndarray:
        return np.array(self.rows).reshape(-1, 4)


def leg_quality(name: str, executed_xy: np.ndarray, plans: list[np.ndarray]) -> dict[str, Any]:
    """Issue 18's motion quality of one leg: self-crossings of the driven path, its
    length over the first plan's, and the worst curvature sign-change rate of its plans
    (:mod:`navstack.interfaces.motion_quality`)."""
    rates = [sign_changes_per_10m(p) for p in plans if len(p) > 1]
    return {"name": name, "self_crossings": self_crossings(executed_xy),
            "length_ratio": round(length_ratio(executed_xy, plans[0]), 4) if plans else None,
            "plans": len(plans),
            "max_sign_changes_per_10m": round(max(rates), 3) if rates else 0.0}


def motion_summary(legs: list[dict[str, Any]]) -> dict[str, Any]:
    """The worst leg per metric and whether issue 18's bounds hold: no self-crossing,
    length ratio <= 1.15, <= 2 curvature sign changes per 10 m of plan."""
    ratios = [g["length_ratio"] for g in legs if g["length_ratio"] is not None]
    out = {"self_crossings": sum(g["self_crossings"] for g in legs),
           "max_length_ratio": max(ratios, default=0.0),
           "max_sign_changes_per_10m": max((g["max_sign_changes_per_10m"] for g in legs),
                                           default=0.0)}
    out["within_bounds"] = (out["self_crossings"] == 0 and out["max_length_ratio"] <= 1.15
                            and out["max_sign_changes_per_10m"] <= 2.0)
    return out


def _progress_line(rec: GoalRecord, idx: int, total: int, fb: Any, sim_t: float,
                   rtf: float) -> str:
    dist = getattr(fb, "distance_remaining", float("nan"))
    rec_n = getattr(fb, "number_of_recoveries", 0)
    return (f"[{idx + 1}/{total}] {rec.name:10s} distance remaining {dist:5.2f} m  "
            f"recoveries {rec_n}  sim {sim_t:6.1f} s  x{rtf:4.0f} real time")


def run_demo(out: FsPath, seed: int = 1, world: str | None = None, robot: str = "diff_drive",
             waypoints_file: str | FsPath | None = None, goal_timeout_s: float = 180.0,
             show_progress: bool = True, record: bool = False, replace_bag: bool = False,
             attach: Callable[[NavStack], Callable[[], None]] | None = None,
             link: LinkKind | None = None,
             nav2_params: FsPath | Mapping[str, Any] | None = None,
             spawn: Pose2D | None = None) -> dict[str, Any]:
    """Run the waypoint mission and write the report files; returns the report dict.

    ``record``: also write a rosbag2 (MCAP) of the run to ``out/bag`` (the recorder's
    default topics, ground truth and goals); a bag left there by an earlier run is a
    :class:`~navstack.runtime.recording.BagExistsError` unless ``replace_bag``.
    ``attach``: called with the stack once it is built (live viewers: web dashboard,
    Foxglove); returns the function that detaches them when the mission ends.
    ``link``: run through the robot's vehicle link (module docstring); ``nav2_params``:
    instead of the robot's packaged Nav2 file; ``spawn``: instead of the world's spawn
    pose (the link benchmark measures the route's sensitivity with it).
    """
    out.mkdir(parents=True, exist_ok=True)
    setup = demo_setup(robot)
    world = world or setup.world
    waypoints = load_waypoints(waypoints_file or setup.waypoints)
    params = setup.nav2_params if nav2_params is None else nav2_params
    wall0 = time.perf_counter()
    vehicle_link = None
    if link is not None:
        stack, vehicle_link = hil_stack(world, robot, params, seed, link, spawn=spawn)
        try:
            stack.start()
        except BaseException:
            vehicle_link.close()
            raise
    else:
        stack = NavStack(world, robot, nav2_params=params, seed=seed, spawn=spawn).start()
    bag = None
    if record:
        from navstack.runtime.recording import BagRecorder

        bag = BagRecorder(stack.runtime, out / "bag", replace=replace_bag)
    nav = Navigator(stack)
    recorder = TrajectoryRecorder(stack)
    stack.runtime.scheduler.create_timer(0.1, recorder.sample, first_at=stack.now)
    zones = ZoneMonitor(stack)
    plans: list[np.ndarray] = []
    stack.runtime.bus.subscribe("/plan", Path, lambda p: plans.append(p.as_array()[:, :2]))
    records = [GoalRecord(name) for name, _ in waypoints]
    live = _Live(show_progress)
    detach = attach(stack) if attach is not None else None
    legs: list[dict[str, Any]] = []
    try:
        for i, ((_, pose), rec) in enumerate(zip(waypoints, records, strict=True)):
            k0, n0 = len(plans), len(recorder.rows)
            _run_goal(nav, stack, recorder, pose, rec, i, len(records), goal_timeout_s, live)
            legs.append(leg_quality(rec.name, recorder.array()[n0:, 1:3], plans[k0:]))
    finally:  # a recording stays readable even if a goal raised
        bag_summary = bag.close() if bag is not None else None
        if detach is not None:
            detach()
        link_report = vehicle_link.report() if vehicle_link is not None else None
        if vehicle_link is not None:
            vehicle_link.close()
    live.close()
    wall = time.perf_counter() - wall0
    traj = recorder.array()
    collisions = stack.sim.sim.collisions
    zone_summary = zones.summary() if zones else None
    success = (all(r.status == "SUCCEEDED" for r in records) and collisions == 0
               and (zone_summary is None or zones_respected(zone_summary)))
    report: dict[str, Any] = {
        "success": success,
        "world": world, "robot": robot, "seed": seed,
        "goals": [{"name": r.name, "status": r.status, "time_s": round(r.time_s, 3),
                   "path_length_m": round(r.path_length_m, 4),
                   "min_goal_dist_m": round(r.min_goal_dist_m, 4),
                   "recoveries": r.recoveries, "reason": r.reason} for r in records],
        "collisions": collisions,
        "min_clearance_m": round(recorder.min_clearance, 4),
        "min_clearance_static_m": round(recorder.min_static, 4),
        "min_clearance_moving_m": (round(recorder.min_moving, 4)
                                   if recorder.min_moving is not None else None),
        "motion_quality": {"legs": legs, **motion_summary(legs)},
        "sim_time_s": round(stack.now, 3),
        "wall_time_s": round(wall, 3),
        "real_time_factor": round(stack.now / wall, 2) if wall > 0 else 0.0,
    }
    if zone_summary is not None:
        report["zones"] = zone_summary
        for line in zone_lines(zone_summary):
            live.done(line)
    if bag_summary is not None:
        report["bag"] = {"path": str(bag_summary.path), "messages": bag_summary.messages}
    if link_report is not None:
        report["link"] = link_report
    np.savetxt(out / "trajectory.csv", traj, delimiter=",", header="t,x,y,theta", fmt="%.4f",
               comments="")
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    (out / "report.md").write_text(_markdown(report))
    goals_xy = {name: (p.pose.position.x, p.pose.position.y) for name, p in waypoints}
    plot_trajectory(stack.world.to_occupancy_grid(), traj[:, 1:3], plans, goals_xy,
                    out / "trajectory.png",
                    title=f"navstack demo: {world}, {' -> '.join(r.name for r in records)}",
                    zones=zone_overlays(zones))
    return report


def _run_goal(nav: Navigator, stack: NavStack, recorder: TrajectoryRecorder, pose: PoseStamped,
              rec: GoalRecord, idx: int, total: int, timeout: float, live: _Live) -> None:
    t0 = stack.now
    n0 = len(recorder.rows)
    gx, gy = pose.pose.position.x, pose.pose.position.y
    if not nav.goToPose(pose):
        rec.status, rec.reason = "FAILED", nav.last_error
        return
    wall0, sim0 = time.perf_counter(), stack.now
    while not nav.isTaskComplete():
        if stack.now - t0 > timeout:
            nav.cancelTask()
            rec.reason = f"timed out after {timeout:.0f} s"
            break
        wall = time.perf_counter() - wall0
        live.update(_progress_line(rec, idx, total, nav.getFeedback(), stack.now,
                                   (stack.now - sim0) / wall if wall > 0 else 0.0))
    result = nav.getTaskResult()
    rec.status = {TaskResult.SUCCEEDED: "SUCCEEDED", TaskResult.CANCELED: "CANCELED",
                  TaskResult.FAILED: "FAILED"}.get(nav.getResult(), "UNKNOWN")
    if result is not None and result.error_msg and not rec.reason:
        rec.reason = result.error_msg
    payload = result.result if result is not None else None
    rec.recoveries = int(getattr(payload, "number_of_recoveries", 0))
    rec.time_s = stack.now - t0
    seg = recorder.array()[n0:, 1:3]
    if len(seg) > 1:
        rec.path_length_m = float(np.sum(np.hypot(*np.diff(seg, axis=0).T)))
    if len(seg):
        rec.min_goal_dist_m = float(np.min(np.hypot(seg[:, 0] - gx, seg[:, 1] - gy)))
    live.done(f"[{idx + 1}/{total}] {rec.name:10s} {rec.status:9s} in {rec.time_s:6.1f} s, "
              f"{rec.path_length_m:5.2f} m driven, closest {rec.min_goal_dist_m:.3f} m"
              + (f" — {rec.reason}" if rec.reason else ""))


def _motion_line(m: dict[str, Any] | None) -> str:
    if not m:
        return "- motion quality: not measured"
    return (f"- motion quality: {m['self_crossings']} self-crossings, executed / first plan "
            f"length at most {m['max_length_ratio']:.2f}, at most "
            f"{m['max_sign_changes_per_10m']:.1f} curvature sign changes per 10 m of plan "
            f"({'within' if m['within_bounds'] else 'outside'} issue 18's bounds)")


class _Live:
    """One status line that rewrites itself on a terminal, plain lines otherwise."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.tty = sys.stdout.isatty()
        self._last = 0.0

    def update(self, line: str) -> None:
        if self.enabled and self.tty and time.perf_counter() - self._last > 0.1:
            self._last = time.perf_counter()
            sys.stdout.write("\r\033[K" + line)
            sys.stdout.flush()

    def done(self, line: str) -> None:
        if self.enabled:
            sys.stdout.write(("\r\033[K" if self.tty else "") + line + "\n")
            sys.stdout.flush()

    def close(self) -> None:
        if self.enabled and self.tty:
            sys.stdout.write("\r\033[K")


def _markdown(r: dict[str, Any]) -> str:
    lines = [f"# navstack demo report — {'SUCCESS' if r['success'] else 'FAILURE'}", "",
             f"World `{r['world']}`, robot `{r['robot']}`, seed {r['seed']}.", "",
             "| goal | status | time [s] | path length [m] | min goal distance [m] | "
             "recoveries |", "|---|---|---:|---:|---:|---:|"]
    for g in r["goals"]:
        lines.append(f"| {g['name']} | {g['status']} | {g['time_s']:.1f} | "
                     f"{g['path_length_m']:.2f} | {g['min_goal_dist_m']:.3f} | "
                     f"{g['recoveries']} |")
    lines += ["", f"- collisions: {r['collisions']}",
              f"- minimum clearance (footprint to obstacle): to static obstacles "
              f"{r['min_clearance_static_m']:.3f} m, to walkers "
              + (f"{r['min_clearance_moving_m']:.3f} m" if r['min_clearance_moving_m']
                 is not None else "– (none in this world)"),
              _motion_line(r.get("motion_quality")),
              f"- simulated time: {r['sim_time_s']:.1f} s, wall time: {r['wall_time_s']:.1f} s "
              f"(real-time factor {r['real_time_factor']:.1f})",
              *(f"- {line}" for line in zone_lines(r.get("zones"))), "",
              "![trajectory](trajectory.png)", ""]
    failed = [g for g in r["goals"] if g["reason"]]
    if failed:
        lines += ["## Failures", ""] + [f"- {g['name']}: {g['reason']}" for g in failed] + [""]
    return "\n".join(lines)
