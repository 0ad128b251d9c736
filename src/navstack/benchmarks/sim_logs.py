"""Simulated laser logs: drive a loop route through a built-in world and record scans,
wheel odometry and the true pose -- a CARMEN-style log with perfect ground truth.

The robot (its kinematics, lidar and wheel-odometry noise from the robot profile) follows
the route's corners with a pure-pursuit-like controller at the simulator's physics rate;
a scan is recorded whenever the robot has moved ``spacing`` metres or turned ``0.1`` rad
since the last one (``spacing`` 0.1: a *dense* log, a scan every ~0.1 m) or a second has
passed, but never more often than the lidar's rate (``spacing`` 0: every lidar scan).
The world's moving obstacles are removed: the score compares the map with the static
world raster, and SLAM among moving people is exercised by the SLAM-while-navigating
benchmark (:mod:`navstack.benchmarks.sim_mapping`).

The logs feed :func:`navstack.mapping.offline.score_run` exactly like a CARMEN log, with
the true poses as the reference.  ``navstack bench slam-robust`` maps the warehouse and
the campus this way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Pose2D, Twist2D
from navstack.mapping.offline import ScanLog
from navstack.mapping.slam import LaserGeometry
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world

FloatArray = NDArray[np.float64]

__all__ = ["ROUTES", "SimLog", "record_route"]

#: Loop routes (corner points, metres) through the built-in worlds, each starting and
#: ending at the spawn.  Warehouse: up aisle 1, back down aisle 5, around the racks;
#: campus: the west road, the plaza, the road between library and lab, the south road.
ROUTES: dict[str, tuple[tuple[float, float], ...]] = {
    "warehouse": ((2.0, 2.0), (8.25, 3.2), (8.25, 23.1), (22.25, 23.1), (22.25, 3.2),
                  (36.0, 3.2), (36.0, 23.1), (4.9, 23.1), (4.9, 3.2), (8.25, 3.2),
                  (8.25, 12.0)),
    "campus": ((7.0, 7.0), (7.0, 46.5), (44.5, 46.5), (44.5, 7.0), (7.0, 7.0),
               (7.0, 20.0)),
}


@dataclass(frozen=True)
class SimLog:
    """A recorded drive: the scans as a :class:`ScanLog` (reference = true poses), the
    world's name, the simulated duration [s], the distance driven [m] and collisions."""

    log: ScanLog
    world: str
    duration_s: float
    distance_m: float
    collisions: int


def record_route(world: str, route: tuple[tuple[float, float], ...] | None = None, *,
                 robot: str = "diff_drive", seed: int = 1, spacing: float = 0.1,
                 laps: int = 1, physics_rate_hz: float = 50.0,
                 timeout_s: float = 7200.0) -> SimLog:
    """Drive ``route`` (default :data:`ROUTES` ``[world]``) ``laps`` times and record."""
    corners = list(route or ROUTES[world])
    w = replace(load_world(world), moving_obstacles=())
    params = load_robot(robot)
    start_heading = math.atan2(corners[1][1] - corners[0][1], corners[1][0] - corners[0][0])
    sim = Simulator(w, params, seed=seed, spawn=Pose2D(corners[0][0], corners[0][1],
                                                       start_heading))
    if sim.lidar is None or sim.odometry is None:
        raise ValueError(f"robot '{robot}' needs a lidar and wheel odometry to record a log")
    lidar = sim.lidar
    kin = params.kinematics
    v_max = 0.8 * kin.max_vel_x
    w_max = 0.8 * kin.max_vel_theta
    dt = 1.0 / physics_rate_hz
    targets = corners[1:] + (corners[1:] * (laps - 1))
    ranges: list[NDArray[np.float32]] = []
    odom: list[tuple[float, float, float]] = []
    truth: list[tuple[float, float, float]] = []
    stamps: list[float] = []
    last: tuple[float, float, float] | None = None
    last_t = -math.inf
    t = 0.0
    i = 0
    while i < len(targets) and t < timeout_s:
        pose = sim.pose
        tx, ty = targets[i]
        dx, dy = tx - pose.x, ty - pose.y
        dist = math.hypot(dx, dy)
        if dist < 0.15:
            i += 1
            continue
        err = math.remainder(math.atan2(dy, dx) - pose.theta, 2 * math.pi)
        wz = max(-w_max, min(w_max, 2.0 * err))
        vx = v_max * max(0.0, math.cos(err)) ** 4 * min(1.0, dist / 0.5 + 0.3)
        sim.set_command(Twist2D(vx, 0.0, wz), t)
        sim.step(dt)
        t += dt
        pose = sim.pose
        o = sim.odometry.pose
        moved = last is None or (t - last_t >= lidar.scan_time - 1e-9 and (
            math.hypot(pose.x - last[0], pose.y - last[1]) >= spacing
            or abs(math.remainder(pose.theta - last[2], 2 * math.pi)) >= 0.1
            or t - last_t >= 1.0))
        if moved:
            scan = sim.scan(t)
            if scan is None:
                continue
            ranges.append(np.asarray(scan.ranges, np.float32))
            odom.append((o.x, o.y, o.theta))
            truth.append((pose.x, pose.y, pose.theta))
            stamps.append(t)
            last, last_t = (pose.x, pose.y, pose.theta), t
    m = lidar.mount
    laser = LaserGeometry(np.asarray(lidar.beam_angles, dtype=np.float64), lidar.range_min,
                          lidar.range_max, np.array([m.x, m.y, m.yaw]))
    log = ScanLog(name=f"sim:{world}", laser=laser, ranges=ranges,
                  odometry=np.array(odom, dtype=np.float64).reshape(-1, 3),
                  odom_gaps=np.zeros(len(ranges), dtype=bool),
                  stamps=np.array(stamps, dtype=np.float64),
                  reference=np.array(truth, dtype=np.float64).reshape(-1, 3))
    return SimLog(log, world, t, sim.distance_travelled, sim.collisions)
