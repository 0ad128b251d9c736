"""``navstack bench rover``: the planetary rover's GNSS-only legs in the mars yard.

Acceptance item 3 of issue 20, GNSS-only row: per seed the rover (its profile on the
course's georeference: skid steer, 1.2 m x 0.9 m, GNSS at 5 Hz with 2 m white noise per
axis and a 1 m Gauss-Markov bias) starts at the yard's spawn, runs the heading-calibration
drive, then

1. the PI chase (:class:`~navstack.missions.gps_legs.GpsChaseLeg`) to leg ``gnss_1``;
2. the navigation-based ``gps_goal_fix`` loop
   (:class:`~navstack.missions.gps_legs.GpsGoalFixLeg`) on to leg ``gnss_2``.

Acceptance item 4 on the yard (full run only): ``Navigator.followGpsWaypoints`` over the
course's five lat/lon ``gps_waypoints`` -- the yard is rotated 0.35 rad against
east-north -- scored by the closest true approach to each point (<= 3 m).

Scored on the simulator's truth: the final true distance from the rover (``base_link``)
to the leg's coordinate, 2 s after the leg ended (<= 3 m passes), and collisions with the
rocks and posts.  Navigation uses the simulator's map -> odom (the rover's lidar map is
not the subject here); the legs themselves only know the fixes, the course over ground
and wheel odometry.

The post and gate rows of item 3 run the rover's behaviour tree
(:class:`~navstack.missions.rover_tree.RoverMission`) with the camera and ArUco chain
(corners mode: projected corners with 0.3 px noise through the detector's PnP): per seed a
post leg (``post_1``, ``post_2``, ``post_3`` in turn; posts 14.1, 15.8 and 19.0 m from their
coordinates) and the gate leg ``gate_a``, each from its course ``start`` 18-24 m away:
calibration drive, GPS leg, spiral search, approach / gate pass
(:func:`navstack.interfaces.rover.run_leg`).  A post leg passes with the post within 2 m
of ``base_link`` at the end, a gate leg when the rover crossed the segment between the
true posts with its heading within 45 degrees of the gate normal; the search time runs
from the GPS goal reached to the leg's end.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from navstack.benchmarks.common import BenchResult, Progress

__all__ = ["LEG_PASS_M", "GpsLegResult", "run", "run_gps_legs", "run_gps_waypoints",
           "run_search_legs"]

LEG_PASS_M = 3.0
SEEDS = tuple(range(20))
QUICK_SEEDS = (0, 1, 2)
SETTLE_S = 2.0
POST_LEGS = ("post_1", "post_2", "post_3")
"""The course's post legs, their posts 14.1, 15.8 and 19.0 m from the coordinate."""


@dataclass
class GpsLegResult:
    seed: int
    variant: str
    leg: str
    status: str
    reason: str
    true_distance: float
    leg_time: float
    goals_sent: int
    collisions: int
    course_error_deg: float


def _rover_nav2_params() -> str:
    return str(resources.files("navstack") / "config" / "rover_nav2_params.yaml")


def run_gps_legs(seed: int, legs: tuple[tuple[str, str], ...] = (("pi", "gnss_1"),
                                                                  ("nav2", "gnss_2")),
                 course_file: str | Path | None = None, timeout: float = 240.0
                 ) -> list[GpsLegResult]:
    """Calibrate, then run each (variant ``"pi"`` | ``"nav2"``, course leg name) in turn
    from where the previous one ended; one :class:`GpsLegResult` per leg."""
    from navstack.geo.gps_goal import parse_coordinate
    from navstack.interfaces.stack import NavStack
    from navstack.missions.gps_legs import (
        GpsChaseLeg,
        GpsChaseLegParams,
        GpsGoalFixLeg,
        GpsGoalFixParams,
        HeadingCalibration,
        LegStatus,
    )
    from navstack.sim.course import course_robot, course_world, ll_to_world, load_course

    course = load_course(course_file)
    robot = course_robot(course)
    stack = NavStack(course_world(course), robot, _rover_nav2_params(), seed=seed).start()
    rt, sim = stack.runtime, stack.sim.sim
    calibration = HeadingCalibration(rt)
    calibration.start()
    while calibration.status is LegStatus.RUNNING and stack.now < 20.0:
        stack.run_for(0.1)
    if calibration.status is not LegStatus.SUCCEEDED:
        raise RuntimeError(f"seed {seed}: heading calibration {calibration.status.value}: "
                           f"{calibration.reason}")
    geo = course.georeference
    odom_yaw = rt.tf.lookup_pose2d("odom", "base_link").theta
    true_axis = math.degrees(math.pi / 2 - (sim.pose.theta + geo.world_yaw) + odom_yaw)
    course_error = abs(math.remainder(calibration.course_deg - true_axis, 360.0))
    mount = robot.sensors.gnss.mount
    antenna = (mount.x, mount.y)
    results = []
    for variant, name in legs:
        leg_spec = course.leg(name)
        lat = parse_coordinate(leg_spec.latitude, f"{name}.latitude", "latitude")
        lon = parse_coordinate(leg_spec.longitude, f"{name}.longitude", "longitude")
        gx, gy = ll_to_world(geo, lat, lon)
        leg: GpsChaseLeg | GpsGoalFixLeg
        if variant == "pi":
            leg = GpsChaseLeg(rt, calibration.course_deg,
                              GpsChaseLegParams(antenna=antenna, timeout=timeout))
        elif variant == "nav2":
            leg = GpsGoalFixLeg(rt, calibration.course_deg,
                                GpsGoalFixParams(antenna=antenna, timeout=timeout))
        else:
            raise ValueError(f"variant must be 'pi' or 'nav2', not {variant!r}")
        before = sim.collisions
        start = stack.now
        leg.start(lat, lon)
        while leg.status is LegStatus.RUNNING:
            stack.run_for(0.5)
        leg_time = stack.now - start
        stack.run_for(SETTLE_S)
        pose = sim.pose
        results.append(GpsLegResult(seed, variant, name, leg.status.value, leg.reason,
                                    math.hypot(pose.x - gx, pose.y - gy), leg_time,
                                    leg.goals_sent, sim.collisions - before, course_error))
    return results


def run_gps_waypoints(seed: int = 0, course_file: str | Path | None = None,
                      timeout: float = 400.0) -> dict[str, Any]:
    """``Navigator.followGpsWaypoints`` over the course's ``gps_waypoints`` (lat/lon) in
    the georeferenced yard; the closest true approach to each point [m]."""
    from navstack.core.msgs import Odometry
    from navstack.geo.gps_goal import parse_coordinate
    from navstack.interfaces.api import Navigator
    from navstack.interfaces.stack import NavStack
    from navstack.sim.course import course_robot, course_world, ll_to_world, load_course

    course = load_course(course_file)
    stack = NavStack(course_world(course), course_robot(course), _rover_nav2_params(),
                     seed=seed)
    nav = Navigator(stack)
    truth: list[tuple[float, float]] = []
    stack.runtime.bus.subscribe("/ground_truth", Odometry, lambda msg: truth.append(
        (msg.pose.pose.position.x, msg.pose.pose.position.y)))
    points = [(w.latitude, w.longitude) for w in course.gps_waypoints]
    if not nav.followGpsWaypoints(points):
        raise RuntimeError(f"followGpsWaypoints refused the course: {nav.last_error}")
    while not nav.isTaskComplete() and stack.now < timeout:
        pass
    closest = []
    for i, (lat, lon) in enumerate(points):
        x, y = ll_to_world(course.georeference,
                           parse_coordinate(lat, f"gps_waypoints[{i}].latitude", "latitude"),
                           parse_coordinate(lon, f"gps_waypoints[{i}].longitude", "longitude"))
        closest.append(min(math.hypot(px - x, py - y) for px, py in truth))
    return {"result": nav.getResult().name, "closest_m": closest, "time_s": stack.now,
            "collisions": stack.sim.sim.collisions}


def run_search_legs(seed: int, legs: tuple[str, ...] | None = None,
                    course_file: str | Path | None = None, timeout: float = 400.0
                    ) -> list[dict[str, Any]]:
    """The post leg of ``seed`` (``POST_LEGS[seed % 3]``) and ``gate_a``, each on a fresh
    stack at the leg's ``start``; one row per leg (:meth:`LegOutcome.row` + seed)."""
    from navstack.core.msgs import Pose2D
    from navstack.interfaces.rover import rover_run, run_leg
    from navstack.sim.course import load_course

    course = load_course(course_file)
    names = legs if legs is not None else (POST_LEGS[seed % len(POST_LEGS)], "gate_a")
    rows = []
    for name in names:
        leg = course.leg(name)
        if leg.start is None:
            raise ValueError(f"leg {name} has no start pose in the course file")
        run = rover_run(seed, Pose2D(leg.start.x, leg.start.y, leg.start.yaw), course_file)
        try:
            rows.append({"seed": seed, **run_leg(run, leg, timeout).row()})
        finally:
            run.close()
    return rows


def search_metrics(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Post and gate rows of acceptance 3 from :func:`run_search_legs` rows."""
    out: dict[str, float] = {}
    posts = [r for r in rows if r["kind"] == "post"]
    gates = [r for r in rows if r["kind"] == "gate"]
    if posts:
        out["post_legs"] = float(len(posts))
        out["post_within_2m"] = float(sum(r["passed"] for r in posts))
        dist = [min(r["true_post_m"].values()) for r in posts]
        out["post_true_m_median"] = statistics.median(dist)
        out["post_true_m_max"] = max(dist)
        search = [r["search_s"] for r in posts if r["search_s"] is not None]
        if search:
            out["post_search_s_median"] = statistics.median(search)
            out["post_search_s_max"] = max(search)
    if gates:
        out["gate_legs"] = float(len(gates))
        out["gate_passed"] = float(sum(r["passed"] for r in gates))
        offs = [min(c["heading_off_normal_deg"] for c in r["crossings"])
                for r in gates if r["crossings"]]
        if offs:
            out["gate_heading_off_deg_median"] = statistics.median(offs)
            out["gate_heading_off_deg_max"] = max(offs)
        search = [r["search_s"] for r in gates if r["search_s"] is not None]
        if search:
            out["gate_search_s_median"] = statistics.median(search)
    out["search_collisions"] = float(sum(r["collisions"] for r in rows))
    return out


def run(quick: bool = False, data_dir: Path | None = None,
        progress: Progress | None = None) -> BenchResult:
    """20 seeds (3 with ``quick``) of calibration + PI chase leg + gps_goal_fix leg."""
    del data_dir  # the course ships with navstack
    seeds = QUICK_SEEDS if quick else SEEDS
    rows: list[GpsLegResult] = []
    walls: list[float] = []
    metrics: dict[str, float] = {"seeds": float(len(seeds))}
    cases: list[dict[str, Any]] = []
    if not quick:  # acceptance 4 on the yard itself (the CI test uses a small yard)
        if progress is not None:
            progress("gps waypoints", 0, 1)
        wp = run_gps_waypoints()
        metrics["gps_waypoints_within_3m"] = float(sum(d <= LEG_PASS_M
                                                       for d in wp["closest_m"]))
        metrics["gps_waypoints_closest_m_max"] = max(wp["closest_m"])
        metrics["gps_waypoints_collisions"] = float(wp["collisions"])
        cases.append({"seed": 0, "variant": "followGpsWaypoints", "leg": "gps_waypoints",
                      "status": wp["result"].lower(),
                      "true_m": round(max(wp["closest_m"]), 3),
                      "leg_s": round(wp["time_s"], 1), "goals": len(wp["closest_m"]),
                      "collisions": wp["collisions"],
                      "reason": "closest approach per point: " + ", ".join(
                          f"{d:.2f}" for d in wp["closest_m"])})
    for i, seed in enumerate(seeds):
        if progress is not None:
            progress("gnss legs", i, len(seeds))
        t0 = time.perf_counter()
        rows.extend(run_gps_legs(seed))
        walls.append(time.perf_counter() - t0)
    if progress is not None:
        progress("gnss legs", len(seeds), len(seeds))
    for variant in ("pi", "nav2"):
        mine = [r for r in rows if r.variant == variant]
        dist = [r.true_distance for r in mine]
        metrics[f"gnss_{variant}_within_3m"] = float(sum(
            d <= LEG_PASS_M and r.status == "succeeded" for d, r in zip(dist, mine,
                                                                         strict=True)))
        metrics[f"gnss_{variant}_final_m_median"] = statistics.median(dist)
        metrics[f"gnss_{variant}_final_m_max"] = max(dist)
        metrics[f"gnss_{variant}_leg_s_median"] = statistics.median(r.leg_time for r in mine)
        metrics[f"gnss_{variant}_collisions"] = float(sum(r.collisions for r in mine))
    search_rows: list[dict[str, Any]] = []
    for i, seed in enumerate(seeds):
        if progress is not None:
            progress("post and gate legs", i, len(seeds))
        search_rows.extend(run_search_legs(seed))
    if progress is not None:
        progress("post and gate legs", len(seeds), len(seeds))
    metrics.update(search_metrics(search_rows))
    metrics["collisions"] = float(sum(r.collisions for r in rows)
                                  + metrics.get("gps_waypoints_collisions", 0.0)
                                  + metrics["search_collisions"])
    metrics["calibration_course_error_deg_median"] = statistics.median(
        r.course_error_deg for r in rows)
    metrics["wall_s_per_seed_median"] = statistics.median(walls)
    cases += [
        {"seed": r.seed, "variant": r.variant, "leg": r.leg, "status": r.status,
         "true_m": round(r.true_distance, 3), "leg_s": round(r.leg_time, 1),
         "goals": r.goals_sent, "collisions": r.collisions, "reason": r.reason}
        for r in rows]
    cases += [{"seed": r["seed"], "variant": "tree", "leg": r["leg"], "status": r["status"],
               "true_m": min(r["true_post_m"].values()) if r["true_post_m"] else None,
               "leg_s": r["leg_s"], "goals": len(r["crossings"]),
               "collisions": r["collisions"],
               "reason": (f"{'PASS' if r['passed'] else 'FAIL'}; search {r['search_s']} s; "
                          f"crossings {r['crossings']}; {r['reason']}")}
              for r in search_rows]
    notes = [f"pass: final true distance <= {LEG_PASS_M:g} m, leg succeeded; "
             "GNSS 2 m white noise + 1 m bias (Gauss-Markov, 60 s) at 5 Hz",
             "post legs: post within 2 m of base_link at the end; gate legs: crossed the "
             "segment between the true posts, heading within 45 deg of the normal; "
             "search time from the GPS goal reached to the leg's end"]
    return BenchResult("rover", metrics, cases, notes, show_cases=True)
