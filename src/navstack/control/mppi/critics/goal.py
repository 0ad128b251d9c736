"""Goal critics: GoalCritic and GoalAngleCritic (Nav2 ``mppi::critics``).

Both take over from the path critics close to the goal; they are active only while the
robot is within ``threshold_to_consider`` of the plan's last pose.

* **GoalCritic** ``mean_t |p_t - goal|`` (xy distance of every pose to the goal);
* **GoalAngleCritic** ``mean_t |yaw_t - goal_yaw|`` (wrapped), where ``goal_yaw`` is the
  yaw of the pruned plan's last pose (Nav2 reads it from the local path); with
  ``symmetric_yaw_tolerance`` the goal yaw + pi counts as well (robots that may arrive
  backwards).

Each term is ``(raw * cost_weight) ** cost_power``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.control.mppi.critics.base import (
    Critic,
    CriticData,
    WeightedCriticParams,
    register_critic,
)

FloatArray = NDArray[np.float64]
Float32Array = NDArray[np.float32]
_TWO_PI = 2.0 * math.pi


@numba.njit(cache=True, fastmath=True)
def goal_distance_critic(traj: Float32Array, gx: float, gy: float, scale: float,
                         power: float, costs: FloatArray) -> None:
    """Add ``(scale * sum_t |p_t - g|) ** power`` (``traj`` (3, T, B))."""
    n_steps, batch = traj.shape[1], traj.shape[2]
    acc = np.zeros(batch, dtype=np.float32)
    fx, fy = np.float32(gx), np.float32(gy)
    for t in range(n_steps):
        for i in range(batch):
            dx, dy = traj[0, t, i] - fx, traj[1, t, i] - fy
            acc[i] += math.sqrt(dx * dx + dy * dy)
    for i in range(batch):
        v = acc[i] * scale
        costs[i] += v if power == 1.0 else v ** power


@numba.njit(cache=True, fastmath=True)
def goal_angle_critic(traj: Float32Array, goal_yaw: float, symmetric: bool, scale: float,
                      power: float, costs: FloatArray) -> None:
    """Add ``(scale * sum_t |wrap(yaw_t - goal_yaw)|) ** power``; with ``symmetric`` the
    smaller of the errors to ``goal_yaw`` and ``goal_yaw + pi``."""
    n_steps, batch = traj.shape[1], traj.shape[2]
    acc = np.zeros(batch)
    for t in range(n_steps):
        for i in range(batch):
            d = traj[2, t, i] - goal_yaw
            d = abs(d - _TWO_PI * math.floor((d + math.pi) / _TWO_PI))
            if symmetric:
                d = min(d, math.pi - d)
            acc[i] += d
    for i in range(batch):
        v = acc[i] * scale
        costs[i] += v if power == 1.0 else v ** power


class GoalCriticParams(WeightedCriticParams):
    """``GoalCritic``: mean distance of the trajectory poses to the goal, active once the
    robot is within ``threshold_to_consider`` of it."""

    cost_weight: float = Field(5.0, ge=0.0)
    threshold_to_consider: float = Field(1.4, ge=0.0)


@register_critic("GoalCritic")
class GoalCritic(Critic):
    """Pull the trajectories onto the goal position near the goal."""

    params_model = GoalCriticParams
    params: GoalCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not p.enabled or data.goal_distance >= p.threshold_to_consider:
            return
        goal_distance_critic(data.trajectories, float(data.goal[0]), float(data.goal[1]),
                             p.cost_weight / data.trajectories.shape[1], float(p.cost_power),
                             data.costs)


class GoalAngleCriticParams(WeightedCriticParams):
    """``GoalAngleCritic``: mean |yaw - goal yaw| over the trajectory, active within
    ``threshold_to_consider``; ``symmetric_yaw_tolerance`` also accepts goal yaw + pi."""

    cost_weight: float = Field(3.0, ge=0.0)
    threshold_to_consider: float = Field(0.5, ge=0.0)
    symmetric_yaw_tolerance: bool = False


@register_critic("GoalAngleCritic")
class GoalAngleCritic(Critic):
    """Turn the trajectories to the goal heading near the goal."""

    params_model = GoalAngleCriticParams
    params: GoalAngleCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not p.enabled or data.goal_distance >= p.threshold_to_consider:
            return
        goal_yaw = float(data.path[-1, 2]) if len(data.path) else float(data.goal[2])
        goal_angle_critic(data.trajectories, goal_yaw, p.symmetric_yaw_tolerance,
                          p.cost_weight / data.trajectories.shape[1], float(p.cost_power),
                          data.costs)
