"""``navstack bench localization``: AMCL, EKF and initial pose against ground truth.

All runs are in the built-in simulator with fixed seeds (deterministic):

* ``amcl_rmse_m`` / ``amcl_rmse_deg``: the office waypoint route (looped to
  :data:`TRACK_S` of simulated time) with ``NavStack(..., amcl=True)`` -- navigation runs on
  AMCL's ``map -> odom`` -- from the known spawn pose; the AMCL pose (``map -> base_link``)
  is sampled every 0.5 s against the simulator's true pose.  ``amcl_nees_inside``: share
  of those samples whose NEES (x, y, yaw; AMCL's covariance) lies in the 95% chi-square
  band (3 dof).
* ``global_loc_success``: share of :data:`GLOBAL_TRIALS` trials, each from a random free
  pose with uniform particles over the map, in which the estimate is within 0.5 m and
  0.3 rad of the truth after at most 30 s of rotating in place.
* ``kidnap_recovery_s``: median time to be within 0.5 m again after the localized robot
  is teleported to another place after 40 s of tracking (AMCL recovery:
  ``recovery_alpha_slow`` 0.01, ``recovery_alpha_fast`` 0.1; at the commonly suggested
  0.001 the slow average has not settled after 40 s and a kidnap triggers no injection).
* ``amcl_update_ms``: median wall time of a filter update (motion + sensor + resample)
  with 2000 particles (min = max = 2000) and 60 beams.
* ``ekf_rmse_m`` / ``odom_rmse_m`` / ``ekf_update_ms`` / ``ekf_nees_inside``: a campus
  drive of :data:`EKF_S` fusing wheel odometry + IMU + GNSS (2 m noise, through the navsat
  transform) in the EKF, against the wheel odometry alone.
* ``initial_pose_err_m``: median position error over 20 trials of the GNSS + magnetometer
  initial pose (2 m fix error, 15 deg heading error) refined by scan-to-map matching.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from navstack.benchmarks.common import BenchResult
from navstack.core.errors import TransformError
from navstack.core.geometry import normalize_angle
from navstack.localization.consistency import nees, nees_band

TRACK_S = 300.0
GLOBAL_TRIALS = 20
GLOBAL_LIMIT_S = 30.0
KIDNAP_TRIALS = 5
KIDNAP_AFTER_S = 40.0
EKF_S = 600.0
BUDGETS: dict[str, float] = {"amcl_rmse_m": 0.05, "amcl_rmse_deg": 2.0,
                             "kidnap_recovery_s": 30.0, "amcl_update_ms": 5.0,
                             "ekf_rmse_m": 0.5, "ekf_update_ms": 0.2,
                             "initial_pose_err_m": 0.3}
FLOORS: dict[str, float] = {"global_loc_success": 0.9, "amcl_nees_inside": 0.9,
                            "ekf_nees_inside": 0.9, "ekf_odom_ratio": 3.0}
#: global localization: more particles than Nav2's 2000 for a 300 m2 office of similar rooms
GLOBAL = {"max_particles": 5000}
RECOVERY = {"recovery_alpha_slow": 0.01, "recovery_alpha_fast": 0.1}


def run(quick: bool, data_dir: Path | None = None) -> BenchResult:
    """All localization measurements (``--quick``: shorter runs, fewer trials)."""
    result = BenchResult("localization")
    _amcl_tracking(result, 60.0 if quick else TRACK_S)
    _global_localization(result, 4 if quick else GLOBAL_TRIALS)
    _kidnap(result, 2 if quick else KIDNAP_TRIALS)
    _amcl_speed(result, 30 if quick else 200)
    _ekf_campus(result, 120.0 if quick else EKF_S)
    _initial_pose(result, 5 if quick else 20)
    if quick:
        result.notes.append("quick: shorter runs and fewer trials, budgets not checked")
    else:
        over = [k for k, v in BUDGETS.items() if not result.metrics.get(k, math.inf) <= v]
        over += [k for k, v in FLOORS.items() if not result.metrics.get(k, -math.inf) >= v]
        result.notes.append("over budget: " + ", ".join(over) if over else "all budgets met")
    result.notes.append("budgets: " + ", ".join(
        [f"{k} <= {v:g}" for k, v in BUDGETS.items()]
        + [f"{k} >= {v:g}" for k, v in FLOORS.items()]))
    return result


# --- AMCL -------------------------------------------------------------------------------
def _amcl_tracking(result: BenchResult, duration: float) -> None:
    from navstack.interfaces.api import Navigator
    from navstack.interfaces.demo import default_waypoints_path
    from navstack.interfaces.stack import NavStack
    from navstack.navigation.waypoint_follower import load_waypoints

    stack = NavStack("office", "diff_drive", seed=1, amcl=True)
    assert stack.amcl is not None
    amcl = stack.amcl
    nav = Navigator(stack)
    errors: list[tuple[float, float, float]] = []
    covs: list[np.ndarray] = []

    def sample() -> None:
        try:
            est = stack.runtime.tf.lookup_pose2d("map", "base_link")
        except TransformError:
            return
        true = stack.sim.sim.pose
        errors.append((true.x - est.x, true.y - est.y,
                       float(normalize_angle(true.theta - est.theta))))
        covs.append(np.array(amcl.covariance, dtype=float))

    stack.runtime.scheduler.create_timer(0.5, sample, first_at=stack.now + 0.5)
    route = load_waypoints(default_waypoints_path())
    reached = failed = 0
    while stack.now < duration:
        for _, pose in route:
            if stack.now >= duration:
                break
            if not nav.goToPose(pose):
                failed += 1
                continue
            start = stack.now
            while not nav.isTaskComplete():
                if stack.now >= duration or stack.now - start > 240.0:
                    nav.cancelTask()
            reached += int(nav.getTaskResult() is not None
                           and not nav.getTaskResult().error_msg)  # type: ignore[union-attr]
    err = np.array(errors)
    m = result.metrics
    m["amcl_rmse_m"] = float(np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2)))
    m["amcl_rmse_deg"] = float(np.degrees(np.sqrt(np.mean(err[:, 2] ** 2))))
    band = nees_band(nees(err, np.array(covs)), dof=3)
    m["amcl_nees_inside"] = band.inside
    result.cases.append({"run": "amcl tracking", "sim_s": stack.now, "samples": len(err),
                         "goals_reached": reached, "collisions": stack.sim.sim.collisions,
                         "nees_above": band.above, "nees_below": band.below,
                         "updates": amcl.updates})


def _amcl_sim(seed: int, spawn: tuple[float, float, float], params: dict[str, Any]
              ) -> tuple[Any, Any, Any]:
    """Runtime + simulator + map server + AMCL (no navigation), robot at ``spawn``."""
    from navstack.core.msgs import Pose2D
    from navstack.localization.amcl.node import AmclNode
    from navstack.localization.amcl.params import AmclParams
    from navstack.navigation.map_server import MapServer
    from navstack.runtime.node import Runtime
    from navstack.sim.node import SimulatorNode
    from navstack.sim.robot import load_robot
    from navstack.sim.simulator import Simulator
    from navstack.sim.worlds import load_world

    rt = Runtime()
    world = load_world("office")
    sim = SimulatorNode(rt, Simulator(world, load_robot("diff_drive"), seed, Pose2D(*spawn)),
                        50.0, False)
    MapServer(rt, grid=world.to_occupancy_grid())
    from navstack.interfaces.stack import default_nav2_params_path
    from navstack.runtime.config import load_yaml, ros_parameters

    packaged = ros_parameters(load_yaml(default_nav2_params_path()), "amcl")
    amcl = AmclNode(rt, AmclParams.from_mapping({**packaged, **params}, key_path="amcl"))
    return rt, sim, amcl


def _free_poses(rng: np.random.Generator, count: int, clearance: float = 0.6
                ) -> list[tuple[float, float, float]]:
    from navstack.sim.worlds import load_world

    world = load_world("office")
    dist = world.distance_field()
    rows, cols = np.nonzero(dist >= clearance)
    picks = rng.choice(rows.size, size=count, replace=False)
    out = []
    for k in picks:
        x, y = world.cell_center(int(rows[k]), int(cols[k]))
        out.append((x, y, float(rng.uniform(-math.pi, math.pi))))
    return out


def _rotate(rt: Any, rate: float = 0.6) -> None:
    from navstack.core.msgs import Twist

    pub = rt.bus.publisher("/cmd_vel", Twist)
    rt.scheduler.create_timer(0.05, lambda: pub.publish(Twist.planar(0.0, 0.0, rate)),
                              first_at=0.0)


def _error(amcl: Any, sim: Any) -> tuple[float, float]:
    est = amcl.estimate
    true = sim.sim.pose
    return (math.hypot(est[0] - true.x, est[1] - true.y),
            abs(float(normalize_angle(est[2] - true.theta))))


def _global_localization(result: BenchResult, trials: int) -> None:
    rng = np.random.default_rng(7)
    times: list[float] = []
    for k, spawn in enumerate(_free_poses(rng, trials)):
        rt, sim, amcl = _amcl_sim(100 + k, spawn, GLOBAL)
        _rotate(rt)
        rt.bring_up()
        rt.scheduler.run_until(0.2)  # the latched map reaches AMCL once it is active
        amcl.global_localization()
        converged_at = math.nan
        t = 0.2
        while t < GLOBAL_LIMIT_S:
            t += 0.5
            rt.scheduler.run_until(t)
            sim.advance()
            d, a = _error(amcl, sim)
            if d <= 0.5 and a <= 0.3:
                converged_at = t
                break
        times.append(converged_at)
        result.cases.append({"run": f"global #{k}", "spawn": [round(v, 2) for v in spawn],
                             "converged_s": converged_at})
    ok = [t for t in times if not math.isnan(t)]
    result.metrics["global_loc_success"] = len(ok) / max(len(times), 1)
    if ok:
        result.metrics["global_loc_median_s"] = float(np.median(ok))


def _kidnap(result: BenchResult, trials: int) -> None:
    from navstack.sim.simulator import RobotState

    rng = np.random.default_rng(11)
    starts = _free_poses(rng, trials)
    targets = _free_poses(rng, trials)
    recoveries: list[float] = []
    for k, (start, target) in enumerate(zip(starts, targets, strict=True)):
        params = {"set_initial_pose": True,
                  "initial_pose": {"x": start[0], "y": start[1], "yaw": start[2]}, **RECOVERY}
        rt, sim, amcl = _amcl_sim(200 + k, start, params)
        _rotate(rt)
        rt.bring_up()
        rt.scheduler.run_until(KIDNAP_AFTER_S)  # localized for a while: w_slow has settled
        sim.advance()
        sim.sim.state = RobotState(x=target[0], y=target[1], yaw=target[2])
        t0 = rt.now
        recovered = math.nan
        while rt.now - t0 < 120.0:
            rt.scheduler.run_until(rt.now + 0.5)
            sim.advance()
            d, a = _error(amcl, sim)
            if d <= 0.5 and a <= 0.3:
                recovered = rt.now - t0
                break
        recoveries.append(recovered)
        result.cases.append({"run": f"kidnap #{k}", "to": [round(v, 2) for v in target],
                             "recovered_s": recovered})
    finite = [r if not math.isnan(r) else 120.0 for r in recoveries]
    result.metrics["kidnap_recovery_s"] = float(np.median(finite))


def _amcl_speed(result: BenchResult, updates: int) -> None:
    start = (3.0, 3.0, 0.0)
    params = {"set_initial_pose": True, "initial_pose": {"x": 3.0, "y": 3.0, "yaw": 0.0},
              "min_particles": 2000, "max_particles": 2000, "max_beams": 60,
              "update_min_d": 0.0, "update_min_a": 0.0}
    rt, sim, amcl = _amcl_sim(300, start, params)
    _rotate(rt, 0.3)
    rt.bring_up()
    t = 0.0
    while len(amcl.update_ms) < updates + 5:
        t += 0.5
        rt.scheduler.run_until(t)
        sim.advance()
    samples = np.array(amcl.update_ms[5:])
    result.metrics["amcl_update_ms"] = float(np.median(samples))
    result.cases.append({"run": "amcl speed", "particles": 2000, "beams": 60,
                         "updates": int(samples.size),
                         "p90_ms": float(np.percentile(samples, 90))})


# --- EKF + GNSS -------------------------------------------------------------------------
def _ekf_campus(result: BenchResult, duration: float) -> None:
    from navstack.benchmarks.ekf_campus import run_campus_drive

    t0 = time.perf_counter()
    run = run_campus_drive(duration)
    m = result.metrics
    m["ekf_rmse_m"] = run.ekf_rmse_m
    m["odom_rmse_m"] = run.odom_rmse_m
    m["ekf_odom_ratio"] = run.odom_rmse_m / max(run.ekf_rmse_m, 1e-9)
    m["ekf_update_ms"] = run.update_ms
    m["ekf_nees_inside"] = run.nees_inside
    result.cases.append({"run": "ekf campus", "sim_s": duration, "samples": run.samples,
                         "wall_s": time.perf_counter() - t0, **run.extra})


def _initial_pose(result: BenchResult, trials: int) -> None:
    from navstack.localization.initial_pose import initial_pose_trials

    errors = initial_pose_trials(n=trials, seed=3)
    result.metrics["initial_pose_err_m"] = float(np.median(errors))
    result.cases.append({"run": "initial pose", "trials": len(errors),
                         "p90_m": float(np.percentile(errors, 90)),
                         "max_m": float(np.max(errors))})
