"""``navstack bench sim``: lidar ray-casting cost and simulator real-time factor.

Metrics (issue #2): ``lidar_scan_ms`` — median time of one 360-beam scan on a 2000x2000
grid (budget <= 1.0); ``sim_rtf`` — simulated seconds per wall second for a diff-drive
robot in the office world with lidar at 10 Hz and odometry at 50 Hz and nothing else
running (budget >= 200).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from navstack.benchmarks.common import BenchResult
from navstack.benchmarks.lidar import measure_lidar_scan_ms
from navstack.core.msgs import Twist
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world


def measure_sim_rtf(duration: float, seed: int = 0) -> float:
    """Real-time factor of a bare simulation (lidar 10 Hz + odometry 50 Hz only)."""
    robot = load_robot("diff_drive")
    sensors = robot.sensors
    robot = robot.updated(sensors=sensors.updated(
        lidar=sensors.lidar.updated(rate_hz=10.0),
        odometry=sensors.odometry.updated(rate_hz=50.0),
        imu=sensors.imu.updated(enabled=False),
        ground_truth=sensors.ground_truth.updated(enabled=False)))
    rt = Runtime()
    SimulatorNode(rt, Simulator(load_world("office"), robot, seed=seed))
    cmd_pub = rt.bus.publisher("/cmd_vel", Twist)
    cmd = Twist.planar(0.25, 0.0, 0.0)  # east along the office corridor from the spawn
    rt.scheduler.create_timer(0.1, lambda: cmd_pub.publish(cmd), first_at=0.0)
    rt.bring_up()
    rt.scheduler.run_until(1.0)  # warm-up (numba dispatch, caches)
    t0 = time.perf_counter()
    rt.scheduler.run_until(1.0 + duration)
    return duration / (time.perf_counter() - t0)


def run(quick: bool, data_dir: Path | None) -> BenchResult:
    result = BenchResult("sim")
    lidar_ms, lidar_info = measure_lidar_scan_ms(quick)
    result.metrics["lidar_scan_ms"] = lidar_ms
    result.cases.append({"case": "lidar_2000x2000_360", **lidar_info})
    runs = [measure_sim_rtf(20.0 if quick else 55.0, seed=i) for i in range(3 if quick else 7)]
    result.metrics["sim_rtf"] = float(statistics.median(runs))
    result.cases.append({"case": "office_diff_drive_rtf", "runs": runs})
    result.notes.append("budgets: lidar_scan_ms <= 1.0, sim_rtf >= 200 (medians)")
    return result
