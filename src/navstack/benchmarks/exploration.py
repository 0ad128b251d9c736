"""``navstack bench exploration``: frontier exploration with SLAM, scored against the truth.

For each world (office, warehouse, arena), seed (1..5) and strategy (``explore_lite``:
explore_lite's cost and semantics; ``information_gain``: navstack's) the TurtleBot3 Waffle
Pi explores from the world's spawn with live SLAM (:func:`navstack.missions.explore.
explore_mission`, the ``navstack mission explore`` setup) and returns home.  Per run:

* time to 90 % and 95 % of the *reachable free space* observed (the world's free cells the
  robot can see from where it fits, known in the published ``/map``);
* final map IoU (observable wall surfaces, :func:`~navstack.mapping.map_metrics.occupancy_iou`),
  path length, collisions, the true distance to the start at the end;
* SLAM map update latency (scan -> ``/map``: the simulated wait for the update plus the
  wall time the update took, :class:`~navstack.interfaces.mission_eval.SlamLatency`) and
  goal-to-first-motion, p95 (the bench's
  goal-to-first-motion p95 is over every goal of all its runs -- a run sends only 1-6
  goals to a standing robot, so a run's own p95 is its slowest start; the worst run's
  is reported beside it);
* success = SUCCEEDED, >= 95 % observed, home within 0.3 m, no collision.

The reference is an idealised greedy nearest-frontier explorer on the same world
(:func:`navstack.exploration.ideal.run_ideal`: perfect localisation, instant turns, the
same lidar, the navigation speed limit); each run's time to 90 % is divided by it.

Budgets (issue 16): success in >= 14 of 15 runs per strategy; the information-gain
strategy's (navstack's default) median time to 90 % <= 2 x the reference on every world and
below explore_lite's; explore_lite's ratio is reported as the peer's (``peer:`` notes), not
budgeted -- with the TurtleBot course's ``potential_scale`` 1e-3 it drives to the largest
frontier anywhere, which is the behaviour reproduced (docs/decisions.md, "Exploration
budgets"); SLAM map update latency p95 <= 1 s and goal-to-first-motion
p95 <= 0.4 s (the TurtleBot course's figures).  ``--quick``: the arena, one seed, both
strategies (the CI subset); ``--workers N``: N cases at a time, in processes;
``--worlds``, ``--seeds``, ``--strategies`` (comma lists) and ``--localization perfect``
select a part (one run at a time on a shared machine).
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from navstack.benchmarks.common import BenchResult
from navstack.core.errors import ConfigError

WORLDS = ("office", "warehouse", "arena")
STRATEGIES = ("explore_lite", "information_gain")
SEEDS = (1, 2, 3, 4, 5)
#: a run is stopped (FAILED) after this many simulated seconds: a net for a wedged run,
#: not a speed test (BUDGET_RATIO is), so about 5x the reference or more (office 533 s,
#: warehouse 1603 s, arena 9 s).  6000 s in the warehouse cut off explore_lite runs that
#: had 96 % observed and were on their way home
MAX_DURATION = {"office": 3000.0, "warehouse": 8000.0, "arena": 900.0}
ROBOT = "turtlebot3_waffle_pi"
BUDGET_RATIO = 2.0
#: strategies that reproduce a peer's semantics: their time ratio is reported, the budget is
#: navstack's own strategy's
PEER_STRATEGIES = ("explore_lite",)
BUDGET_SUCCESSES = 14 / 15
BUDGET_SLAM_LATENCY_S = 1.0
BUDGET_RESPONSE_S = 0.4


def reference(world: str) -> dict[str, float]:
    """The idealised greedy nearest-frontier explorer on ``world`` (module docstring)."""
    from navstack.exploration.ideal import IdealRobot, reachable_free_space, run_ideal
    from navstack.interfaces.mission_catalog import default_nav2_params
    from navstack.runtime.config import load_yaml
    from navstack.sim.robot import load_robot
    from navstack.sim.worlds import load_world

    w = load_world(world)
    robot = load_robot(ROBOT)
    nav2 = load_yaml(default_nav2_params(ROBOT) or "")
    follow = nav2["controller_server"]["ros__parameters"]["FollowPath"]
    speed = float(follow.get("desired_linear_vel", follow.get("max_vel_x", 0.26)))
    lidar = robot.sensors.lidar
    body = np.asarray(robot.footprint_model().polygon)
    half_width = float(min(np.ptp(body[:, 0]), np.ptp(body[:, 1])) / 2.0)
    target = reachable_free_space(w.occupied, w.resolution, w.origin_x, w.origin_y,
                                  (w.spawn.x, w.spawn.y), half_width, lidar.range_max)
    ideal = IdealRobot(speed=speed, sensor_range=lidar.range_max, beams=lidar.beams,
                       rate_hz=lidar.rate_hz, inscribed_radius=half_width + 0.05)
    t0 = time.perf_counter()
    res = run_ideal(w.occupied, w.resolution, w.origin_x, w.origin_y,
                    (w.spawn.x, w.spawn.y), ideal, target, max_time=20000.0)
    return {"reference_time_to_90_s": res.time_to(0.90),
            "reference_time_to_95_s": res.time_to(0.95),
            "reference_path_length_m": res.path_length,
            "reference_speed_m_s": speed, "reference_wall_s": time.perf_counter() - t0}


def run_case(world: str, strategy: str, seed: int,
             localization: str | None = None) -> dict[str, Any]:
    """One exploration run; the report figures of ``navstack mission explore``.
    ``localization`` ``"perfect"`` explores with given poses (no SLAM error)."""
    from navstack.interfaces.mission_catalog import MissionOptions
    from navstack.interfaces.mission_run import evaluate, start_mission

    with tempfile.TemporaryDirectory() as tmp:
        run = start_mission("explore", Path(tmp), world, ROBOT, seed,
                            MissionOptions(strategy=strategy,
                                           localization=localization,  # type: ignore[arg-type]
                                           max_duration=MAX_DURATION.get(world, 3600.0)))
        runner = run.runner.start()
        while not runner.done:
            run.stack.run_for(5.0)
        report = evaluate(run)
        run.close()
    keys = ("status", "reason", "success", "duration_s", "time_to_90_s", "time_to_95_s",
            "observed_fraction", "map_iou", "path_length_m", "collisions", "home_distance_m",
            "slam_map_latency_p95_s", "slam_map_latency_sim_p95_s", "slam_map_build_s",
            "slam_map_compute_p95_s", "slam_map_latency_bound_p95_s",
            "goal_to_first_motion_p95_s", "goal_to_first_motion_wall_p95_s",
            "max_spin_in_place_s", "pose_error_rms_m", "pose_error_max_m", "wall_time_s",
            "real_time_factor", "goal_to_first_motion_s")
    case = {"world": world, "strategy": strategy, "seed": seed,
            "localization": report["localization"],
            **{k: report.get(k, math.nan) for k in keys}}
    explore = report.get("explore", {})
    case["goals"] = explore.get("goals_sent", 0)
    case["blacklisted"] = explore.get("blacklisted", 0)
    return case


def _median(values: Sequence[float]) -> float:
    return float(statistics.median(values)) if values else math.nan


def summarize(cases: list[dict[str, Any]], refs: dict[str, dict[str, float]],
              result: BenchResult) -> None:
    """Metrics and budget checks from the per-run cases."""
    m = result.metrics
    worlds = sorted({c["world"] for c in cases}, key=lambda w: WORLDS.index(w)
                    if w in WORLDS else 99)
    strategies = [s for s in STRATEGIES if any(c["strategy"] == s for c in cases)]
    for world in worlds:
        ref = refs.get(world, {})
        m[f"{world}.reference_time_to_90_s"] = ref.get("reference_time_to_90_s", math.nan)
        m[f"{world}.reference_time_to_95_s"] = ref.get("reference_time_to_95_s", math.nan)
        for s in strategies:
            runs = [c for c in cases if c["world"] == world and c["strategy"] == s]
            if not runs:
                continue
            t90 = [c["time_to_90_s"] for c in runs]
            key = f"{world}.{s}"
            m[f"{key}.success"] = float(sum(bool(c["success"]) for c in runs))
            m[f"{key}.runs"] = float(len(runs))
            m[f"{key}.time_to_90_s"] = _median(t90)
            m[f"{key}.time_to_95_s"] = _median([c["time_to_95_s"] for c in runs])
            m[f"{key}.ratio_to_reference"] = _median(t90) / ref.get(
                "reference_time_to_90_s", math.nan)
            m[f"{key}.map_iou"] = _median([c["map_iou"] for c in runs])
            m[f"{key}.path_length_m"] = _median([c["path_length_m"] for c in runs])
            m[f"{key}.collisions"] = float(sum(c["collisions"] for c in runs))
            m[f"{key}.home_distance_max_m"] = max(c["home_distance_m"] for c in runs)
    for s in strategies:
        runs = [c for c in cases if c["strategy"] == s]
        m[f"{s}.success"] = float(sum(bool(c["success"]) for c in runs))
        m[f"{s}.runs"] = float(len(runs))
    lat = [c["slam_map_latency_p95_s"] for c in cases if not math.isnan(c[
        "slam_map_latency_p95_s"])]
    per_run = [c["goal_to_first_motion_p95_s"] for c in cases
               if not math.isnan(c["goal_to_first_motion_p95_s"])]
    delays = [d for c in cases for d in c.get("goal_to_first_motion_s") or ()]
    m["slam_map_latency_p95_s"] = max(lat) if lat else math.nan
    bound = [b for c in cases
             if not math.isnan(b := c.get("slam_map_latency_bound_p95_s", math.nan))]
    m["slam_map_latency_bound_p95_s"] = max(bound) if bound else math.nan
    # the p95 of every goal sent to a standing robot in the bench's runs: a run has only
    # 1-6 such goals, so its own "p95" is its slowest one (reported beside it)
    m["goal_to_first_motion_p95_s"] = float(np.percentile(delays, 95)) if delays else math.nan
    m["goal_to_first_motion_samples"] = float(len(delays))
    m["goal_to_first_motion_worst_run_p95_s"] = max(per_run) if per_run else math.nan
    m["max_spin_in_place_s"] = max(c["max_spin_in_place_s"] for c in cases)
    _budgets(cases, worlds, strategies, result)


def _budgets(cases: list[dict[str, Any]], worlds: list[str], strategies: list[str],
             result: BenchResult) -> None:
    m, notes = result.metrics, result.notes
    ok = True
    for s in strategies:
        runs = m[f"{s}.runs"]
        if m[f"{s}.success"] < math.ceil(BUDGET_SUCCESSES * runs - 1e-9):
            ok = False
            notes.append(f"budget: {s} succeeded in {m[f'{s}.success']:.0f} of {runs:.0f} "
                         f"runs (needs {BUDGET_SUCCESSES * runs:.1f})")
    for world in worlds:
        for s in strategies:
            ratio = m.get(f"{world}.{s}.ratio_to_reference", math.nan)
            if ratio <= BUDGET_RATIO:
                continue
            if s in PEER_STRATEGIES:
                notes.append(f"peer: {world} {s} median time to 90 % is {ratio:.2f} x the "
                             f"reference (its semantics; not budgeted)")
                continue
            ok = False
            notes.append(f"budget: {world} {s} median time to 90 % is {ratio:.2f} x the "
                         f"reference (budget {BUDGET_RATIO})")
        if {"explore_lite", "information_gain"} <= set(strategies):
            better = m.get(f"{world}.information_gain.time_to_90_s", math.nan)
            lite = m.get(f"{world}.explore_lite.time_to_90_s", math.nan)
            if not better < lite:
                ok = False
                notes.append(f"budget: {world}: information_gain median time to 90 % "
                             f"{better:.0f} s is not below explore_lite's {lite:.0f} s")
    if not m["slam_map_latency_p95_s"] <= BUDGET_SLAM_LATENCY_S:
        ok = False
        notes.append(f"budget: SLAM map update latency p95 {m['slam_map_latency_p95_s']:.2f} s "
                     f"> {BUDGET_SLAM_LATENCY_S} s")
    if not m["goal_to_first_motion_p95_s"] <= BUDGET_RESPONSE_S:
        ok = False
        notes.append(f"budget: goal-to-first-motion p95 {m['goal_to_first_motion_p95_s']:.2f}"
                     f" s > {BUDGET_RESPONSE_S} s")
    for c in cases:
        if not c["success"]:
            notes.append(f"run {c['world']} {c['strategy']} seed {c['seed']}: {c['status']} "
                         f"observed {c['observed_fraction']:.3f}, home "
                         f"{c['home_distance_m']:.2f} m, collisions {c['collisions']}"
                         + (f": {c['reason']}" if c["reason"] else ""))
    m["budgets_met"] = float(ok)


def run(quick: bool, data_dir: Path | None, worlds: Sequence[str] | None = None,
        seeds: Sequence[int] | None = None, strategies: Sequence[str] | None = None,
        localization: str | None = None, workers: int | None = None) -> BenchResult:
    """The suite (module docstring); ``worlds``/``seeds``/``strategies`` select a part,
    ``localization="perfect"`` explores with given poses instead of SLAM.

    ``workers`` > 1 (``navstack bench exploration --workers N``) runs the cases and the
    references in that many processes, longest worlds first; every case is seeded and
    on simulated time, so its figures do not depend on where or beside what it runs
    (only the wall-clock ones do)."""
    result = BenchResult("exploration", show_cases=True)
    worlds = list(worlds or (("arena",) if quick else WORLDS))
    seeds = list(seeds or ((1,) if quick else SEEDS))
    strategies = list(strategies or STRATEGIES)
    jobs = [(w, s, seed) for w in worlds for seed in seeds for s in strategies]
    unknown = [s for s in strategies if s not in STRATEGIES]
    if unknown:
        raise ConfigError(f"unknown exploration strategy {', '.join(unknown)}",
                          key_path="strategies",
                          suggestion=f"choose from {', '.join(STRATEGIES)}")
    if localization not in (None, "slam", "perfect"):
        raise ConfigError(f"unknown localization {localization!r} for the exploration "
                          "bench", key_path="localization",
                          suggestion="slam (default) or perfect")
    if localization == "slam":
        localization = None
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {workers}",
                          key_path="workers", suggestion="omit it to run the cases one by one")
    if not workers or workers == 1:
        refs = {w: reference(w) for w in worlds}
        cases = [run_case(w, s, seed, localization) for w, s, seed in jobs]
    else:
        refs, cases = _run_parallel(worlds, jobs, localization, workers)
    result.cases = cases
    summarize(cases, refs, result)
    return result


def _run_parallel(worlds: list[str], jobs: list[tuple[str, str, int]],
                  localization: str | None, workers: int
                  ) -> tuple[dict[str, dict[str, float]], list[dict[str, Any]]]:
    """References and cases in a process pool; cases come back in ``jobs`` order."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    def size(world: str) -> float:  # longest first: the pool ends with short cases
        return MAX_DURATION.get(world, 3600.0)

    with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
        ref_futures = {w: pool.submit(reference, w) for w in sorted(worlds, key=size,
                                                                     reverse=True)}
        order = sorted(range(len(jobs)), key=lambda k: -size(jobs[k][0]))
        case_futures = {k: pool.submit(run_case, *jobs[k], localization) for k in order}
        refs = {w: f.result() for w, f in ref_futures.items()}
        cases = [case_futures[k].result() for k in range(len(jobs))]
    return refs, cases
