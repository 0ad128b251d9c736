"""Scenes and a kinematic closed loop for the MPPI tests."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.control.mppi import MPPIController
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from navstack.costmap.inflation_kernel import cell_distance, cost_lut, inflate

FloatArray = NDArray[np.float64]


def straight_plan(length: float, ds: float = 0.05, y: float = 0.0) -> FloatArray:
    """``(N, 3)`` poses along +x from the origin."""
    x = np.arange(0.0, length + 1e-9, ds)
    return np.column_stack((x, np.full_like(x, y), np.zeros_like(x)))


def curved_plan(radius: float = 1.5, straight: float = 1.0, ds: float = 0.05) -> FloatArray:
    """A left quarter circle of ``radius`` from the origin, then ``straight`` m on."""
    s = np.arange(0.0, radius * math.pi / 2 + 1e-9, ds)
    arc = np.column_stack((radius * np.sin(s / radius), radius - radius * np.cos(s / radius),
                           s / radius))
    end = arc[-1]
    t = np.arange(ds, straight + 1e-9, ds)
    line = np.column_stack((end[0] + t * math.cos(end[2]), end[1] + t * math.sin(end[2]),
                            np.full_like(t, end[2])))
    return np.vstack((arc, line))


def costmap(size_m: float = 8.0, resolution: float = 0.05, origin: float = -4.0,
            frame: str = "odom") -> Costmap2D:
    n = round(size_m / resolution)
    return Costmap2D(n, n, resolution, origin, origin, frame_id=frame)


def add_box(cm: Costmap2D, x0: float, y0: float, x1: float, y1: float) -> None:
    """Mark the cells whose centres lie in ``[x0, x1] x [y0, y1]`` LETHAL."""
    xs = cm.origin_x + (np.arange(cm.size_x) + 0.5) * cm.resolution
    ys = cm.origin_y + (np.arange(cm.size_y) + 0.5) * cm.resolution
    ix = np.nonzero((xs >= x0) & (xs <= x1))[0]
    iy = np.nonzero((ys >= y0) & (ys <= y1))[0]
    cm.data[iy[0]:iy[-1] + 1, ix[0]:ix[-1] + 1] = LETHAL_OBSTACLE


def inflate_costmap(cm: Costmap2D, inscribed: float, radius: float, scaling: float) -> None:
    """Nav2 InflationLayer costs around every LETHAL cell."""
    r = cell_distance(radius, cm.resolution)
    lut = cost_lut(r, cm.resolution, inscribed, scaling)
    window = (0, 0, cm.size_x, cm.size_y)
    inflate(cm.data, window, window, r, lut)


@dataclass
class Run:
    """Outcome of a closed-loop run."""

    poses: list[Pose2D] = field(default_factory=list)
    commands: list[Twist2D] = field(default_factory=list)
    reached_at: float | None = None

    @property
    def final(self) -> Pose2D:
        return self.poses[-1]


def drive(ctrl: MPPIController, plan: FloatArray, cm: Costmap2D, *, dt: float,
          max_time: float, goal_tolerance: float = 0.25, start: Pose2D | None = None
          ) -> Run:
    """Integrate the commands as a perfect kinematic base (SE(2), body-frame twist) until
    the robot is within ``goal_tolerance`` of the plan's end (the goal checker's role)."""
    path = Path.from_array(plan, frame_id=cm.frame_id)
    pose = start or Pose2D(*plan[0])
    vel = Twist2D()
    run = Run([pose])
    goal = plan[-1]
    for k in range(round(max_time / dt)):
        if math.hypot(goal[0] - pose.x, goal[1] - pose.y) <= goal_tolerance:
            run.reached_at = k * dt
            break
        cmd = ctrl.compute(pose, vel, path, cm, k * dt)
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        pose = Pose2D.from_array([pose.x + (cmd.vx * c - cmd.vy * s) * dt,
                                  pose.y + (cmd.vx * s + cmd.vy * c) * dt,
                                  pose.theta + cmd.wz * dt])
        vel = cmd
        run.poses.append(pose)
        run.commands.append(cmd)
    return run


def footprint_rect(length: float, width: float) -> Footprint:
    hx, hy = length / 2, width / 2
    return Footprint.from_polygon([[hx, hy], [hx, -hy], [-hx, -hy], [-hx, hy]])
