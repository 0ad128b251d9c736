"""``navstack mission NAME``: run a mission in the simulator and write its report.

Builds the stack the mission needs (:mod:`.mission_catalog`: SLAM for exploration and
map-by-poses, the known map for coverage), runs the mission to its end (or
``max_duration``, or Ctrl-C, which cancels it), and writes to ``--out``:

* ``report.json`` / ``report.md`` -- status and reason, time, path length, collisions,
  true distance to home at the end, and the mission's own figures: for exploration the
  time to 90 % / 95 % of the reachable free space observed, final map IoU, SLAM map
  latency and command response; for coverage the cells visited (judged on the true
  trajectory); for map-by-poses the completeness after every pose and the reload checks;
* ``trajectory.png`` (the executed path over the final map) and, for exploration,
  ``exploration.png`` (observed fraction over time).

``--record`` writes a rosbag2 of the run (with ``/mission/state`` and the frontier
markers); ``attach`` serves the live viewers (web dashboard, Foxglove).
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from navstack.core.msgs import OccupancyGrid, Path
from navstack.interfaces.demo import TrajectoryRecorder
from navstack.interfaces.mission_catalog import (
    MissionOptions,
    MissionSetup,
    MissionSpec,
    default_nav2_params,
    mission_spec,
)
from navstack.interfaces.mission_eval import (
    CommandResponse,
    CoverageTracker,
    PoseError,
    SlamLatency,
    spin_in_place_max,
)
from navstack.interfaces.mission_perception import perception_figures
from navstack.interfaces.mission_report import (
    coverage_figures,
    map_poses_figures,
    write_report,
)
from navstack.interfaces.stack import NavStack, default_nav2_params_path
from navstack.interfaces.stack_description import AmclLocalization, SlamLocalization
from navstack.mapping.map_metrics import occupancy_iou
from navstack.missions.context import MissionContext
from navstack.missions.explore import FRONTIERS_TOPIC
from navstack.missions.mission import MISSION_STATE_TOPIC, MissionRunner, MissionStatus
from navstack.nodes.known_pose_mapper import KnownPoseMapper, KnownPoseMapperParams
from navstack.runtime.config import load_yaml
from navstack.sim.world import World
from navstack.sim.worlds import load_world

__all__ = ["MissionRun", "run_mission", "start_mission"]


@dataclass
class MissionRun:
    """A mission started on a stack, with the watchers that score it."""

    spec: MissionSpec
    stack: NavStack
    runner: MissionRunner
    setup: MissionSetup
    trajectory: TrajectoryRecorder
    coverage: CoverageTracker | None
    latency: SlamLatency | None
    response: CommandResponse
    pose_error: PoseError
    plans: list[np.ndarray]
    wall_start: float

    def close(self) -> None:
        self.response.close()
        for watcher in (self.coverage, self.latency):
            if watcher is not None:
                watcher.close()


def start_mission(name: str, out: FsPath, world: str | None = None,
                  robot: str = "turtlebot3_waffle_pi", seed: int = 1,
                  options: MissionOptions | None = None) -> MissionRun:
    """Build the stack and the mission, attach the watchers; nothing has run yet."""
    opts = options or MissionOptions()
    spec = mission_spec(name)
    nav2_path = opts.nav2_params or default_nav2_params(robot) or default_nav2_params_path()
    nav2 = load_yaml(nav2_path)
    loc_name = opts.localization or spec.localization
    localization: Any = loc_name
    if loc_name == "slam":
        section = nav2.get("slam_toolbox", {}).get("ros__parameters", {})
        localization = SlamLocalization(dict(section))
    elif loc_name == "amcl":  # seeded: same seed, same run
        localization = AmclLocalization({"random_seed": seed})
    wall0 = time.perf_counter()
    map_grid = None
    explore_without_slam = spec.name == "explore" and loc_name != "slam"
    if explore_without_slam:
        # exploring with given poses: the map server starts with an all-unknown map and a
        # known-pose mapper builds /map from the scans (no SLAM error)
        truth = load_world(world or spec.world).to_occupancy_grid()
        map_grid = replace(truth, data=np.full_like(truth.data, -1))
    world_arg: str | World = world or spec.world
    nav2_arg: FsPath | dict[str, Any] = nav2_path
    if spec.prepare is not None:  # e.g. packages placed by the seed, the package cloud
        world_arg, nav2_arg = spec.prepare(load_world(world or spec.world), dict(nav2), seed)
    stack = NavStack(world_arg, robot, nav2_arg, seed=seed,
                     localization=localization, map_grid=map_grid).start()
    if explore_without_slam:
        mapper_params = KnownPoseMapperParams(
            max_laser_range=stack.robot.sensors.lidar.range_max,
            map_minimum_extent=list(stack.world.bounds))
        KnownPoseMapper(stack.runtime, mapper_params).configure()
        stack.runtime.nodes["known_pose_mapper"].activate()
    out.mkdir(parents=True, exist_ok=True)
    ctx = MissionContext(stack.runtime)
    setup = MissionSetup(stack, ctx, out, opts, nav2, str(nav2_path))
    mission = spec.build(setup)
    runner = MissionRunner(stack.runtime, mission,
                           max_duration=opts.max_duration or spec.max_duration)
    recorder = TrajectoryRecorder(stack)
    stack.runtime.scheduler.create_timer(0.1, recorder.sample, first_at=stack.now)
    plans: list[np.ndarray] = []
    stack.runtime.bus.subscribe("/plan", Path, lambda p: plans.append(p.as_array()[:, :2]))
    lidar = stack.robot.sensors.lidar
    slam = loc_name == "slam"
    coverage = None
    if slam or explore_without_slam:
        coverage = CoverageTracker(stack, lidar.range_max)
    latency = SlamLatency(stack) if slam else None
    response = CommandResponse(stack)
    return MissionRun(spec, stack, runner, setup, recorder, coverage, latency, response,
                      PoseError(stack), plans, wall0)


def run_mission(name: str, out: FsPath, world: str | None = None,
                robot: str = "turtlebot3_waffle_pi", seed: int = 1, record: bool = False,
                options: MissionOptions | None = None, show_progress: bool = True,
                attach: Callable[[NavStack], Callable[[], None]] | None = None,
                ) -> dict[str, Any]:
    """Run mission ``name`` and write the report files; returns the report dict."""
    run = start_mission(name, out, world, robot, seed, options)
    stack, runner = run.stack, run.runner
    bag = None
    if record:
        from navstack.runtime.recording import DEFAULT_TOPICS, BagRecorder

        bag = BagRecorder(stack.runtime, out / "bag", replace=True,
                          topics=(*DEFAULT_TOPICS, MISSION_STATE_TOPIC, FRONTIERS_TOPIC))
    detach = attach(stack) if attach is not None else None
    runner.start()
    tty = show_progress and sys.stdout.isatty()
    try:
        while not runner.done:
            stack.run_for(0.5)
            if show_progress:
                state = runner.mission_state()
                line = (f"[{state['elapsed']:7.1f} s] {state['status']} "
                        f"{state['feedback'][:90]}")
                sys.stdout.write(("\r\033[K" + line) if tty else "")
                sys.stdout.flush()
    except KeyboardInterrupt:
        runner.cancel("interrupted (Ctrl-C)")
        stack.run_for(0.0)
    finally:
        if tty:
            sys.stdout.write("\r\033[K")
        bag_summary = bag.close() if bag is not None else None
        if detach is not None:
            detach()
    report = evaluate(run)
    run.close()
    if bag_summary is not None:
        report["bag"] = {"path": str(bag_summary.path), "messages": bag_summary.messages}
    write_report(report, out, run)
    return report


def evaluate(run: MissionRun) -> dict[str, Any]:
    """The report of a finished run (module docstring)."""
    stack, runner = run.stack, run.runner
    result = runner.result
    assert result is not None
    traj = run.trajectory.array()
    spawn = stack.description.spawn
    final = stack.sim.sim.pose
    xy = traj[:, 1:3]
    path_length = float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0
    wall = time.perf_counter() - run.wall_start
    report: dict[str, Any] = {
        "mission": run.spec.name, "description": run.spec.description,
        "status": result.status.value, "reason": result.reason,
        "world": stack.world.name, "robot": stack.robot.name,
        "seed": stack.description.seed, "localization": stack.description.localization.name,
        "nav2_params": run.setup.nav2_file,
        "duration_s": round(result.duration, 2), "sim_time_s": round(stack.now, 2),
        "wall_time_s": round(wall, 2),
        "real_time_factor": round(stack.now / wall, 2) if wall > 0 else 0.0,
        "path_length_m": round(path_length, 3),
        "collisions": int(stack.sim.sim.collisions),
        "min_clearance_m": round(run.trajectory.min_clearance, 4),
        "home_distance_m": round(math.hypot(final.x - spawn.x, final.y - spawn.y), 4),
        "max_spin_in_place_s": round(spin_in_place_max(traj), 2),
        "events": [[round(t, 2), text] for t, text in result.events],
    }
    report.update(result.data)
    report.update(run.response.summary())
    report.update({k: (round(v, 4) if isinstance(v, float) else v)
                   for k, v in run.pose_error.summary().items()})
    if run.coverage is not None:
        cov = run.coverage
        t0 = runner.started
        report.update({
            "reachable_free_m2": round(float(cov.region.sum()) * stack.world.resolution ** 2,
                                       2),
            "time_to_90_s": round(cov.time_to(0.90, t0), 2),
            "time_to_95_s": round(cov.time_to(0.95, t0), 2),
            "observed_fraction": round(cov.final, 4),
            "coverage_trace": [[round(t - t0, 2), round(f, 4)]
                               for t, f in zip(cov.times, cov.fractions, strict=True)],
        })
        if cov.last is not None:
            try:
                score = occupancy_iou(cov.last, stack.world.to_occupancy_grid())
                report["map_iou"] = round(score.iou, 4)
            except Exception as exc:
                report["map_iou"] = math.nan
                report["map_iou_error"] = str(exc)
    if run.latency is not None:
        report.update({k: (round(v, 4) if isinstance(v, float) else v)
                       for k, v in run.latency.summary().items()})
    if "coverage" in report:
        report.update(coverage_figures(report, traj))
    if "map_poses" in report:
        report.update(map_poses_figures(run, report))
    report.update(perception_figures(stack, report))
    report["success"] = _success(report)
    return report


def _success(r: dict[str, Any]) -> bool:
    ok = r["status"] == MissionStatus.SUCCEEDED.value and r["collisions"] == 0
    if r["mission"] == "explore":
        ok = ok and r.get("observed_fraction", 0.0) >= 0.95 and r["home_distance_m"] <= 0.3
    elif r["mission"] == "coverage":
        ok = ok and r.get("cells_visited", 0) == r.get("cells_total", -1) \
            and r["home_distance_m"] <= 0.3
    elif r["mission"] == "marker-frame":
        ok = ok and bool(r.get("marker_frame_ok")) and r["home_distance_m"] <= 0.3
    elif r["mission"] == "package-retrieval":
        ok = ok and bool(r.get("package_held")) and r.get("package_collisions", 1) == 0 \
            and r["home_distance_m"] <= 0.3
    elif r["mission"] == "map-poses":
        ok = ok and bool(r.get("reload", {}).get("map_server_ok")) \
            and bool(r.get("reload", {}).get("slam_localization_ok"))
    return bool(ok)


def final_map(run: MissionRun) -> OccupancyGrid:
    """The map to draw under the trajectory: SLAM's, else the world's."""
    slam = run.stack.slam
    grid = slam.occupancy_grid() if slam is not None else None
    return grid if grid is not None else run.stack.world.to_occupancy_grid()


def dumps(report: dict[str, Any]) -> str:
    return json.dumps(report, indent=2, default=float) + "\n"
