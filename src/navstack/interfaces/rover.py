"""The rover's missions on a simulated stack: setup, truth scoring and the demo.

:func:`rover_run` builds what the rover's legs need on the mars yard course: the course's
world (rocks, marker posts with their ArUco markers) and georeferenced rover profile, the
rover's Nav2 file (its twist_mux: navigation 50, joystick 100), the camera and ArUco
chain (corners mode by default: the camera's projected marker corners with pixel noise
go through the detector's PnP, as images would), and the :class:`~navstack.missions.
rover_tree.RoverMission` node.  With ``link="udp"`` the stack drives the simulated VCU
over UDP on loopback (:mod:`navstack.interfaces.hil`): commands go out as the VCU string,
odometry and GNSS come back as VCU packets.

:class:`TruthMonitor` scores a leg on the simulator's truth every 0.1 s: the closest
approach to each post, and gate crossings -- the segment between the two true posts
crossed by ``base_link``, with the heading relative to the gate normal.

:func:`run_rover_demo` is ``navstack demo --robot rover``: one leg of each kind (the
course's ``demo`` section) one after another, through the UDP VCU link.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np

from navstack.core.msgs import Pose2D
from navstack.interfaces.hil import VehicleLink
from navstack.interfaces.perception import PerceptionOptions, attach_perception
from navstack.interfaces.stack import NavStack
from navstack.missions.rover_behaviours import segment_crossing
from navstack.missions.rover_context import TaskStatus
from navstack.missions.rover_tree import GoToGpsRequest, RoverMission, RoverMissionParams
from navstack.sim.course import Course, CourseLeg, course_robot, course_world, load_course

__all__ = ["LegOutcome", "RoverRun", "TruthMonitor", "rover_nav2_params", "rover_run",
           "run_leg", "run_rover_demo"]


def rover_nav2_params() -> str:
    return str(resources.files("navstack") / "config" / "rover_nav2_params.yaml")


class TruthMonitor:
    """True closest approach to each post and gate crossings (module docstring)."""

    def __init__(self, stack: NavStack, course: Course, period: float = 0.1) -> None:
        self.stack = stack
        self.course = course
        self.closest: dict[int, float] = {p.id: math.inf for p in course.posts}
        self.crossings: list[dict[str, Any]] = []
        self.path: list[tuple[float, float, float, float]] = []
        self._last: Pose2D | None = None
        stack.runtime.scheduler.create_timer(period, self._sample, first_at=stack.now)

    def _sample(self) -> None:
        sim = self.stack.sim
        sim.advance()
        p = sim.sim.pose
        self.path.append((self.stack.now, p.x, p.y, p.theta))
        for post in self.course.posts:
            d = math.hypot(p.x - post.x, p.y - post.y)
            self.closest[post.id] = min(self.closest[post.id], d)
        last = self._last
        self._last = p
        if last is None:
            return
        for gate in self.course.gates:
            a, b = (self.course.post(i) for i in gate.posts)
            if segment_crossing((last.x, last.y), (p.x, p.y), (a.x, a.y), (b.x, b.y)):
                normal = math.atan2(b.x - a.x, -(b.y - a.y))  # either way through
                off = abs(math.remainder(p.theta - normal, math.pi))
                self.crossings.append({"gate": gate.name, "t": round(self.stack.now, 2),
                                       "heading_off_normal_deg": round(math.degrees(off), 1)})

    def reset(self) -> None:
        self.closest = {k: math.inf for k in self.closest}
        self.crossings = []

    def true_distance(self, post_id: int) -> float:
        post = self.course.post(post_id)
        p = self.stack.sim.sim.pose
        return math.hypot(p.x - post.x, p.y - post.y)


@dataclass
class RoverRun:
    stack: NavStack
    course: Course
    mission: RoverMission
    truth: TruthMonitor
    link: VehicleLink | None = None

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
            self.link = None


def rover_run(seed: int, spawn: Pose2D | None = None, course_file: str | Path | None = None,
              link: Literal["udp"] | None = None, camera_mode: Literal["image", "corners"]
              = "corners", variant: str = "nav2") -> RoverRun:
    """A started stack on the course with perception and the rover mission (module
    docstring)."""
    course = load_course(course_file)
    robot = course_robot(course)
    world = course_world(course)
    vehicle_link = None
    if link is not None:
        vehicle_link = VehicleLink(robot, link)
        stack = NavStack(world, vehicle_link.robot, rover_nav2_params(), seed=seed, spawn=spawn,
                         localization="external", extensions=[vehicle_link])
    else:
        stack = NavStack(world, robot, rover_nav2_params(), seed=seed, spawn=spawn)
    try:
        stack.start()
        sizes = {p.id: p.marker_size for p in course.posts}
        size = max(set(sizes.values()), key=list(sizes.values()).count) if sizes else 0.2
        attach_perception(stack, PerceptionOptions(
            camera_mode=camera_mode, gripper=False,
            detector={"marker_size": size, "marker_sizes": sizes}))
        mount = robot.sensors.gnss.mount
        radius = max((p.radius for p in course.posts), default=0.15)
        mission = RoverMission(stack.runtime, RoverMissionParams.from_mapping({
            "antenna": (mount.x, mount.y), "post_radius": radius,
            "camera_range": robot.sensors.camera.max_range + 3.0,
            "tree": {"variant": variant}})).start()
        truth = TruthMonitor(stack, course)
    except BaseException:
        if vehicle_link is not None:
            vehicle_link.close()
        raise
    return RoverRun(stack, course, mission, truth, vehicle_link)


@dataclass
class LegOutcome:
    """One leg scored on the truth."""

    leg: str
    kind: str
    status: str
    reason: str
    leg_time: float
    search_time: float | None
    true_post_m: dict[int, float] = field(default_factory=dict)
    crossings: list[dict[str, Any]] = field(default_factory=list)
    collisions: int = 0
    passed: bool = False

    def row(self) -> dict[str, Any]:
        return {"leg": self.leg, "kind": self.kind, "status": self.status,
                "passed": self.passed, "leg_s": round(self.leg_time, 1),
                "search_s": None if self.search_time is None else round(self.search_time, 1),
                "true_post_m": {str(k): round(v, 3) for k, v in self.true_post_m.items()},
                "crossings": self.crossings, "collisions": self.collisions,
                "reason": self.reason}


POST_PASS_M = 2.0
GATE_HEADING_DEG = 45.0


def run_leg(run: RoverRun, leg: CourseLeg, timeout: float = 400.0, settle: float = 1.0
            ) -> LegOutcome:
    """Send ``leg`` to the rover mission (``/rover/go_to_gps``), run until it ends, and
    score it on the truth: a post leg passes with the post within 2 m of ``base_link``
    at the end; a gate leg when the rover crossed the segment between the gate's posts
    with its heading within 45 degrees of the gate normal; a GNSS leg on the mission's
    own result.  Every kind needs the task SUCCEEDED and no collision."""
    stack, course, mission = run.stack, run.course, run.mission
    ids = course.leg_post_ids(leg)
    sim = stack.sim.sim
    before = sim.collisions
    run.truth.reset()
    start = stack.now
    answer = stack.runtime.bus.call("/rover/go_to_gps", GoToGpsRequest(
        leg.latitude, leg.longitude, ids, leg.name))
    if not answer.get("accepted"):
        raise RuntimeError(f"leg {leg.name}: refused: {answer.get('reason')}")
    bb = mission.bb
    while bb.status is TaskStatus.RUNNING and stack.now - start < timeout:
        stack.run_for(0.5)
    if bb.status is TaskStatus.RUNNING:
        stack.runtime.bus.call("/rover/stop_mission", None)
        status, reason = "timeout", f"not done within {timeout:.0f} s"
    else:
        status, reason = bb.status.value, bb.reason
    end = bb.ended if bb.ended is not None else stack.now
    search = (end - bb.goal_reached_at if bb.goal_reached_at is not None and ids else None)
    stack.run_for(settle)
    out = LegOutcome(leg.name, leg.kind, status, reason, end - start, search,
                     collisions=sim.collisions - before)
    ok = status == TaskStatus.SUCCEEDED.value and out.collisions == 0
    if leg.kind == "post":
        out.true_post_m = {i: run.truth.true_distance(i) for i in ids}
        ok = ok and all(d <= POST_PASS_M for d in out.true_post_m.values())
    elif leg.kind == "gate":
        out.true_post_m = {i: run.truth.true_distance(i) for i in ids}
        out.crossings = [c for c in run.truth.crossings if c["gate"] == leg.gate]
        ok = ok and any(c["heading_off_normal_deg"] <= GATE_HEADING_DEG for c in out.crossings)
    out.passed = bool(ok)
    return out


def demo_legs(course: Course) -> tuple[Pose2D, list[CourseLeg]]:
    """The course's ``demo`` section: start pose and legs (one of each kind)."""
    if course.demo is None:
        raise ValueError("the course has no demo section (demo: {start, legs})")
    s = course.demo.start
    return Pose2D(s.x, s.y, s.yaw), [course.leg(name) for name in course.demo.legs]


def run_rover_demo(out: Path, seed: int = 1, course_file: str | Path | None = None,
                   link: Literal["udp"] | None = "udp", leg_timeout: float = 400.0,
                   show_progress: bool = True) -> dict[str, Any]:
    """``navstack demo --robot rover``: the course's demo legs through the VCU link;
    writes ``report.json``, ``report.md`` and ``trajectory.csv`` to ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    course = load_course(course_file)
    spawn, legs = demo_legs(course)
    wall0 = time.perf_counter()
    run = rover_run(seed, spawn, course_file, link=link)
    outcomes: list[LegOutcome] = []
    try:
        for i, leg in enumerate(legs):
            res = run_leg(run, leg, leg_timeout)
            outcomes.append(res)
            if show_progress:
                extra = (f", search {res.search_time:.0f} s" if res.search_time is not None
                         else "")
                print(f"[{i + 1}/{len(legs)}] {leg.name:8s} ({leg.kind}) "
                      f"{'PASS' if res.passed else 'FAIL'} {res.status} in "
                      f"{res.leg_time:.0f} s{extra}: {res.reason}", flush=True)
        link_report = run.link.report() if run.link is not None else None
    finally:
        run.close()
    collisions = run.stack.sim.sim.collisions
    wall = time.perf_counter() - wall0
    report: dict[str, Any] = {
        "success": all(o.passed for o in outcomes) and collisions == 0,
        "robot": "rover", "world": course.world, "seed": seed,
        "legs": [o.row() for o in outcomes], "collisions": collisions,
        "sim_time_s": round(run.stack.now, 2), "wall_time_s": round(wall, 2),
        "events": [[round(t, 2), e] for t, e in run.mission.ctx.events]}
    if link_report is not None:
        report["link"] = link_report
    np.savetxt(out / "trajectory.csv", np.array(run.truth.path).reshape(-1, 4),
               delimiter=",", header="t,x,y,theta", fmt="%.4f", comments="")
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    lines = [f"# navstack rover demo -- {'SUCCESS' if report['success'] else 'FAILURE'}", "",
             f"Course `{course.world}`, seed {seed}, link {link or 'in-process'}.", "",
             "| leg | kind | passed | status | time [s] | search [s] | true post distance [m] "
             "| crossings |", "|---|---|---|---|---:|---:|---|---|"]
    for o in outcomes:
        r = o.row()
        lines.append(f"| {o.leg} | {o.kind} | {o.passed} | {o.status} | {r['leg_s']} | "
                     f"{r['search_s'] if r['search_s'] is not None else '-'} | "
                     f"{r['true_post_m'] or '-'} | {r['crossings'] or '-'} |")
    lines += ["", f"- collisions: {collisions}",
              f"- simulated {report['sim_time_s']:.0f} s in {report['wall_time_s']:.0f} s", ""]
    (out / "report.md").write_text("\n".join(lines))
    return report
