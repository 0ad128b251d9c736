"""Closed loop: DWB drives a simulated unicycle along a curved plan to the goal."""

from __future__ import annotations

import math

import numpy as np

from navstack.control.dwb import DWBLocalPlanner
from navstack.control.goal_checker import SimpleGoalChecker
from navstack.core.msgs import Path, Pose2D, Twist2D
from navstack.costmap.costmap_2d import Costmap2D


def _curved_plan() -> np.ndarray:
    """Quarter circle of radius 2 m turning left, then 2.5 m straight (5.6 m, 0.05 m spacing)."""
    r, ds = 2.0, 0.05
    s = np.arange(0.0, r * math.pi / 2 + 1e-9, ds)
    arc = np.column_stack((r * np.sin(s / r), r - r * np.cos(s / r), s / r))
    end = arc[-1]
    t = np.arange(ds, 2.5 + 1e-9, ds)
    line = np.column_stack((end[0] + t * math.cos(end[2]), end[1] + t * math.sin(end[2]),
                            np.full_like(t, end[2])))
    return np.vstack((arc, line))


def test_follows_curved_path_to_goal() -> None:
    plan = _curved_plan()
    path = Path.from_array(plan, frame_id="odom")
    seg = np.linspace(0.0, 1.0, 10, endpoint=False)[:, None, None]
    dense = (plan[:-1, None, :2] + seg.transpose(1, 0, 2) * np.diff(plan[:, :2], axis=0)[:, None])
    dense = np.vstack((dense.reshape(-1, 2), plan[-1:, :2]))
    costmap = Costmap2D(60, 60, 0.05, -1.5, -1.5, frame_id="odom")  # 3 m rolling window
    dwb, checker = DWBLocalPlanner(), SimpleGoalChecker()
    goal = Pose2D(*plan[-1])
    pose, vel, dt = Pose2D(), Twist2D(), 0.05
    max_cte, reached_at = 0.0, None
    for k in range(600):  # 30 s of simulated time
        costmap.update_origin(pose.x - 1.5, pose.y - 1.5)
        if checker.is_goal_reached(pose, goal, vel):
            reached_at = k * dt
            break
        cmd = dwb.compute(pose, vel, path, costmap, k * dt)
        heading = pose.theta + 0.5 * cmd.wz * dt  # unicycle, midpoint heading
        pose = Pose2D.from_array([pose.x + cmd.vx * math.cos(heading) * dt,
                                  pose.y + cmd.vx * math.sin(heading) * dt,
                                  pose.theta + cmd.wz * dt])
        vel = cmd
        max_cte = max(max_cte, float(np.min(np.hypot(dense[:, 0] - pose.x,
                                                     dense[:, 1] - pose.y))))
    assert reached_at is not None and reached_at < 30.0
    assert pose.distance_to(goal) <= 0.25
    assert max_cte < 0.15
    # 5.6 m at 0.26 m/s is 21.5 s; the robot stops as it enters the 0.25 m goal window
    assert 18.0 < reached_at < 25.0
