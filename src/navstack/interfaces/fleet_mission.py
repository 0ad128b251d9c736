"""The fleet mission: every robot drives its own route at the same time; one report.

Each robot's route is a sequence of NavigateToPose goals sent to that robot's
``/<robot>/navigate_to_pose`` (its own BT navigator), the next as soon as the previous
ended, all robots concurrently on the fleet's one clock.  A goal that does not end within
the fleet's ``goal_timeout`` is canceled and recorded as such.  Success: every goal of
every robot SUCCEEDED and no robot touched anything -- walls, walkers or another robot.

The report (``report.json``, ``report.md``, ``fleet.png``) carries per robot its goals
(status, time, reason), collisions (robot-robot among them) and distance driven, and for
the fleet the smallest body-to-body distance any two robots came to
(:attr:`~navstack.sim.fleet.FleetSimulator.min_separation`).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from navstack.core.msgs import Pose2D, PoseStamped
from navstack.interfaces.fleet import Fleet, FleetRobotParams
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, GoalHandle, GoalStatus

SPIN = 0.1
"""Simulated seconds between looks at the goals (and trajectory samples)."""


@dataclass
class GoalOutcome:
    name: str
    status: str = "PENDING"
    time_s: float = 0.0
    reason: str = ""


@dataclass
class RobotRun:
    """One robot's progress through its route."""

    spec: FleetRobotParams
    client: ActionClient[m.NavigateToPoseGoal]
    goals: list[GoalOutcome]
    index: int = -1
    handle: GoalHandle[m.NavigateToPoseGoal] | None = None
    started: float = 0.0
    trail: list[tuple[float, float, float]] = field(default_factory=list)

    @property
    def finished(self) -> bool:
        return self.index >= len(self.goals)

    @property
    def current(self) -> str:
        return self.goals[self.index].name if 0 <= self.index < len(self.goals) else ""


def goal_pose(pose: tuple[float, float, float], stamp: float) -> PoseStamped:
    return PoseStamped.from_pose2d(Pose2D(*pose), "map", stamp)


class FleetMission:
    """Drives every robot of a started :class:`Fleet` through its route."""

    def __init__(self, fleet: Fleet) -> None:
        self.fleet = fleet.start()
        self.runs: dict[str, RobotRun] = {
            r.name: RobotRun(r, ActionClient(fleet.runtime(r.name).bus, m.NAVIGATE_TO_POSE),
                             [GoalOutcome(g.name) for g in r.route])
            for r in fleet.members}

    @property
    def done(self) -> bool:
        return all(run.finished for run in self.runs.values())

    def step(self) -> None:
        """Start or finish goals, then advance every robot by :data:`SPIN` seconds."""
        now = self.fleet.now
        timeout = self.fleet.params.goal_timeout
        for run in self.runs.values():
            self._sample(run)
            if run.handle is not None and not run.handle.done and \
                    now - run.started > timeout:
                run.goals[run.index].reason = f"timed out after {timeout:.0f} s"
                run.handle.cancel()
            if run.handle is None or run.handle.done:
                self._next(run, now)
        if not self.done:
            self.fleet.run_for(SPIN)

    def _sample(self, run: RobotRun) -> None:
        p = self.fleet.physics.sim(run.spec.name).pose
        run.trail.append((p.x, p.y, p.theta))

    def _next(self, run: RobotRun, now: float) -> None:
        if run.handle is not None:  # the current goal ended: record it
            outcome = run.goals[run.index]
            result = run.handle.result
            status = result.status if result is not None else GoalStatus.FAILED
            outcome.status = status.name
            outcome.time_s = round(now - run.started, 3)
            if result is not None and result.error_msg and not outcome.reason:
                outcome.reason = result.error_msg
            run.handle = None
        run.index += 1
        if run.finished:
            return
        goal = run.spec.route[run.index]
        run.started = now
        run.handle = run.client.send_goal(m.NavigateToPoseGoal(goal_pose(goal.pose, now)))
        if run.handle.status is GoalStatus.REJECTED:
            run.goals[run.index].reason = (run.handle.result.error_msg
                                           if run.handle.result else "rejected")

    def run(self, max_s: float = math.inf,
            progress: Callable[[FleetMission], None] | None = None) -> None:
        """Step until every route ended (or ``max_s`` simulated seconds passed)."""
        while not self.done and self.fleet.now < max_s:
            self.step()
            if progress is not None:
                progress(self)
        for run in self.runs.values():  # a run cut short by max_s: cancel what is open
            if run.handle is not None and not run.handle.done:
                run.goals[run.index].reason = f"mission stopped at {max_s:.0f} s"
                run.handle.cancel()
                self._next(run, self.fleet.now)

    def status(self) -> dict[str, dict[str, Any]]:
        """Per robot: current goal, distance remaining and goals done (the fleet view)."""
        out = {}
        for name, run in self.runs.items():
            fb = run.handle.feedback if run.handle is not None else None
            out[name] = {"goal": run.current,
                         "distance_remaining": getattr(fb, "distance_remaining", None),
                         "done": sum(g.status != "PENDING" for g in run.goals),
                         "total": len(run.goals),
                         "succeeded": sum(g.status == "SUCCEEDED" for g in run.goals)}
        return out

    def report(self, wall_s: float) -> dict[str, Any]:
        fleet = self.fleet
        robots = []
        for name, run in self.runs.items():
            sim = fleet.physics.sim(name)
            robots.append({"name": name, "goals": [vars(g) for g in run.goals],
                           "succeeded": all(g.status == "SUCCEEDED" for g in run.goals),
                           "collisions": sim.collisions,
                           "robot_collisions": sim.robot_collisions,
                           "distance_m": round(sim.distance_travelled, 3)})
        collisions = fleet.physics.collisions
        return {
            "success": all(r["succeeded"] for r in robots) and collisions == 0,
            "fleet": fleet.params.name, "world": fleet.params.world,
            "robot": fleet.params.robot, "seed": fleet.params.seed,
            "robots": robots,
            "collisions": collisions,
            "robot_robot_collisions": fleet.physics.robot_collisions,
            "min_robot_distance_m": round(fleet.physics.min_separation, 4),
            "closest_robots": _closest(fleet),
            "sim_time_s": round(fleet.now, 3),
            "wall_time_s": round(wall_s, 3),
            "real_time_factor": round(fleet.now / wall_s, 2) if wall_s > 0 else 0.0,
        }


def _closest(fleet: Fleet) -> dict[str, Any] | None:
    at = fleet.physics.min_separation_at
    return None if at is None else {"time_s": round(at[0], 2), "robots": list(at[1:])}


def run_fleet(fleet: Fleet, out: FsPath | None = None, max_s: float = 900.0,
              progress: Callable[[FleetMission], None] | None = None) -> dict[str, Any]:
    """Run the fleet mission; write ``report.json``, ``report.md`` and ``fleet.png`` to
    ``out`` when given.  Returns the report."""
    wall0 = time.perf_counter()
    mission = FleetMission(fleet)
    mission.run(max_s, progress)
    report = mission.report(time.perf_counter() - wall0)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
        (out / "report.md").write_text(markdown(report))
        plot_fleet(mission, out / "fleet.png")
    return report


def markdown(report: dict[str, Any]) -> str:
    lines = [f"# Fleet {report['fleet']} in {report['world']}: "
             f"{'SUCCESS' if report['success'] else 'FAILURE'}", "",
             f"- robots: {len(report['robots'])} ({report['robot']}), seed {report['seed']}",
             f"- collisions: {report['collisions']} (robot-robot "
             f"{report['robot_robot_collisions']})",
             f"- closest two robots came (body to body): {report['min_robot_distance_m']:.3f} m",
             f"- simulated {report['sim_time_s']:.1f} s in {report['wall_time_s']:.1f} s "
             f"(x{report['real_time_factor']:.1f} real time)", "",
             "| robot | goal | status | time [s] | reason |", "|---|---|---|---|---|"]
    for r in report["robots"]:
        for g in r["goals"]:
            lines.append(f"| {r['name']} | {g['name']} | {g['status']} | {g['time_s']:.1f} | "
                         f"{g['reason']} |")
    return "\n".join(lines) + "\n"


def format_summary(report: dict[str, Any]) -> list[str]:
    """The lines ``navstack fleet`` prints."""
    out = []
    for r in report["robots"]:
        goals = ", ".join(f"{g['name']} {g['status']} {g['time_s']:.1f} s"
                          + (f" ({g['reason']})" if g["reason"] else "") for g in r["goals"])
        out.append(f"/{r['name']}: {goals}; collisions {r['collisions']} "
                   f"(robot-robot {r['robot_collisions']}), {r['distance_m']:.1f} m driven")
    out.append(f"fleet: {'SUCCESS' if report['success'] else 'FAILURE'}, collisions "
               f"{report['collisions']} (robot-robot {report['robot_robot_collisions']}), "
               f"closest robots {report['min_robot_distance_m']:.3f} m, "
               f"sim {report['sim_time_s']:.1f} s in {report['wall_time_s']:.1f} s")
    return out


def plot_fleet(mission: FleetMission, path: FsPath) -> None:
    """Map, every robot's driven trail (one colour per robot) and its goals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    world = mission.fleet.world
    grid = world.to_occupancy_grid()
    info = grid.info
    o = info.origin.position
    extent = (o.x, o.x + info.width * info.resolution, o.y, o.y + info.height * info.resolution)
    fig, ax = plt.subplots(figsize=(10, 10 * info.height / max(info.width, 1) + 0.8))
    ax.imshow(np.where(grid.data == 100, 0.15, 1.0), origin="lower", extent=extent,
              cmap="gray", vmin=0, vmax=1)
    for i, (name, run) in enumerate(mission.runs.items()):
        colour = f"C{i}"
        trail = np.array(run.trail).reshape(-1, 3)
        if len(trail):
            ax.plot(trail[:, 0], trail[:, 1], "-", color=colour, lw=2.0, label=f"/{name}")
            ax.plot(trail[0, 0], trail[0, 1], "o", color=colour, ms=8)
        for g in run.spec.route:
            ax.plot(g.pose[0], g.pose[1], "*", color=colour, ms=14)
            ax.annotate(g.name, g.pose[:2], textcoords="offset points", xytext=(6, 6),
                        fontsize=8)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"navstack fleet: {mission.fleet.params.name}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
