"""Open-loop driving: the ``navstack sim`` command's engine."""

from __future__ import annotations

import time
from typing import Any

from navstack.core.msgs import Twist
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import load_robot
from navstack.sim.simulator import Simulator
from navstack.sim.worlds import load_world


def build_sim(world: str, robot: str, seed: int, physics_rate_hz: float = 50.0,
              perfect_localization: bool = True) -> tuple[Runtime, SimulatorNode]:
    """A runtime holding one simulator node for ``world`` and ``robot`` (names or paths)."""
    rt = Runtime()
    sim = Simulator(load_world(world), load_robot(robot), seed=seed)
    node = SimulatorNode(rt, sim, physics_rate_hz, perfect_localization)
    return rt, node


def run_open_loop(world: str, robot: str, duration: float, vx: float, wz: float,
                  seed: int = 0) -> dict[str, Any]:
    """Drive with a constant command (published on ``/cmd_vel`` at 20 Hz) for ``duration``."""
    rt, node = build_sim(world, robot, seed)
    cmd_pub = rt.bus.publisher("/cmd_vel", Twist)
    cmd = Twist.planar(vx, 0.0, wz)
    rt.scheduler.create_timer(0.05, lambda: cmd_pub.publish(cmd), first_at=0.0)
    rt.bring_up()
    t0 = time.perf_counter()
    rt.scheduler.run_until(duration)
    node.advance()
    wall = time.perf_counter() - t0
    sim = node.sim
    p = sim.pose
    return {
        "world": world, "robot": robot, "seed": seed, "duration_s": duration,
        "command": {"vx": vx, "wz": wz},
        "final_pose": {"x": p.x, "y": p.y, "yaw": p.theta},
        "collisions": sim.collisions, "rejected_commands": sim.rejected_commands,
        "distance_m": sim.distance_travelled, "scans": node.scans_published,
        "odom_msgs": node.odom_published, "wall_time_s": wall,
        "real_time_factor": duration / wall if wall > 0 else float("inf"),
    }
