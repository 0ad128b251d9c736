"""``navstack bench localization``: AMCL, EKF and initial pose against ground truth.

All runs are in the built-in simulator with fixed seeds (AMCL's ``random_seed`` too), and
AMCL uses the packaged ``amcl:`` section throughout (docs/localization.md):

* ``amcl_rmse_m`` / ``amcl_rmse_deg``: the office waypoint route (looped to
  :data:`TRACK_S` of simulated time, once per AMCL seed in :data:`TRACK_SEEDS`, samples
  pooled) with ``NavStack(..., localization="amcl")`` -- navigation runs on
  AMCL's ``map -> odom`` -- from the known spawn pose; every 0.5 s ``map -> base_link`` at
  the newest odometry stamp against the simulator's true pose at that stamp.
  ``amcl_nees_inside``: share of those samples whose NEES (x, y, yaw; AMCL's covariance)
  lies in the 95% chi-square band (3 dof).
* ``global_loc_success``: share of :data:`GLOBAL_TRIALS` trials, each from a random free
  pose with uniform particles over the map while the robot wanders on its scan
  (:class:`Wander`), in which the estimate comes within 0.5 m and 0.3 rad of the truth by
  :data:`GLOBAL_LIMIT_S` and stays there for :data:`HOLD_S`.
* ``kidnap_recovery_s``: median time (unrecovered trials count as
  :data:`KIDNAP_LIMIT_S`) to be within tolerance again, and stay, after the wandering robot
  is teleported to another place after :data:`KIDNAP_AFTER_S` of tracking;
  ``kidnap_recovered``: the share recovered.
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
#: AMCL seeds of the tracking runs (one 5-minute run each, samples pooled)
TRACK_SEEDS = (1, 2, 3)
GLOBAL_TRIALS = 20
GLOBAL_LIMIT_S = 30.0
KIDNAP_TRIALS = 10
KIDNAP_AFTER_S = 40.0
KIDNAP_LIMIT_S = 120.0
EKF_S = 600.0
BUDGETS: dict[str, float] = {"amcl_rmse_m": 0.05, "amcl_rmse_deg": 2.0,
                             "kidnap_recovery_s": 30.0, "amcl_update_ms": 5.0,
                             "ekf_rmse_m": 0.5, "ekf_update_ms": 0.2,
                             "initial_pose_err_m": 0.3}
FLOORS: dict[str, float] = {"global_loc_success": 0.9, "amcl_nees_inside": 0.9,
                            "ekf_nees_inside": 0.9, "ekf_odom_ratio": 3.0}
#: the estimate must stay within tolerance this long to count as converged [s]
HOLD_S = 5.0


def run(quick: bool, data_dir: Path | None = None) -> BenchResult:
    """All localization measurements (``--quick``: shorter runs, fewer trials)."""
    result = BenchResult("localization")
    _amcl_tracking(result, 60.0 if quick else TRACK_S, (1,) if quick else TRACK_SEEDS)
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
def _amcl_tracking(result: BenchResult, duration: float,
                   seeds: tuple[int, ...] = TRACK_SEEDS) -> None:
    """The tracking runs, one per AMCL seed, with errors and covariances pooled."""
    errors: list[tuple[float, float, float]] = []
    covs: list[np.ndarray] = []
    for seed in seeds:
        case = _track_once(duration, seed, errors, covs)
        result.cases.append(case)
    err = np.array(errors)
    m = result.metrics
    m["amcl_rmse_m"] = float(np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2)))
    m["amcl_rmse_deg"] = float(np.degrees(np.sqrt(np.mean(err[:, 2] ** 2))))
    band = nees_band(nees(err, np.array(covs)), dof=3)
    m["amcl_nees_inside"] = band.inside
    result.cases.append({"run": "amcl tracking (pooled)", "samples": len(err),
                         "nees_above": band.above, "nees_below": band.below})


def _track_once(duration: float, seed: int, errors: list[tuple[float, float, float]],
                covs: list[np.ndarray]) -> dict[str, Any]:
    """One office route run on AMCL (``random_seed`` = ``seed``); appends the samples."""
    from navstack.benchmarks.ekf_campus import TruthHistory
    from navstack.core.msgs import Odometry
    from navstack.interfaces.api import Navigator
    from navstack.interfaces.demo import default_waypoints_path
    from navstack.interfaces.stack import NavStack
    from navstack.interfaces.stack_description import AmclLocalization
    from navstack.navigation.waypoint_follower import load_waypoints

    stack = NavStack("office", "diff_drive", seed=1,
                     localization=AmclLocalization({"random_seed": seed})).start()
    assert stack.amcl is not None
    amcl = stack.amcl
    nav = Navigator(stack)
    truth = TruthHistory()
    stack.runtime.bus.subscribe("/ground_truth", Odometry, truth.add)
    odom_stamps: list[float] = []
    stack.runtime.bus.subscribe("/odom", Odometry,
                                lambda m: odom_stamps.append(float(m.header.stamp)))
    first = len(errors)

    def sample() -> None:
        # map -> base_link at the newest odometry stamp, against the truth at that stamp
        if not odom_stamps:
            return
        stamp = odom_stamps[-1]
        odom_stamps.clear()
        ref = truth.at(stamp)
        try:
            est = stack.runtime.tf.lookup_pose2d("map", "base_link", stamp)
        except TransformError:
            return
        if ref is None:
            return
        errors.append((ref[0] - est.x, ref[1] - est.y,
                       float(normalize_angle(ref[2] - est.theta))))
        covs.append(np.array(amcl.covariance, dtype=float))

    stack.runtime.scheduler.create_timer(0.5, sample, first_at=stack.now + 0.5)
    route = load_waypoints(default_waypoints_path())
    reached = 0
    while stack.now < duration:
        for _, pose in route:
            if stack.now >= duration:
                break
            if not nav.goToPose(pose):
                continue
            start = stack.now
            while not nav.isTaskComplete():
                if stack.now >= duration or stack.now - start > 240.0:
                    nav.cancelTask()
            reached += int(nav.getTaskResult() is not None
                           and not nav.getTaskResult().error_msg)  # type: ignore[union-attr]
    err = np.array(errors[first:])
    band = nees_band(nees(err, np.array(covs[first:])), dof=3)
    return {"run": f"amcl tracking, seed {seed}", "sim_s": round(stack.now, 2),
            "samples": len(err), "goals_reached": reached,
            "collisions": stack.sim.sim.collisions,
            "rmse_m": round(float(np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2))), 4),
            "nees_inside": round(band.inside, 3), "updates": amcl.updates}


def _amcl_sim(seed: int, spawn: tuple[float, float, float], params: dict[str, Any]
              ) -> tuple[Any, Any, Any]:
    """Runtime + simulator + map server + AMCL (no navigation), robot at ``spawn``."""
    from navstack.core.msgs import Pose2D
    from navstack.localization.amcl.params import AmclParams
    from navstack.navigation.map_server import MapServer
    from navstack.nodes.amcl import AmclNode
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
    from navstack.core.config_files import load_yaml, ros_parameters
    from navstack.interfaces.stack import default_nav2_params_path

    packaged = ros_parameters(load_yaml(default_nav2_params_path()), "amcl")
    amcl = AmclNode(rt, AmclParams.from_mapping({**packaged, "random_seed": seed, **params},
                                                key_path="amcl"))
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


class Wander:
    """A reactive wander on the raw scan: what a robot does while it localizes globally.

    Drives at :attr:`SPEED` while the sector ahead (+-35 deg, footprint-wide) is clear for
    :attr:`CLEAR` metres, otherwise turns in place towards the most open direction and
    keeps turning that way until the front is clear again (no dithering at corners).
    Uses only the scan, never the map or the true pose.
    """

    SPEED = 0.35
    TURN = 0.8
    CLEAR = 0.75
    HALF_WIDTH = 0.3

    def __init__(self, rt: Any) -> None:
        from navstack.core.msgs import LaserScan, Twist

        self._twist = Twist
        self.pub = rt.bus.publisher("/cmd_vel", Twist)
        self.turn = 0.0
        rt.bus.subscribe("/scan", LaserScan, self._on_scan)

    def _on_scan(self, scan: Any) -> None:
        r = np.asarray(scan.ranges, dtype=float)
        a = scan.angle_min + scan.angle_increment * np.arange(r.size)
        a = np.arctan2(np.sin(a), np.cos(a))
        ok = np.isfinite(r) & (r > scan.range_min)
        r = np.where(ok, r, scan.range_max)
        ahead = (np.abs(a) < math.radians(90)) & (np.abs(r * np.sin(a)) < self.HALF_WIDTH)
        front = float(np.min(r[ahead] * np.cos(a[ahead]))) if ahead.any() else math.inf
        if front > self.CLEAR and self.turn == 0.0:
            self.pub.publish(self._twist.planar(self.SPEED, 0.0, 0.0))
            return
        if front > self.CLEAR + 0.4:
            self.turn = 0.0
            self.pub.publish(self._twist.planar(self.SPEED, 0.0, 0.0))
            return
        if self.turn == 0.0:
            left = float(np.mean(r[(a > 0.3) & (a < 2.0)]))
            right = float(np.mean(r[(a < -0.3) & (a > -2.0)]))
            self.turn = self.TURN if left >= right else -self.TURN
        self.pub.publish(self._twist.planar(0.0, 0.0, self.turn))


def _error(amcl: Any, sim: Any) -> tuple[float, float]:
    est = amcl.estimate
    true = sim.sim.pose
    return (math.hypot(est[0] - true.x, est[1] - true.y),
            abs(float(normalize_angle(est[2] - true.theta))))


def _converge_time(rt: Any, sim: Any, amcl: Any, start: float, limit: float) -> float:
    """Seconds after ``start`` at which the estimate came within 0.5 m / 0.3 rad of the
    truth and then stayed there for :data:`HOLD_S` (NaN if not by ``start + limit``)."""
    held_since = math.nan
    while rt.now < start + limit + HOLD_S:
        rt.scheduler.run_until(rt.now + 0.5)
        sim.advance()
        d, a = _error(amcl, sim)
        if d <= 0.5 and a <= 0.3:
            if math.isnan(held_since):
                held_since = rt.now
            if rt.now - held_since >= HOLD_S:
                return held_since - start
        else:
            held_since = math.nan
            if rt.now > start + limit:
                break
    return math.nan


def _global_localization(result: BenchResult, trials: int) -> None:
    rng = np.random.default_rng(7)
    times: list[float] = []
    for k, spawn in enumerate(_free_poses(rng, trials)):
        rt, sim, amcl = _amcl_sim(100 + k, spawn, {})
        Wander(rt)
        rt.bring_up()
        rt.scheduler.run_until(0.2)  # the latched map reaches AMCL once it is active
        amcl.global_localization()
        converged_at = _converge_time(rt, sim, amcl, rt.now, GLOBAL_LIMIT_S)
        times.append(converged_at)
        result.cases.append({"run": f"global #{k}", "spawn": [round(v, 2) for v in spawn],
                             "converged_s": round(converged_at, 2),
                             "collisions": sim.sim.collisions,
                             "injected": amcl.filter.pf.injected_total})
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
                  "initial_pose": {"x": start[0], "y": start[1], "yaw": start[2]}}
        rt, sim, amcl = _amcl_sim(200 + k, start, params)
        Wander(rt)
        rt.bring_up()
        rt.scheduler.run_until(KIDNAP_AFTER_S)  # localized for a while: w_slow has settled
        sim.advance()
        tracking = _error(amcl, sim)
        sim.sim.state = RobotState(x=target[0], y=target[1], yaw=target[2])
        recovered = _converge_time(rt, sim, amcl, rt.now, KIDNAP_LIMIT_S)
        recoveries.append(recovered)
        result.cases.append({"run": f"kidnap #{k}", "to": [round(v, 2) for v in target],
                             "error_before_m": round(tracking[0], 3),
                             "recovered_s": round(recovered, 2), "collisions": sim.sim.collisions})
    finite = [r if not math.isnan(r) else KIDNAP_LIMIT_S for r in recoveries]
    result.metrics["kidnap_recovery_s"] = float(np.median(finite))
    result.metrics["kidnap_recovered"] = sum(not math.isnan(r) for r in recoveries) / max(
        len(recoveries), 1)


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
    from navstack.benchmarks.initial_pose import initial_pose_trials

    errors = initial_pose_trials(n=trials, seed=3)
    result.metrics["initial_pose_err_m"] = float(np.median(errors))
    result.cases.append({"run": "initial pose", "trials": len(errors),
                         "p90_m": float(np.percentile(errors, 90)),
                         "max_m": float(np.max(errors))})
