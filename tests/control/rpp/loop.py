"""Closed-loop harness for RPP tests: exact unicycle integration, no simulator."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navstack.control.rpp import RegulatedPurePursuitController
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.costmap.costmap_2d import Costmap2D


def unicycle_step(pose: Pose2D, cmd: Twist2D, dt: float) -> Pose2D:
    """Exact integration of constant (v, w) over dt (arc of radius v / w)."""
    if abs(cmd.wz) < 1e-12:
        return Pose2D.from_array([pose.x + cmd.vx * dt * math.cos(pose.theta),
                                  pose.y + cmd.vx * dt * math.sin(pose.theta), pose.theta])
    r = cmd.vx / cmd.wz
    th = pose.theta + cmd.wz * dt
    return Pose2D.from_array([pose.x + r * (math.sin(th) - math.sin(pose.theta)),
                              pose.y - r * (math.cos(th) - math.cos(pose.theta)), th])


@dataclass
class Trace:
    """Per step: pose (x, y, theta) after the step, command (v, w) and robot-cell cost."""

    poses: np.ndarray
    cmds: np.ndarray
    costs: np.ndarray


def drive(ctrl: RegulatedPurePursuitController, path: Path, pose: Pose2D, seconds: float,
          costmap: Costmap2D | None = None, dt: float = 0.05,
          stop_within: float | None = None) -> Trace:
    """Run the controller at 1/dt Hz; a rolling 5 m window follows the robot unless a
    fixed ``costmap`` is given; stops early within ``stop_within`` of the path end."""
    rolling = costmap is None
    cm = costmap if costmap is not None else Costmap2D(100, 100, 0.05, -2.5, -2.5)
    goal = path.as_array()[-1]
    vel = Twist2D()
    poses, cmds, costs = [], [], []
    for k in range(round(seconds / dt)):
        if rolling:
            cm.update_origin(pose.x - 2.5, pose.y - 2.5)
        if stop_within is not None and math.hypot(pose.x - goal[0], pose.y - goal[1]) \
                < stop_within:
            break
        costs.append(cm.cost_at_world(pose.x, pose.y))
        cmd = ctrl.compute(pose, vel, path, cm, k * dt)
        pose = unicycle_step(pose, cmd, dt)
        vel = cmd
        poses.append((pose.x, pose.y, pose.theta))
        cmds.append((cmd.vx, cmd.wz))
    return Trace(np.array(poses), np.array(cmds), np.array(costs))


def straight_path(length: float, heading: float = 0.0, step: float = 0.05,
                  theta: float | None = None) -> Path:
    """Poses every ``step`` from the origin along ``heading``; orientation ``theta``
    (default: the heading)."""
    s = np.arange(0.0, length + 1e-9, step)
    th = heading if theta is None else theta
    return Path.from_array(np.column_stack((s * math.cos(heading), s * math.sin(heading),
                                            np.full_like(s, th))), frame_id="map")


def circle_path(radius: float, turns: float, step: float = 0.05) -> Path:
    """Counter-clockwise circle through the origin, centre (0, radius), heading +x at start."""
    s = np.arange(0.0, 2.0 * math.pi * radius * turns, step)
    th = s / radius
    return Path.from_array(np.column_stack((radius * np.sin(th), radius - radius * np.cos(th),
                                            th)), frame_id="map")
