"""Collision monitor, "approach" behaviour (Nav2 ``nav2_collision_monitor``).

Given the commanded body velocity and the latest raw sensor points in ``base_link``, the
robot's motion is simulated for ``time_before_collision`` seconds in steps of
``simulation_time_step`` (Nav2's parameter names); at the first simulated pose whose
footprint contains a point, the command is scaled by ``t_collision /
time_before_collision`` so the robot slows down and stops short of the obstacle instead
of relying on a costmap that lags a moving obstacle by one update.  Pure: no bus.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.msgs import Twist2D
from navstack.core.params import Params
from navstack.core.polygon import points_in_polygon

FloatArray = NDArray[np.float64]


class ApproachParams(Params):
    """Nav2 collision_monitor polygon of ``action_type: approach`` (names as Nav2)."""

    enabled: bool = True
    time_before_collision: float = Field(1.2, gt=0.0)
    simulation_time_step: float = Field(0.1, gt=0.0)
    min_points: int = Field(1, ge=1)
    max_range: float = Field(3.0, gt=0.0)


class ApproachMonitor:
    """Scales commands so the footprint never reaches a sensed point within the horizon."""

    def __init__(self, footprint: FloatArray, params: ApproachParams | None = None) -> None:
        self.params = params or ApproachParams()
        self.footprint = np.asarray(footprint, dtype=np.float64)
        self.radius = float(np.max(np.hypot(self.footprint[:, 0], self.footprint[:, 1])))
        p = self.params
        steps = math.ceil(p.time_before_collision / p.simulation_time_step)
        self.times = np.arange(1, steps + 1) * p.simulation_time_step
        self.last_ratio = 1.0

    def collision_time(self, cmd: Twist2D, points_base: FloatArray) -> float | None:
        """First simulated time [s] at which the footprint holds ``min_points`` points."""
        p = self.params
        if len(points_base) == 0 or (cmd.vx == 0.0 and cmd.vy == 0.0 and cmd.wz == 0.0):
            return None
        reach = self.radius + math.hypot(cmd.vx, cmd.vy) * p.time_before_collision
        d = np.hypot(points_base[:, 0], points_base[:, 1])
        pts = points_base[(d <= min(reach, p.max_range))]
        if len(pts) < p.min_points:
            return None
        for t in self.times:  # few steps; each test is vectorised over points
            th = cmd.wz * t
            if abs(cmd.wz) < 1e-9:
                x, y = cmd.vx * t, cmd.vy * t
            else:  # exact arc for a constant body twist
                s, c = math.sin(th), math.cos(th)
                x = (cmd.vx * s + cmd.vy * (c - 1.0)) / cmd.wz
                y = (cmd.vx * (1.0 - c) + cmd.vy * s) / cmd.wz
            dx, dy = pts[:, 0] - x, pts[:, 1] - y
            near = dx * dx + dy * dy <= self.radius * self.radius  # broad phase
            if int(np.count_nonzero(near)) < p.min_points:
                continue
            cs, sn = math.cos(th), math.sin(th)
            dx, dy = dx[near], dy[near]
            local = np.column_stack((cs * dx + sn * dy, -sn * dx + cs * dy))
            if int(np.count_nonzero(points_in_polygon(local, self.footprint))) >= p.min_points:
                return float(t)
        return None

    def filter(self, cmd: Twist2D, points_base: FloatArray) -> Twist2D:
        """The command, slowed in proportion to the time left before contact."""
        self.last_ratio = 1.0
        if not self.params.enabled:
            return cmd
        t = self.collision_time(cmd, points_base)
        if t is None:
            return cmd
        ratio = max(0.0, (t - self.params.simulation_time_step) /
                    self.params.time_before_collision)
        self.last_ratio = ratio
        return Twist2D(cmd.vx * ratio, cmd.vy * ratio, cmd.wz * ratio)
