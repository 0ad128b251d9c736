"""Simulated camera benchmark (metric ``camera_frame_ms``, budget 5 ms).

A 640 x 480 frame of the ``diff_drive`` profile's camera (the Nav2 lab's: horizontal FOV
1.047 rad, pixel noise on, 4x oversampled markers) is rendered in a 6 x 6 m room with
four 10 cm markers on the far wall, a box and a walker, from poses that keep all four
markers in view (1.7 - 2.9 m away, +-0.1 rad heading).  The metric is the median wall
time of one frame; the corners mode and the optional effects (lens distortion, motion
blur) are reported beside it.
"""

from __future__ import annotations

import math
import statistics
from functools import partial
from typing import Any

import numpy as np

from navstack.benchmarks.common import BenchResult, time_ms
from navstack.core.msgs import Pose2D
from navstack.sim.camera import CameraModel
from navstack.sim.robot import load_robot
from navstack.sim.world import World
from navstack.sim.world_io import world_from_mapping

BUDGET_MS = 5.0


def bench_world() -> World:
    """The benchmark room: markers ids 0-3 on the east wall facing west."""
    markers = [{"id": i, "size": 0.1, "position": [5.899, 2.4 + 0.4 * i], "height": 0.3,
                "yaw": math.pi} for i in range(4)]
    return world_from_mapping({
        "name": "camera_bench", "size": [6.0, 6.0], "resolution": 0.05, "boundary": True,
        "walls": [{"from": [0.0, 1.0], "to": [2.0, 1.0], "thickness": 0.1}],
        "boxes": [{"center": [4.5, 5.0], "size": [0.6, 0.4]}],
        "moving_obstacles": [{"name": "walker", "shape": "circle", "radius": 0.25,
                              "path": [[2.5, 4.8], [2.5, 5.5]], "speed": 0.3}],
        "markers": markers,
        "packages": [{"id": 10, "position": [4.0, 2.0], "yaw": 0.4}],
        "spawn": {"x": 3.0, "y": 3.0}})


def _poses(n: int, seed: int) -> list[Pose2D]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        x = float(rng.uniform(2.8, 4.0))
        y = float(rng.uniform(2.9, 3.1))
        out.append(Pose2D(x, y, float(rng.uniform(-0.1, 0.1))))
    return out


def run(quick: bool = False, data_dir: Any = None) -> BenchResult:
    """Time the camera's render and corners modes (see module docstring)."""
    del data_dir
    world = bench_world()
    params = load_robot("diff_drive").sensors.camera
    cam = CameraModel(params)
    rng = np.random.default_rng(3)
    moving = world.moving_at(0.0)
    poses = _poses(20 if quick else 60, 5)
    repeats = 3 if quick else 10
    in_view = [sum(1 for pm in cam.visible_markers(world, p, moving) if pm.marker.package is None)
               for p in poses]
    frame: list[float] = []
    corners: list[float] = []
    for pose in poses:
        frame += time_ms(partial(cam.render, world, pose, rng, moving), repeats, warmup=1)
        corners += time_ms(partial(cam.detect_corners, world, pose, rng, moving), repeats,
                           warmup=1)
    effects = CameraModel(params.updated(distortion=(-0.1, 0.02, 0.0, 0.0, 0.0),
                                         motion_blur=True, exposure_time=0.02))
    fx: list[float] = []
    for pose in poses[:10]:
        fx += time_ms(partial(effects.render, world, pose, rng, moving, yaw_rate=1.0),
                      repeats, warmup=1)
    median = float(statistics.median(frame))
    result = BenchResult("camera")
    result.metrics = {
        "camera_frame_ms": median,
        "camera_frame_p95_ms": float(np.percentile(frame, 95)),
        "camera_corners_ms": float(statistics.median(corners)),
        "camera_frame_distortion_blur_ms": float(statistics.median(fx)),
        "markers_in_view_min": float(min(in_view)),
        "budget_ms": BUDGET_MS,
        "within_budget": float(median <= BUDGET_MS),
    }
    result.cases = [{"width": params.width, "height": params.height,
                     "oversample": params.oversample, "frames": len(frame)}]
    if min(in_view) < 4:
        result.notes.append(f"some poses saw only {min(in_view)} of the 4 markers")
    return result
