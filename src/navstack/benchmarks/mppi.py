"""MPPI benchmark: full controller cycles with every critic on, per motion model.

Scene: a 10 m x 10 m local costmap at 0.05 m (200 x 200 cells) with six 0.4 m boxes
alternating left and right of a curved plan (1.5 m straight, a quarter circle of radius
2.5 m, 2 m straight; 0.05 m spacing), their near edges 0.55 m from it, inflated as
Nav2's InflationLayer does (``inflation_radius`` 0.55 m, ``cost_scaling_factor`` 3.0,
0.5 m x 0.4 m footprint).  The controller is Nav2's MPPI
with ``batch_size`` 2000 x ``time_steps`` 56 and all eleven critics enabled
(CostCritic and ObstaclesCritic checking the footprint near obstacles,
VelocityDeadbandCritic with a 0.05 deadband).  The robot follows its own commands
(perfect tracking at 20 Hz) until it is within 0.25 m of the goal; every ``compute()``
call of the loop is timed.

Metrics (medians of full ``compute()`` calls, milliseconds; budget 10 ms each):
``mppi_cycle_ms_diff``, ``mppi_cycle_ms_omni``, ``mppi_cycle_ms_ackermann`` and
``mppi_cycle_ms`` (the largest of the three).  Cases also record the 90th percentile,
the CPU time per cycle (the machine may be shared: wall time includes waiting for a
core), the distance driven and the closest approach to a lethal cell.
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path as FsPath
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.benchmarks.common import BenchResult
from navstack.control.mppi import MPPIController
from navstack.core.errors import ControllerError
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from navstack.costmap.inflation_kernel import cell_distance, cost_lut, inflate

BUDGET_MS = 10.0
ALL_CRITICS = ["ConstraintCritic", "CostCritic", "ObstaclesCritic", "GoalCritic",
               "GoalAngleCritic", "PathAlignCritic", "PathFollowCritic", "PathAngleCritic",
               "PreferForwardCritic", "TwirlingCritic", "VelocityDeadbandCritic"]
FOOTPRINT = [[0.25, 0.2], [0.25, -0.2], [-0.25, -0.2], [-0.25, 0.2]]
INFLATION_RADIUS, COST_SCALING = 0.55, 3.0


def bench_plan() -> NDArray[np.float64]:
    """The curved plan ``(N, 3)``: 1.5 m straight, left quarter circle r=2.5 m, 2 m up."""
    ds, r = 0.05, 2.5
    x0, y0 = -3.5, -3.5
    a = np.arange(0.0, 1.5, ds)
    s1 = np.column_stack((x0 + a, np.full_like(a, y0), np.zeros_like(a)))
    th = np.arange(0.0, math.pi / 2, ds / r)
    cx, cy = x0 + 1.5, y0 + r
    s2 = np.column_stack((cx + r * np.sin(th), cy - r * np.cos(th), th))
    b = np.arange(0.0, 2.0 + 1e-9, ds)
    s3 = np.column_stack((np.full_like(b, cx + r), cy + b, np.full_like(b, math.pi / 2)))
    return np.vstack((s1, s2, s3))


def bench_costmap() -> Costmap2D:
    """10 m x 10 m at 0.05 m, 0.4 m boxes 0.75 m left and right of the plan, inflated."""
    cm = Costmap2D(200, 200, 0.05, -5.0, -5.0, frame_id="odom")
    plan = bench_plan()
    for k, side in ((12, 1.0), (30, -1.0), (50, 1.0), (75, -1.0), (95, 1.0), (120, -1.0)):
        x, y, th = plan[k]
        cx, cy = x - side * 0.75 * math.sin(th), y + side * 0.75 * math.cos(th)
        x0, x1 = int((cx - 0.2 + 5.0) / 0.05), int((cx + 0.2 + 5.0) / 0.05)
        y0, y1 = int((cy - 0.2 + 5.0) / 0.05), int((cy + 0.2 + 5.0) / 0.05)
        cm.data[y0:y1, x0:x1] = LETHAL_OBSTACLE
    fp = Footprint.from_polygon(FOOTPRINT)
    radius_cells = cell_distance(INFLATION_RADIUS, cm.resolution)
    lut = cost_lut(radius_cells, cm.resolution, fp.inscribed_radius, COST_SCALING)
    window = (0, 0, cm.size_x, cm.size_y)
    inflate(cm.data, window, window, radius_cells, lut)
    return cm


def bench_params(model: str) -> dict[str, Any]:
    """Nav2 defaults, batch 2000 x 56 steps, every critic on."""
    collision = {"consider_footprint": True, "inflation_radius": INFLATION_RADIUS,
                 "cost_scaling_factor": COST_SCALING}
    return {"motion_model": model, "batch_size": 2000, "time_steps": 56,
            "critics": list(ALL_CRITICS), "shift_control_sequence": True,
            "AckermannConstraints": {"min_turning_r": 0.5},
            "CostCritic": dict(collision), "ObstaclesCritic": dict(collision),
            "VelocityDeadbandCritic": {"deadband_velocities": [0.05, 0.05, 0.05]}}


def run_model(model: str, cycles: int, warmup: int = 3) -> dict[str, Any]:
    """Closed-loop cycles of one motion model; timing and outcome row."""
    plan = bench_plan()
    path = Path.from_array(plan, frame_id="odom")
    cm = bench_costmap()
    ctrl = MPPIController(bench_params(model), footprint=Footprint.from_polygon(FOOTPRINT))
    pose, vel, dt = Pose2D(*plan[0]), Twist2D(), 0.05
    times: list[float] = []
    cpu: list[float] = []
    driven, failures = 0.0, 0
    lethal = np.argwhere(cm.data == LETHAL_OBSTACLE)
    lethal_xy = cm.origin_x + (lethal[:, ::-1] + 0.5) * cm.resolution
    closest = math.inf
    reached: float | None = None
    for k in range(warmup + cycles):
        if math.hypot(plan[-1, 0] - pose.x, plan[-1, 1] - pose.y) <= 0.25:
            reached = (k - warmup) * dt
            break
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            cmd = ctrl.compute(pose, vel, path, cm, k * dt)
        except ControllerError:
            cmd, failures = Twist2D(), failures + 1
        if k >= warmup:
            times.append((time.perf_counter() - t0) * 1e3)
            cpu.append((time.thread_time() - c0) * 1e3)
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        nxt = Pose2D.from_array([pose.x + (cmd.vx * c - cmd.vy * s) * dt,
                                 pose.y + (cmd.vx * s + cmd.vy * c) * dt,
                                 pose.theta + cmd.wz * dt])
        driven += pose.distance_to(nxt)
        pose, vel = nxt, cmd
        closest = min(closest, float(np.min(np.hypot(lethal_xy[:, 0] - pose.x,
                                                     lethal_xy[:, 1] - pose.y))))
    times.sort()
    return {"model": model, "cycles": len(times), "median_ms": statistics.median(times),
            "p90_ms": times[int(0.9 * (len(times) - 1))],
            "cpu_median_ms": statistics.median(cpu), "driven_m": driven,
            "closest_lethal_m": closest, "failures": failures, "reached_goal_s": reached,
            "goal_distance_m": math.hypot(plan[-1, 0] - pose.x, plan[-1, 1] - pose.y)}


def run(quick: bool, data_dir: FsPath | None = None) -> BenchResult:
    """``navstack bench mppi``: median compute() time per motion model (no data files)."""
    cycles = 40 if quick else 400
    result = BenchResult("mppi")
    for name, model in (("diff", "DiffDrive"), ("omni", "Omni"), ("ackermann", "Ackermann")):
        row = run_model(model, cycles)
        result.cases.append(row)
        result.metrics[f"mppi_cycle_ms_{name}"] = row["median_ms"]
    result.metrics["mppi_cycle_ms"] = max(result.metrics[f"mppi_cycle_ms_{n}"]
                                          for n in ("diff", "omni", "ackermann"))
    result.notes.append(
        f"batch 2000 x 56 steps, all 11 critics, up to {cycles} closed-loop cycles per "
        f"model (until the goal is within 0.25 m) after 3 warm-up cycles; budget "
        f"{BUDGET_MS:.0f} ms median per cycle")
    return result
