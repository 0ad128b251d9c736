"""Package retrieval in the arena (issue 17, acceptance 3), 20 seeds with random packages.

Each seed runs the ``package-retrieval`` mission of ``navstack mission`` (the same world
preparation, perception and tree): the TurtleBot course's two packages (10 x 5 x 5 cm,
5 cm ``DICT_4X4_50`` markers on every face, ids 3 = target and 4) at random free spots of
the ``arena`` world (:func:`~navstack.sim.packages.place_packages`: at least 0.6 m from
walls and obstacles, 0.7 m from each other and 0.8 m from the start, random yaw), the
``turtlebot3_waffle_pi`` stack (its Nav2 parameters plus the ``package_cloud``
observation source, global costmap at 5 Hz) with perfect localisation on the known map,
the camera (images at 10 Hz), the ArUco detector (5 cm markers), the marker map
(packages 3 and 4) and the simulated gripper;
:func:`~navstack.missions.marker_missions.package_retrieval_mission` on the mission
runner with a 600 s budget.

Per run: success (the tree succeeded, the target is held and the robot is within 0.3 m
of home), time to locate the target (simulated seconds from the start to the package's
first detection), collisions with packages (simulator contacts), and the latency from
the first detection of each package to its ring (the points last published) being LETHAL
in the global costmap, polled every 20 ms; ``footprint_replans`` counts the plans the
planner server replaced because the body did not fit a gap.  Metrics:
``success_rate``, ``successes``, ``locate_time_median_s``, ``package_collisions``,
``cloud_latency_p95_s`` (budgets: >= 19 of 20, <= 300 s, 0, <= 0.4 s).  ``--quick`` runs 3 seeds.
"""

from __future__ import annotations

import math
import statistics
import time
from typing import Any

import numpy as np

from navstack.benchmarks.common import BenchResult
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.interfaces.mission_catalog import (
    RETRIEVAL_TARGET,
    build_package_retrieval,
    prepare_retrieval,
)
from navstack.interfaces.perception import with_package_cloud
from navstack.interfaces.stack import NavStack
from navstack.missions.mission import MissionRunner, MissionStatus
from navstack.runtime.config import load_yaml
from navstack.sim.robot import load_robot
from navstack.sim.worlds import load_world

ROBOT = "turtlebot3_waffle_pi"
PARAMS = "turtlebot3_waffle_pi_nav2_params.yaml"


def nav2_params() -> dict[str, Any]:
    """The Waffle Pi's Nav2 parameters with the package cloud (global costmap at 5 Hz).

    A wider, flatter global inflation (0.8 m, scaling 1.5) was tried against the file's
    0.55 m / 3.0: 11 of 20 seeds either way, so the file's values stay."""
    from importlib import resources

    path = resources.files("navstack") / "config" / PARAMS
    return with_package_cloud(load_yaml(str(path)))


def run_once(seed: int, timeout: float = 600.0) -> dict[str, Any]:
    """One retrieval run (see module docstring): the ``package-retrieval`` mission of
    ``navstack mission`` (same world preparation, perception and tree)."""
    from importlib import resources

    world, nav2 = prepare_retrieval(
        load_world("arena"), load_yaml(str(resources.files("navstack") / "config" / PARAMS)),
        seed)
    stack = NavStack(world, load_robot(ROBOT), nav2, seed=seed).start()
    mission, per = build_package_retrieval(stack)
    home = world.spawn
    # the virtual obstacle of a package in the global costmap: first time its ring is lethal
    cm = stack.global_costmap.costmap
    in_costmap: dict[int, float] = {}

    def poll() -> None:
        for pid, ring in per.marker_map.cloud_rings.items():
            if pid in in_costmap:
                continue
            cells = [cm.world_to_map(float(x), float(y)) for x, y, _ in ring]
            if all(c is not None and cm.data[c[1], c[0]] >= LETHAL_OBSTACLE for c in cells):
                in_costmap[pid] = stack.now

    stack.runtime.scheduler.create_timer(0.02, poll)
    wall = time.perf_counter()
    outcome = MissionRunner(stack.runtime, mission).run(timeout)
    sim = stack.sim.sim
    pose = sim.pose
    home_dist = math.hypot(pose.x - home.x, pose.y - home.y)
    held = sim.packages.carried is not None and sim.packages.specs[sim.packages.carried] \
        .marker_id == RETRIEVAL_TARGET
    first = per.marker_map.package_first_seen
    # a package's ring must reach the costmap; the target's only counts if it was not
    # already taken out (to be gripped) by then
    latencies = [in_costmap[p] - first[p] if p in in_costmap else math.inf for p in first
                 if p in in_costmap or p not in per.marker_map.ignored_packages]
    return {
        "seed": seed, "success": bool(outcome.status is MissionStatus.SUCCEEDED and held
                                      and home_dist <= 0.3),
        "status": outcome.status.value, "failed": outcome.reason,
        "sim_time_s": round(outcome.duration, 1),
        "locate_time_s": (round(first[RETRIEVAL_TARGET], 2) if RETRIEVAL_TARGET in first
                          else math.nan),
        "held": held, "home_distance_m": round(home_dist, 3),
        "package_collisions": int(sim.packages.total_collisions),
        "collisions": int(sim.collisions),
        "cloud_latency_s": [round(v, 3) for v in latencies],
        "packages": [(round(p.x, 2), round(p.y, 2)) for p in world.packages],
        "footprint_replans": stack.planner.footprint_replans,
        "frames": per.camera.frames, "wall_s": round(time.perf_counter() - wall, 1)}


def run(quick: bool = False, data_dir: Any = None) -> BenchResult:
    """All seeds; metrics of the module docstring."""
    del data_dir
    seeds = list(range(3)) if quick else list(range(20))
    cases = [run_once(s) for s in seeds]
    located = [c["locate_time_s"] for c in cases if not math.isnan(c["locate_time_s"])]
    latencies = [v for c in cases for v in c["cloud_latency_s"]]
    result = BenchResult("retrieval")
    n_ok = sum(c["success"] for c in cases)
    result.metrics = {
        "runs": float(len(cases)), "successes": float(n_ok), "success_rate": n_ok / len(cases),
        "locate_time_median_s": float(statistics.median(located)) if located else math.nan,
        "locate_time_max_s": max(located) if located else math.nan,
        "package_collisions": float(sum(c["package_collisions"] for c in cases)),
        "collisions": float(sum(c["collisions"] for c in cases)),
        "cloud_latency_p95_s": float(np.percentile(latencies, 95)) if latencies else math.nan,
        "home_distance_max_m": max(c["home_distance_m"] for c in cases),
    }
    result.cases = [{k: v for k, v in c.items() if k != "cloud_latency_s"} for c in cases]
    result.show_cases = True
    for c in cases:
        if not c["success"]:
            result.notes.append(f"seed {c['seed']}: {c['status']} {c['failed']}")
    return result
