"""Path critics: PathAlign, PathFollow and PathAngle (Nav2 ``mppi::critics``).

All three compare the trajectories with the pruned plan and share the *furthest reached
path point*, computed once per iteration (Nav2 Kilted's arc-length bounded
``findPathFurthestReachedPoint``, which fixes path skipping on curved paths): a
trajectory reaches the path point nearest to its end among those within its travelled
length along the path; the batch maximum is the furthest point.  All three switch off
within ``threshold_to_consider`` of the goal, where the goal critics take over.

* **PathAlignCritic**: every ``trajectory_point_step``-th pose is compared with the path
  point at the same travelled distance (``findClosestPathPt``); the score is the mean
  distance (plus yaw error with ``use_path_orientations``) over poses whose path point is
  collision-free.  Skipped until ``offset_from_furthest`` points are reached, and when
  more than ``max_path_occupancy_ratio`` of the reached path is blocked, so the obstacle
  critics can take the robot around an obstructed plan;
* **PathFollowCritic**: distance of the trajectory end to the first collision-free path
  point from ``furthest + offset_from_furthest`` on;
* **PathAngleCritic**: heading error of the trajectory end towards the path point at
  ``furthest + offset_from_furthest`` - mode 0 forward, 1 either direction, 2 the path's
  own direction of travel - applied only while the robot itself points more than
  ``max_angle_to_furthest`` away from it.

Each term is ``(raw * cost_weight) ** cost_power``.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from navstack.control.mppi.critics.base import (
    Critic,
    CriticData,
    WeightedCriticParams,
    register_critic,
)

FloatArray = NDArray[np.float64]
Float32Array = NDArray[np.float32]
_TWO_PI = 2.0 * math.pi


@numba.njit(cache=True, inline="always")
def _wrap(a: float) -> float:
    """Angle in [-pi, pi)."""
    return a - _TWO_PI * math.floor((a + math.pi) / _TWO_PI)


@numba.njit(cache=True)
def _cumulative_length(path: FloatArray, count: int) -> FloatArray:
    cum = np.zeros(count)
    for k in range(1, count):
        dx, dy = path[k, 0] - path[k - 1, 0], path[k, 1] - path[k - 1, 1]
        cum[k] = cum[k - 1] + math.sqrt(dx * dx + dy * dy)
    return cum


@numba.njit(cache=True)
def furthest_reached_point(path: FloatArray, traj: Float32Array, arc: FloatArray) -> int:
    """Index of the furthest path point reached by any trajectory; ``path`` (M, 3),
    ``traj`` (3, T, B), ``arc`` (B,) travelled lengths."""
    m = path.shape[0]
    cum = _cumulative_length(path, m)
    last = traj.shape[1] - 1
    best = 0
    for i in range(traj.shape[2]):
        reach = min(np.searchsorted(cum, arc[i]), m - 1)  # std::lower_bound
        ex, ey = traj[0, last, i], traj[1, last, i]
        dmin, kmin = np.inf, 0
        for k in range(reach + 1):
            d = (path[k, 0] - ex) ** 2 + (path[k, 1] - ey) ** 2
            if d < dmin:
                dmin, kmin = d, k
        best = max(best, kmin)
        if best == m - 1:
            break
    return best


@numba.njit(cache=True)
def path_align_critic(path: FloatArray, valid: NDArray[np.bool_], traj: Float32Array,
                      furthest: int, offset: int, max_ratio: float, step: int,
                      use_yaw: bool, weight: float, power: float, costs: FloatArray) -> bool:
    """PathAlignCritic; returns False when it skipped (too early or path blocked)."""
    count = furthest
    if count < offset or count == 0:
        return False
    invalid = 0.0
    for k in range(count):
        if not valid[k]:
            invalid += 1.0
        if invalid / count > max_ratio and invalid > 2.0:
            return False
    cum = _cumulative_length(path, count)
    batch = traj.shape[2]
    travelled = np.zeros(batch)
    summed = np.zeros(batch)
    samples = np.zeros(batch, dtype=np.int64)
    pts = np.zeros(batch, dtype=np.int64)
    for t in range(step, traj.shape[1], step):
        for i in range(batch):
            tx, ty = traj[0, t, i], traj[1, t, i]
            dx, dy = tx - traj[0, t - step, i], ty - traj[1, t - step, i]
            dist = travelled[i] + math.sqrt(dx * dx + dy * dy)
            travelled[i] = dist
            # findClosestPathPt: nearest integrated distance, searching forward
            k = pts[i]
            prev = cum[k] if k != 0 else 0.0
            pt = count - 1
            for kk in range(k + 1, count):
                cur = cum[kk]
                if cur > dist:
                    pt = kk - 1 if dist - prev < cur - dist else kk
                    break
                prev = cur
            pts[i] = pt
            if valid[pt]:
                ex, ey = path[pt, 0] - tx, path[pt, 1] - ty
                samples[i] += 1
                if use_yaw:
                    dyaw = _wrap(traj[2, t, i] - path[pt, 2])
                    summed[i] += math.sqrt(ex * ex + ey * ey + dyaw * dyaw)
                else:
                    summed[i] += math.sqrt(ex * ex + ey * ey)
    for i in range(batch):
        if samples[i] > 0:
            v = summed[i] / samples[i] * weight
            costs[i] += v if power == 1.0 else v ** power
    return True


@numba.njit(cache=True, fastmath=True)
def path_follow_critic(traj: Float32Array, gx: float, gy: float, weight: float,
                       power: float, costs: FloatArray) -> None:
    """PathFollowCritic: ``(weight * |end - target|) ** power``."""
    last = traj.shape[1] - 1
    for i in range(traj.shape[2]):
        dx, dy = traj[0, last, i] - gx, traj[1, last, i] - gy
        v = weight * math.sqrt(dx * dx + dy * dy)
        costs[i] += v if power == 1.0 else v ** power


@numba.njit(cache=True)
def pose_point_angle(x: float, y: float, yaw: float, px: float, py: float, mode: int,
                     point_yaw: float) -> float:
    """Nav2 ``utils::posePointAngle``: the robot's heading error towards a point (mode 1
    accepts reversing, mode 2 follows the point's own direction)."""
    to_point = math.atan2(py - y, px - x)
    if mode == 2:
        if abs(_wrap(point_yaw - to_point)) > math.pi / 2.0:
            to_point = _wrap(to_point + math.pi)
        return abs(_wrap(yaw - to_point))
    forward = abs(_wrap(yaw - to_point))
    if mode == 1:
        return min(forward, abs(_wrap(yaw + math.pi - to_point)))
    return forward


@numba.njit(cache=True)
def path_angle_critic(traj: Float32Array, gx: float, gy: float, gyaw: float, mode: int,
                      weight: float, power: float, costs: FloatArray) -> None:
    """PathAngleCritic over the trajectory ends."""
    last = traj.shape[1] - 1
    half_pi = math.pi / 2.0
    for i in range(traj.shape[2]):
        eyaw = traj[2, last, i]
        to_point = math.atan2(gy - traj[1, last, i], gx - traj[0, last, i])
        if mode == 1:
            if abs(_wrap(to_point - eyaw)) >= half_pi:
                to_point += math.pi
        elif mode == 2 and abs(_wrap(gyaw - to_point)) >= half_pi:
            to_point += math.pi
        v = weight * abs(_wrap(to_point - eyaw))
        costs[i] += v if power == 1.0 else v ** power


def _furthest(data: CriticData) -> int:
    """The furthest reached path point, computed once per iteration."""
    if data.furthest_reached_path_point is None:
        data.furthest_reached_path_point = int(
            furthest_reached_point(data.path, data.trajectories, data.arc))
    return data.furthest_reached_path_point


class PathAlignCriticParams(WeightedCriticParams):
    """``PathAlignCritic``: mean distance of every ``trajectory_point_step``-th pose to
    the path point at the same arc length; skipped near the goal, before trajectories
    reach ``offset_from_furthest`` path points, or when more than
    ``max_path_occupancy_ratio`` of the path is blocked."""

    cost_weight: float = Field(10.0, ge=0.0)
    max_path_occupancy_ratio: float = Field(0.07, ge=0.0, le=1.0)
    offset_from_furthest: int = Field(20, ge=0)
    trajectory_point_step: int = Field(4, ge=1)
    threshold_to_consider: float = Field(0.5, ge=0.0)
    use_path_orientations: bool = False


@register_critic("PathAlignCritic")
class PathAlignCritic(Critic):
    """Keep the trajectories on the path (exact tracking when it is free)."""

    params_model = PathAlignCriticParams
    params: PathAlignCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not p.enabled or data.goal_distance < p.threshold_to_consider or len(data.path) < 2:
            return
        path_align_critic(data.path, data.path_valid, data.trajectories, _furthest(data),
                          p.offset_from_furthest, p.max_path_occupancy_ratio,
                          p.trajectory_point_step, p.use_path_orientations, p.cost_weight,
                          float(p.cost_power), data.costs)


class PathFollowCriticParams(WeightedCriticParams):
    """``PathFollowCritic``: distance of the trajectory end to the first valid path
    point ``offset_from_furthest`` points beyond the furthest one reached."""

    cost_weight: float = Field(5.0, ge=0.0)
    offset_from_furthest: int = Field(6, ge=0)
    threshold_to_consider: float = Field(1.4, ge=0.0)


@register_critic("PathFollowCritic")
class PathFollowCritic(Critic):
    """Make progress along the path."""

    params_model = PathFollowCriticParams
    params: PathFollowCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not p.enabled or data.goal_distance < p.threshold_to_consider or len(data.path) < 2:
            return
        last = len(data.path) - 1
        idx = min(_furthest(data) + p.offset_from_furthest, last)
        while idx < last - 1 and not data.path_valid[idx]:
            idx += 1
        path_follow_critic(data.trajectories, float(data.path[idx, 0]),
                           float(data.path[idx, 1]), p.cost_weight, float(p.cost_power),
                           data.costs)


class PathAngleCriticParams(WeightedCriticParams):
    """``PathAngleCritic``: heading error of the trajectory end towards the path point
    ``offset_from_furthest`` beyond the furthest reached, active when the robot's own
    heading is off by more than ``max_angle_to_furthest``.

    ``mode``: 0 forward preference, 1 no directional preference, 2 consider the path's
    orientations (feasible planners).  ``forward_preference`` (Nav2 Humble) maps to
    mode 0 (true) or 1 (false) when given.
    """

    cost_weight: float = Field(2.2, ge=0.0)
    offset_from_furthest: int = Field(4, ge=0)
    threshold_to_consider: float = Field(0.5, ge=0.0)
    max_angle_to_furthest: float = Field(0.785398, ge=0.0)
    mode: int = Field(0, ge=0, le=2)
    forward_preference: bool | None = None

    @model_validator(mode="before")
    @classmethod
    def _humble_forward_preference(cls, data: Any) -> Any:
        if isinstance(data, dict) and isinstance(data.get("forward_preference"), bool):
            data = {**data, "mode": 0 if data["forward_preference"] else 1}
        return data


@register_critic("PathAngleCritic")
class PathAngleCritic(Critic):
    """Turn towards the path when the robot points away from it."""

    params_model = PathAngleCriticParams
    params: PathAngleCriticParams

    @property
    def mode(self) -> int:
        """Nav2: without reversing (``vx_min`` 0) mode 1 falls back to forward (0)."""
        vx_min = self.controller_params.vx_min
        reversing = vx_min < 0.0 and abs(vx_min) >= 1e-6
        return 0 if self.params.mode == 1 and not reversing else self.params.mode

    def score(self, data: CriticData) -> None:
        p = self.params
        if not p.enabled or data.goal_distance < p.threshold_to_consider or len(data.path) == 0:
            return
        idx = min(_furthest(data) + p.offset_from_furthest, len(data.path) - 1)
        gx, gy, gyaw = (float(v) for v in data.path[idx])
        mode = self.mode
        if pose_point_angle(float(data.state[0]), float(data.state[1]), float(data.state[2]),
                            gx, gy, mode, gyaw) < p.max_angle_to_furthest:
            return
        path_angle_critic(data.trajectories, gx, gy, gyaw, mode, p.cost_weight,
                          float(p.cost_power), data.costs)
