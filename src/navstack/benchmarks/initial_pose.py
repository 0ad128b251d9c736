"""The initial-pose evaluation (``initial_pose_err_m`` of ``navstack bench localization``).

It drives the simulator, which ``localization/`` must not import, so it lives here.
"""

from __future__ import annotations

import math

import numpy as np

from navstack.core.errors import SimulationError
from navstack.core.msgs import Pose2D
from navstack.localization.initial_pose import (
    InitialPoseParams,
    MapMatcher,
    estimate_initial_pose,
)
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world


def initial_pose_trials(n: int = 20, seed: int = 0, world: str = "office",
                        robot: str = "turtlebot", gnss_sigma: float = 2.0,
                        heading_error_deg: float = 15.0, world_yaw: float = 0.4,
                        clearance: float = 0.4) -> list[float]:
    """Position errors [m] of the refined initial pose over ``n`` random trials.

    Each trial spawns the robot at a random free pose (at least ``clearance`` from static
    obstacles) in the built-in ``world``, with the simulator's GNSS (white noise
    ``gnss_sigma`` per axis, i.e. a radial RMS of ``sqrt(2) * gnss_sigma``) and
    magnetometer (heading offset of exactly +-``heading_error_deg``, sign random),
    the world rotated by ``world_yaw`` in ENU (so ``map_from_enu`` is not trivial); the
    real scan of the simulated lidar is matched.
    """
    w = load_world(world)
    rng = np.random.default_rng(seed)
    base = load_robot(robot)
    geo = base.sensors.georeference
    params = InitialPoseParams(datum=(geo.latitude, geo.longitude, geo.altitude),
                               map_from_enu=(0.0, 0.0, -world_yaw), magnetic_declination=0.18)
    matcher = MapMatcher.from_grid(w.to_occupancy_grid(), params)
    free = np.argwhere(w.distance_field() >= clearance)
    errors: list[float] = []
    for i in range(n):
        r, c = free[rng.integers(len(free))]
        x, y = w.cell_center(int(r), int(c))
        pose = Pose2D(x, y, float(rng.uniform(-math.pi, math.pi)))
        sign = 1.0 if rng.random() < 0.5 else -1.0
        prof = load_robot(robot, {"sensors": {
            "gnss": {"enabled": True, "horizontal_noise_std": gnss_sigma, "bias_std": 0.0,
                     "mount": {"x": 0.0, "y": 0.0, "z": 0.3}},
            "magnetometer": {"enabled": True, "declination": 0.18, "noise_std": 0.0,
                             "heading_offset": sign * math.radians(heading_error_deg)},
            "georeference": {"world_yaw": world_yaw}}})
        sim = Simulator(w, prof, seed=seed * 1000 + i, spawn=pose)
        scan = sim.scan(0.0)
        gnss = sim.gnss_sample(0.0)
        mag = sim.magnetic_field(0.0)
        if scan is None or gnss is None or mag is None:
            raise SimulationError(f"trial {i}: the '{robot}' profile gave no scan, fix or "
                                  "magnetometer sample at t=0 (scan_dropout_prob > 0?)")
        sensors = prof.sensors
        est = estimate_initial_pose(matcher, gnss[0], mag, scan, sensors.lidar.mount.pose2d,
                                    (sensors.gnss.mount.x, sensors.gnss.mount.y),
                                    sensors.magnetometer.mount.yaw)
        errors.append(est.pose.distance_to(pose))
    return errors
