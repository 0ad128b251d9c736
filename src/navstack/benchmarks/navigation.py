"""``navstack bench navigation``: closed-loop navigation scenarios in the simulator.

At least 30 scenarios over the built-in worlds, generated deterministically:

* random reachable start/goal pairs (>= 3 m apart, >= 0.5 m clearance) in ``office``
  (doors 0.9 m wide, a person walking the corridor), ``warehouse`` (forklift and worker
  moving) and ``maze``;
* office room-to-room trips between the named goals (through the doors);
* a blocked aisle: a pallet that is not on the map closes warehouse aisle 1, so the
  robot must discover it, recover and reroute through the next aisle;
* unreachable goals (outside the map, inside a rack, inside a walled pocket) that must
  end FAILED with a reason within a bounded time.

The controller is the packaged DWB (``nav2_params.yaml``) unless ``controller`` names
another: ``mppi`` or ``rpp`` merge ``config/controllers/<name>.yaml`` (a Nav2-layout
``controller_server`` section) over the packaged parameters (:func:`nav2_params_for`).

Metrics: ``success_rate`` (reachable scenarios reaching the goal, and unreachable ones
failing cleanly with a reason in time), ``collisions`` (sum), the smallest clearances of
the body's outline (sampled every 0.1 s, the demo's definition) to static obstacles
(``min_clearance_static_m``) and to walkers (``min_clearance_moving_m``, worlds with
moving obstacles), issue 18's motion quality over the reachable scenarios
(``self_crossings``, ``max_length_ratio`` -- the blocked aisle is left out: it must
reroute --, ``max_sign_changes_per_10m`` over every global plan, and
``motion_quality_ok`` 1/0 for all three bounds), ``controller_cycle_ms``
(median controller compute time measured inside the runs; also ``dwb_cycle_ms`` when the
controller is DWB, the name earlier results used), ``real_time_factor`` (simulated time /
wall time of the running stack, from goal to result), ``real_time_factor_with_setup``
(including building each stack), ``unreachable_max_time_s``.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from navstack.benchmarks.chaos import Fault, attach_fault, robot_with_fault, world_with_fault
from navstack.benchmarks.common import BenchResult, Progress, no_progress
from navstack.core.errors import ConfigError, UnknownNameError
from navstack.core.msgs import Pose2D, PoseStamped
from navstack.runtime.config import load_yaml
from navstack.sim.robot import load_robot
from navstack.sim.world import World
from navstack.sim.worlds import load_world

CONTROLLERS: dict[str, str] = {
    "dwb": "dwb_core::DWBLocalPlanner",
    "mppi": "nav2_mppi_controller::MPPIController",
    "rpp": "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController",
}
"""``--controller`` names -> the Nav2 plugin each runs as ``FollowPath``."""

#: median controller cycle budgets [ms] per controller (DWB's from issue 6; MPPI's is
#: ``navstack bench mppi``'s; RPP is a handful of numpy operations)
CYCLE_BUDGET_MS: dict[str, float] = {"dwb": 5.0, "mppi": 10.0, "rpp": 2.0}


def controller_overlay_path(controller: str) -> Path:
    """The packaged ``config/controllers/<controller>.yaml``."""
    return Path(str(resources.files("navstack") / "config" / "controllers"
                    / f"{controller}.yaml"))


def merge_controller_section(base: Mapping[str, Any], overlay: Mapping[str, Any], *,
                             file: str = "") -> dict[str, Any]:
    """``base`` (a Nav2 parameter file's data) with ``overlay``'s ``controller_server``
    merged in: each key under ``controller_server.ros__parameters`` replaces the base's
    whole (a ``FollowPath`` section of another plugin must not inherit DWB keys).

    The overlay may hold nothing but ``controller_server: ros__parameters: {...}``;
    anything else is a :class:`ConfigError` naming ``file`` and the key.
    """
    for key in overlay:
        if key != "controller_server":
            raise ConfigError("a controller file holds only the controller_server section",
                              file=file, key_path=str(key),
                              suggestion="put other servers' parameters in the Nav2 "
                                         "parameter file")
    node = overlay.get("controller_server")
    params = node.get("ros__parameters") if isinstance(node, Mapping) else None
    if not isinstance(params, Mapping):
        raise ConfigError("must be a mapping with a ros__parameters mapping", file=file,
                          key_path="controller_server",
                          suggestion="controller_server: {ros__parameters: {FollowPath: "
                                     "{plugin: ...}}}")
    merged = dict(base)
    server = dict(merged.get("controller_server") or {})
    server["ros__parameters"] = {**dict(server.get("ros__parameters") or {}), **params}
    merged["controller_server"] = server
    return merged


def nav2_params_for(controller: str = "") -> dict[str, Any] | None:
    """Nav2 parameters running ``controller`` (``None``: the packaged file, DWB).

    ``""`` and ``"dwb"`` are the packaged file; ``"mppi"``/``"rpp"`` merge their packaged
    controller file over it.  Unknown names raise :class:`UnknownNameError` listing the
    known ones.
    """
    name = controller.lower()
    if name in ("", "dwb"):
        return None
    if name not in CONTROLLERS:
        raise UnknownNameError("controller", controller, CONTROLLERS)
    from navstack.interfaces.stack import default_nav2_params_path

    overlay_path = controller_overlay_path(name)
    return merge_controller_section(load_yaml(default_nav2_params_path()),
                                    load_yaml(overlay_path), file=str(overlay_path))


@dataclass(frozen=True)
class Scenario:
    name: str
    world: str
    start: Pose2D
    goal: Pose2D
    kind: str = "random"  # random | doors | blocked | unreachable
    expect_success: bool = True
    block: tuple[float, float, float, float] | None = None  # unmapped box x0, y0, x1, y1
    pocket: tuple[float, float, float, float] | None = None  # walled square, mapped
    timeout_s: float = 120.0
    fault: Fault | None = None  # the chaos suite's injected fault (chaos.py)


@dataclass
class Outcome:
    scenario: Scenario
    status: str = ""
    reason: str = ""
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    loop_wall_s: float = 0.0
    collisions: int = 0
    recoveries: int = 0
    final_dist_m: float = math.inf
    cycle_ms: list[float] = field(default_factory=list)
    min_static_m: float = math.inf
    min_moving_m: float | None = None
    motion: dict[str, Any] = field(default_factory=dict)
    fault_events: list[str] = field(default_factory=list)  # what an injected fault did

    def result_key(self) -> tuple[Any, ...]:
        """What a run of the scenario decides (no wall times): equal across processes
        and executors for one seed."""
        return (self.scenario.name, self.status, self.reason, round(self.sim_time_s, 6),
                self.collisions, self.recoveries, round(self.final_dist_m, 6),
                tuple(self.fault_events))

    @property
    def passed(self) -> bool:
        if self.scenario.expect_success:
            return self.status == "SUCCEEDED" and self.collisions == 0
        return self.status == "FAILED" and bool(self.reason) and self.collisions == 0


def _free_cells(world: World, clearance: float) -> np.ndarray:
    """Cells with at least ``clearance`` to obstacles, in the largest connected region."""
    free = world.distance_field() >= clearance
    labels, n = ndimage.label(free)
    if n == 0:
        return np.zeros((0, 2), dtype=np.int64)
    sizes = np.bincount(labels.ravel())[1:]
    keep = labels == (1 + int(np.argmax(sizes)))
    return np.argwhere(keep)


def random_pairs(world_name: str, count: int, rng: np.random.Generator,
                 min_dist: float = 3.0) -> list[Scenario]:
    world = load_world(world_name)
    cells = _free_cells(world, 0.55)
    out: list[Scenario] = []
    while len(out) < count:
        a, b = cells[rng.integers(len(cells), size=2)]
        sx, sy = world.cell_center(int(a[0]), int(a[1]))
        gx, gy = world.cell_center(int(b[0]), int(b[1]))
        if math.hypot(gx - sx, gy - sy) < min_dist:
            continue
        start = Pose2D(sx, sy, float(rng.uniform(-math.pi, math.pi)))
        goal = Pose2D(gx, gy, float(rng.uniform(-math.pi, math.pi)))
        dist = math.hypot(gx - sx, gy - sy)
        out.append(Scenario(f"{world_name}_random_{len(out)}", world_name, start, goal,
                            timeout_s=90.0 + 8.0 * dist))
    return out


def scenarios(quick: bool = False, seed: int = 7) -> list[Scenario]:
    return _suite(quick, seed)


def _suite(quick: bool = False, seed: int = 7) -> list[Scenario]:
    """The scenario suite (quick: a smaller deterministic subset for CI)."""
    rng = np.random.default_rng(seed)
    n_office, n_warehouse, n_maze = (3, 2, 1) if quick else (10, 10, 6)
    out = random_pairs("office", n_office, rng)
    out += random_pairs("warehouse", n_warehouse, rng)
    out += random_pairs("maze", n_maze, rng, min_dist=2.5)
    office = load_world("office")
    wp = office.waypoints
    trips = [("Goal_1", "Goal_2"), ("Goal_4", "Goal_3"), ("Goal_2", "Goal_1"),
             ("Goal_3", "Goal_4")]
    for a, b in trips[:1] if quick else trips:
        out.append(Scenario(f"office_{a}_to_{b}", "office", wp[a], wp[b], "doors",
                            timeout_s=240.0))
    out.append(Scenario("warehouse_blocked_aisle", "warehouse", Pose2D(8.25, 4.5, 1.5708),
                        Pose2D(8.25, 23.5, 1.5708), "blocked",
                        block=(6.9, 13.5, 9.6, 14.5), timeout_s=240.0))
    out.append(Scenario("office_goal_outside_map", "office", office.spawn,
                        Pose2D(35.0, 7.5, 0.0), "unreachable", expect_success=False,
                        timeout_s=120.0))
    if not quick:
        out.append(Scenario("warehouse_goal_in_rack", "warehouse", Pose2D(2.0, 2.0, 0.0),
                            Pose2D(10.0, 14.0, 0.0), "unreachable", expect_success=False,
                            timeout_s=120.0))
        out.append(Scenario("warehouse_walled_pocket", "warehouse", Pose2D(2.0, 2.0, 0.0),
                            Pose2D(20.0, 27.5, 0.0), "unreachable", expect_success=False,
                            pocket=(19.0, 26.5, 21.0, 28.5), timeout_s=180.0))
    return out


def _with_box(world: World, box: tuple[float, float, float, float]) -> World:
    occ = world.occupied.copy()
    x0, y0, x1, y1 = box
    c0 = int((x0 - world.origin_x) / world.resolution)
    c1 = math.ceil((x1 - world.origin_x) / world.resolution)
    r0 = int((y0 - world.origin_y) / world.resolution)
    r1 = math.ceil((y1 - world.origin_y) / world.resolution)
    occ[max(r0, 0):r1, max(c0, 0):c1] = True
    return replace(world, occupied=occ)


def _with_pocket(world: World, square: tuple[float, float, float, float]) -> World:
    x0, y0, x1, y1 = square
    t = 0.1
    for wall in ((x0, y0, x1, y0 + t), (x0, y1 - t, x1, y1), (x0, y0, x0 + t, y1),
                 (x1 - t, y0, x1, y1)):
        world = _with_box(world, wall)
    return world


def run_scenario(sc: Scenario, seed: int = 0, controller: str = "") -> Outcome:
    from navstack.core.msgs import Path as PathMsg
    from navstack.interfaces.api import Navigator, TaskResult
    from navstack.interfaces.demo import TrajectoryRecorder, leg_quality
    from navstack.interfaces.stack import NavStack

    world = load_world(sc.world)
    if sc.pocket is not None:
        world = _with_pocket(world, sc.pocket)
    map_grid = world.to_occupancy_grid()
    if sc.block is not None:
        world = _with_box(world, sc.block)  # in the simulator only, not on the map
    world = world_with_fault(world, sc.fault)  # unmapped box or people: simulator only
    robot = robot_with_fault(load_robot("diff_drive"), sc.fault)
    wall0 = time.perf_counter()
    stack = NavStack(world, robot, seed=seed, spawn=sc.start, map_grid=map_grid,
                     nav2_params=nav2_params_for(controller)).start()
    events = attach_fault(stack, sc.fault)
    outcome = Outcome(sc)
    ctrl = next(iter(stack.controller.controllers.values()))
    compute = ctrl.compute

    def timed(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return compute(*args, **kwargs)
        finally:
            outcome.cycle_ms.append((time.perf_counter() - t0) * 1e3)

    ctrl.compute = timed  # type: ignore[method-assign]  # times this instance's cycles
    recorder = TrajectoryRecorder(stack)  # true pose and clearances every 0.1 s
    stack.runtime.scheduler.create_timer(0.1, recorder.sample, first_at=stack.now)
    plans: list[np.ndarray] = []
    stack.runtime.bus.subscribe("/plan", PathMsg, lambda m: plans.append(m.as_array()[:, :2]))
    nav = Navigator(stack)
    t0 = stack.now
    loop0 = time.perf_counter()
    if nav.goToPose(PoseStamped.from_pose2d(sc.goal, "map", stack.now)):
        while not nav.isTaskComplete():
            if stack.now - t0 > sc.timeout_s:  # stop a goal the navigator has not ended
                outcome.reason = _timeout_reason(stack, sc)
                nav.cancelTask()
                break
        result = nav.getTaskResult()
        outcome.status = {TaskResult.SUCCEEDED: "SUCCEEDED", TaskResult.FAILED: "FAILED",
                          TaskResult.CANCELED: "CANCELED"}.get(nav.getResult(), "UNKNOWN")
        if outcome.status == "CANCELED":
            outcome.status = "TIMEOUT"
        if result is not None and not outcome.reason:
            outcome.reason = result.error_msg
        outcome.recoveries = int(getattr(result.result if result else None,
                                         "number_of_recoveries", 0))
    else:
        outcome.status, outcome.reason = "FAILED", nav.last_error
    outcome.sim_time_s = stack.now - t0
    outcome.loop_wall_s = time.perf_counter() - loop0
    outcome.wall_time_s = time.perf_counter() - wall0
    outcome.collisions = stack.sim.sim.collisions
    outcome.fault_events = events
    p = stack.sim.sim.pose
    outcome.final_dist_m = math.hypot(p.x - sc.goal.x, p.y - sc.goal.y)
    recorder.sample()
    outcome.min_static_m, outcome.min_moving_m = recorder.min_static, recorder.min_moving
    if sc.expect_success:
        outcome.motion = leg_quality(sc.name, recorder.array()[:, 1:3], plans)
    return outcome


def _timeout_reason(stack: Any, sc: Scenario) -> str:
    """Why the benchmark stops a running goal: its time limit, what the navigator was
    doing (:meth:`BtNavigator.activity`) and how far from the goal the robot is."""
    p = stack.sim.sim.pose
    doing = stack.navigator.activity() or "no navigation goal running"
    return (f"timed out after {sc.timeout_s:.0f} s: {doing}; "
            f"{math.hypot(p.x - sc.goal.x, p.y - sc.goal.y):.2f} m from the goal")


def _motion_metrics(outcomes: list[Outcome]) -> dict[str, float]:
    """Issue 18's bounds over the reachable scenarios' legs (module docstring)."""
    legs = [o.motion for o in outcomes if o.motion]
    ratios = [g["length_ratio"] for o in outcomes for g in [o.motion]
              if g and g["length_ratio"] is not None and o.scenario.kind != "blocked"]
    out = {"self_crossings": float(sum(g["self_crossings"] for g in legs)),
           "max_length_ratio": max(ratios, default=0.0),
           "max_sign_changes_per_10m": max((g["max_sign_changes_per_10m"] for g in legs),
                                           default=0.0)}
    out["motion_quality_ok"] = float(out["self_crossings"] == 0
                                     and out["max_length_ratio"] <= 1.15
                                     and out["max_sign_changes_per_10m"] <= 2.0)
    return out


def chaos_suite(count: int, seed: int = 7, faults: str = "all") -> list[Scenario]:
    """``count`` chaos scenarios (:func:`navstack.benchmarks.chaos.chaos_trips`)."""
    from navstack.benchmarks.chaos import chaos_trips, parse_faults

    return [Scenario(name, world, start, goal, "chaos", timeout_s=timeout, fault=fault)
            for name, world, start, goal, fault, timeout
            in chaos_trips(count, seed, parse_faults(faults))]


def run(quick: bool, data_dir: Path | None, controller: str = "",
        progress: Progress = no_progress, scenarios: int | None = None,
        executor: str = "serial", workers: int | None = None, address: str | None = None,
        faults: str = "all", seed: int = 7, report: Path | None = None) -> BenchResult:
    """The suite with ``controller`` (``dwb`` default, ``mppi``, ``rpp``) as FollowPath.

    ``scenarios``: run that many chaos scenarios (:func:`chaos_suite` from ``seed``
    with ``faults``) instead of the fixed suite; ``executor``/``workers``/``address``
    choose where they run (:mod:`navstack.benchmarks.sweep`); ``report``: a folder for
    the Markdown report and the time-to-goal plot (:mod:`navstack.benchmarks.sweep_report`).

    The executor is opened before the scenarios are drawn (a Ray cluster starts in the
    background meanwhile); ``sweep_wall_s`` runs from there to the last result with the
    executor closed, for every executor, and ``draw_s`` is the drawing's part.
    """
    from navstack.benchmarks.sweep import Job, check_executor, default_workers, open_executor

    name = controller.lower() or "dwb"
    nav2_params_for(name)  # an unknown name fails before the first scenario
    check_executor(executor, workers, address)
    if scenarios is not None and scenarios < 1:
        raise ConfigError(f"--scenarios must be >= 1, got {scenarios}", key_path="--scenarios",
                          suggestion="leave it out for the fixed suite")
    if scenarios is not None:
        from navstack.benchmarks.chaos import parse_faults

        parse_faults(faults)  # a bad fault name fails before a cluster starts
    result = BenchResult("navigation" if scenarios is None else "navigation-sweep")
    t_sweep = time.perf_counter()
    ex = open_executor(executor, workers, address)  # a Ray cluster starts in the background
    try:
        todo = (_suite(quick) if scenarios is None else chaos_suite(scenarios, seed, faults))
        draw_s = time.perf_counter() - t_sweep
        jobs = [Job(sc, i, name) for i, sc in enumerate(todo)]
        outcomes = ex.run(jobs, progress)
    finally:
        ex.close()
    sweep_wall = time.perf_counter() - t_sweep
    cycles = [c for o in outcomes for c in o.cycle_ms]
    sim_total = sum(o.sim_time_s for o in outcomes)
    loop_total = sum(o.loop_wall_s for o in outcomes)
    wall_total = sum(o.wall_time_s for o in outcomes)
    unreachable = [o for o in outcomes if not o.scenario.expect_success]
    moving = [o.min_moving_m for o in outcomes if o.min_moving_m is not None]
    result.metrics = {
        "scenarios": float(len(outcomes)),
        "success_rate": sum(o.passed for o in outcomes) / len(outcomes),
        "collisions": float(sum(o.collisions for o in outcomes)),
        "min_clearance_static_m": min(o.min_static_m for o in outcomes),
        "min_clearance_moving_m": min(moving) if moving else math.nan,
        **_motion_metrics(outcomes),
        "controller_cycle_ms": float(statistics.median(cycles)) if cycles else math.nan,
        "real_time_factor": sim_total / loop_total if loop_total > 0 else math.nan,
        "real_time_factor_with_setup": sim_total / wall_total if wall_total > 0 else math.nan,
        "unreachable_max_time_s": max((o.sim_time_s for o in unreachable), default=0.0),
        "recoveries_blocked_aisle": float(sum(o.recoveries for o in outcomes
                                              if o.scenario.kind == "blocked")),
    }
    if name == "dwb":
        result.metrics["dwb_cycle_ms"] = result.metrics["controller_cycle_ms"]
    result.metrics["sweep_wall_s"] = sweep_wall
    result.metrics["draw_s"] = draw_s
    if executor != "serial":
        result.metrics["workers"] = ex.timings.get("workers", float(workers or default_workers()))
    for key in ("cluster_start_s", "cluster_wait_s", "shutdown_s"):
        if key in ex.timings:
            result.metrics[key] = ex.timings[key]
    if scenarios is not None:
        from navstack.benchmarks.sweep_report import chaos_metrics

        result.metrics.update(chaos_metrics(outcomes))
    for o in outcomes:
        result.cases.append(case_row(o))
    failed = [c["name"] for c in result.cases if not c["passed"]]
    result.notes.append(f"controller: {name} ({CONTROLLERS[name]})")
    result.notes.append(f"executor: {executor}"
                        + (f" at {address}" if address else "")
                        + f", wall {sweep_wall:.1f} s (drawing the scenarios "
                        + f"{draw_s:.1f} s included)")
    if "cluster_start_s" in ex.timings:
        result.notes.append(
            f"ray: cluster {'joined' if address else 'started'} in "
            f"{ex.timings['cluster_start_s']:.1f} s in the background, "
            f"{ex.timings.get('cluster_wait_s', 0.0):.1f} s of it not hidden behind the "
            f"drawing; shutdown {ex.timings.get('shutdown_s', 0.0):.1f} s")
    result.notes.append(f"budgets: success_rate >= 0.95, collisions == 0, "
                        f"min_clearance_moving_m >= 0.10, motion_quality_ok == 1, "
                        f"controller_cycle_ms <= {CYCLE_BUDGET_MS[name]:g}, "
                        f"real_time_factor >= 10")
    if failed:
        result.notes.append("not passed: " + ", ".join(failed))
    if report is not None:
        from navstack.benchmarks.sweep_report import write_report

        for path in write_report(result, outcomes, report):
            result.notes.append(f"report: {path}")
    return result


def failure_category(o: Outcome) -> str:
    """Why a scenario did not pass, in a few words ("" when it passed)."""
    if o.passed:
        return ""
    if o.collisions:
        return "collision"
    if o.status == "TIMEOUT":  # "timed out after 150 s: recovering (BackUp), ..."
        doing = o.reason.split(": ", 1)[1].split(",")[0] if ": " in o.reason else ""
        return f"timeout: {doing}" if doing else "timeout"
    if not o.scenario.expect_success:
        return f"expected failure ended {o.status or 'without a status'}"
    if not o.reason:
        return f"{o.status or 'no status'} without a reason"
    parts = [part.strip() for part in o.reason.split(": ")]
    for i, part in enumerate(parts[:-1]):  # the failing server and its first cause
        if part.endswith(" failed"):
            return f"{o.status.lower()}: {part}: {parts[i + 1]}"[:100]
    return f"{o.status.lower()}: {parts[0]}"[:100]


def failure_reason(o: Outcome) -> str:
    """Why a scenario did not pass, as a sentence ("" when it passed or nothing says):
    its collisions with the closest approaches, then the navigation reason."""
    if o.passed:
        return ""
    parts = []
    if o.collisions:
        closest = [f"static {o.min_static_m:.2f} m"]
        if o.min_moving_m is not None:
            closest.append(f"moving {o.min_moving_m:.2f} m")
        parts.append(f"{o.collisions} collision{'s' if o.collisions != 1 else ''} "
                     f"(closest approach: {', '.join(closest)})")
    if o.reason:
        parts.append(o.reason)
    return "; ".join(parts)


def case_row(o: Outcome) -> dict[str, Any]:
    """One scenario's row of the result (and of the sweep report)."""
    fault = o.scenario.fault
    return {
        "name": o.scenario.name, "kind": o.scenario.kind, "passed": o.passed,
        "status": o.status, "reason": o.reason, "sim_time_s": round(o.sim_time_s, 2),
        "wall_time_s": round(o.wall_time_s, 2), "collisions": o.collisions,
        "recoveries": o.recoveries, "final_dist_m": round(o.final_dist_m, 3),
        "min_clearance_static_m": round(o.min_static_m, 4),
        "min_clearance_moving_m": (round(o.min_moving_m, 4)
                                   if o.min_moving_m is not None else None),
        **({"self_crossings": o.motion["self_crossings"],
            "length_ratio": o.motion["length_ratio"], "plans": o.motion["plans"],
            "max_sign_changes_per_10m": o.motion["max_sign_changes_per_10m"]}
           if o.motion else {}),
        **({"fault": fault.label()} if fault is not None else {}),
        **({"fault_events": "; ".join(o.fault_events)} if o.fault_events else {}),
        **({"failure": failure_category(o)} if not o.passed else {})}
