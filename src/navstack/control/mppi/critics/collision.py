"""Costmap critics: CostCritic and ObstaclesCritic (Nav2 ``mppi::critics``).

Both walk each trajectory over the costmap and stop at its first collision:

* a pose *collides* when its cost is LETHAL, or INSCRIBED for a point check (the
  footprint check decides for itself), or NO_INFORMATION unless the costmap tracks
  unknown space (Nav2 ``inCollision``); poses off the map cost NO_INFORMATION;
* with ``consider_footprint`` the outline of the footprint is checked (max cost along its
  edges, LETHAL if a vertex leaves the map - ``footprintCostAtPose``) wherever the
  centre cost reaches ``possible_collision_cost``, the inflation cost at the
  circumscribed radius (lower costs cannot hide a collision); without inflation every
  pose is footprint-checked;
* when every trajectory collides the critic sets ``data.fail`` and the optimizer falls
  back (reset and retry, then ``NoValidControl``).

**CostCritic** (every ``trajectory_point_step``-th pose) adds the raw cost, or
``critical_cost`` at or above ``near_collision_cost``, and replaces the sum with
``collision_cost`` on collision; its term is ``(sum * cost_weight / 254 / n) **
cost_power``.  Within ``near_goal_distance`` only critical and collision costs count.

**ObstaclesCritic** (every pose) converts cost back into distance,
``d = (k r_in - ln c + ln 253) / k`` (``- r_in`` for a point check), and adds
``collision_margin_distance - d`` when closer than the margin (``critical_weight``) and
``inflation_radius - d`` as repulsion (``repulsion_weight``, normalised by the batch
minimum and the horizon, dropped within ``near_goal_distance``); a collision scores
``collision_cost``.

Nav2 reads ``inflation_radius`` and ``cost_scaling_factor`` from the costmap's inflation
layer; navstack controllers get a plain costmap, so both critics carry them as
parameters (Nav2 Humble's ObstaclesCritic names) - set them to the local costmap's.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numba
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.control.mppi.critics.base import (
    Critic,
    CriticData,
    CriticParams,
    RobotShape,
    register_critic,
)
from navstack.control.mppi.models import MotionModel
from navstack.core.errors import ConfigError

FloatArray = NDArray[np.float64]
Float32Array = NDArray[np.float32]

LETHAL = 254.0
INSCRIBED = 253.0
UNKNOWN = 255.0
_LOG_253 = math.log(253.0)


def inflation_cost(distance: float, inscribed_radius: float, cost_scaling_factor: float) -> float:
    """Nav2 ``InflationLayer::computeCost`` at ``distance`` [m] from an obstacle."""
    if distance <= 0.0:
        return LETHAL
    if distance <= inscribed_radius:
        return INSCRIBED
    return float(math.floor(252.0 * math.exp(-cost_scaling_factor
                                              * (distance - inscribed_radius))))


@numba.njit(cache=True)
def _line_cost(grid: NDArray[np.uint8], x0: int, y0: int, x1: int, y1: int) -> float:
    """Max cost on the Bresenham line ``(x0, y0) -> (x1, y1)``, stopping at LETHAL
    (``FootprintCollisionChecker::lineCost``)."""
    dx, dy = abs(x1 - x0), abs(y1 - y0)
    sx = 1 if x1 >= x0 else -1
    sy = 1 if y1 >= y0 else -1
    err = dx - dy
    x, y = x0, y0
    best = 0.0
    while True:
        c = float(grid[y, x])
        if c == LETHAL:
            return LETHAL
        best = max(best, c)
        if x == x1 and y == y1:
            return best
        e2 = 2 * err
        if e2 > -dy:
            err -= dy
            x += sx
        if e2 < dx:
            err += dx
            y += sy


@numba.njit(cache=True)
def footprint_cost(grid: NDArray[np.uint8], x: float, y: float, yaw: float,
                   footprint: FloatArray, ox: float, oy: float, res: float) -> float:
    """Max cost along the footprint outline at ``(x, y, yaw)``; LETHAL if a vertex lies
    off the map (``FootprintCollisionChecker::footprintCostAtPose``)."""
    n = footprint.shape[0]
    c, s = math.cos(yaw), math.sin(yaw)
    mxs = np.empty(n, dtype=np.int64)
    mys = np.empty(n, dtype=np.int64)
    for k in range(n):
        wx = x + c * footprint[k, 0] - s * footprint[k, 1]
        wy = y + s * footprint[k, 0] + c * footprint[k, 1]
        if wx < ox or wy < oy:
            return LETHAL
        mx, my = int((wx - ox) / res), int((wy - oy) / res)
        if mx >= grid.shape[1] or my >= grid.shape[0]:
            return LETHAL
        mxs[k], mys[k] = mx, my
    best = 0.0
    for k in range(n):
        j = (k + 1) % n
        best = max(best, _line_cost(grid, mxs[k], mys[k], mxs[j], mys[j]))
        if best == LETHAL:
            return LETHAL
    return best


@numba.njit(cache=True, inline="always")
def _in_collision(cost: int, consider_footprint: bool, track_unknown: bool) -> bool:
    """Nav2 ``inCollision``: LETHAL; INSCRIBED for a point check; unknown unless tracked."""
    return (cost == 254 or (cost == 253 and not consider_footprint)
            or (cost == 255 and not track_unknown))


@numba.njit(cache=True, inline="always")
def _cell(flat: NDArray[np.uint8], width: int, height: int, x: float, y: float, ox: float,
          oy: float, inv_res: float) -> int:
    """Cost under a world point, NO_INFORMATION (255) off the map (``worldToMapFloat``)."""
    fx, fy = (x - ox) * inv_res, (y - oy) * inv_res
    if fx < 0.0 or fy < 0.0:
        return 255
    mx, my = int(fx), int(fy)
    if mx >= width or my >= height:
        return 255
    return int(flat[my * width + mx])


@numba.njit(cache=True)
def cost_critic(traj: Float32Array, grid: NDArray[np.uint8], ox: float, oy: float,
                res: float, track_unknown: bool, footprint: FloatArray, use_footprint: bool,
                possible: float, step: int, near_collision: int, critical: float,
                collision: float, near_goal: bool, scale: float, power: float,
                costs: FloatArray) -> bool:
    """CostCritic over ``traj`` (3, T, B); returns True if every trajectory collides.
    ``scale`` is ``cost_weight / 254 / n`` with ``n = T // step`` poses evaluated."""
    batch = traj.shape[2]
    n_eval = traj.shape[1] // step
    height, width = grid.shape
    flat = grid.ravel()
    inv_res = 1.0 / res
    check_all = use_footprint and possible < 1.0
    acc = np.zeros(batch)
    hit = np.zeros(batch, dtype=np.bool_)
    for j in range(n_eval):
        t = j * step
        for i in range(batch):
            if hit[i]:
                continue
            x, y = traj[0, t, i], traj[1, t, i]
            pc = _cell(flat, width, height, x, y, ox, oy, inv_res)
            if pc == 0:
                continue
            score = pc
            if use_footprint and (check_all or pc >= possible):
                score = int(footprint_cost(grid, x, y, traj[2, t, i], footprint, ox, oy, res))
            if _in_collision(score, use_footprint, track_unknown):
                acc[i] = collision
                hit[i] = True
            elif pc >= near_collision:
                acc[i] += critical
            elif not near_goal:
                acc[i] += pc
    all_hit = True
    for i in range(batch):
        all_hit &= hit[i]
        v = acc[i] * scale
        costs[i] += v if power == 1.0 else v ** power
    return all_hit


@numba.njit(cache=True)
def obstacles_critic(traj: Float32Array, grid: NDArray[np.uint8], ox: float, oy: float,
                     res: float, track_unknown: bool, footprint: FloatArray,
                     use_footprint: bool, possible: float, margin_lut: Float32Array,
                     repulsion_lut: Float32Array, collision: float, near_goal: bool,
                     critical_weight: float, repulsion_weight: float, power: float,
                     costs: FloatArray) -> bool:
    """ObstaclesCritic over ``traj`` (3, T, B); returns True if every trajectory
    collides.  ``margin_lut`` / ``repulsion_lut`` (2, 256) hold the margin and repulsion
    terms per cost value for a point check (row 0) and a footprint check (row 1)."""
    n_steps, batch = traj.shape[1], traj.shape[2]
    height, width = grid.shape
    flat = grid.ravel()
    inv_res = 1.0 / res
    check_all = use_footprint and possible < 1.0
    raw = np.zeros(batch, dtype=np.float32)
    rep = np.zeros(batch, dtype=np.float32)
    hit = np.zeros(batch, dtype=np.bool_)
    for t in range(n_steps):
        for i in range(batch):
            if hit[i]:
                continue
            x, y = traj[0, t, i], traj[1, t, i]
            pc = _cell(flat, width, height, x, y, ox, oy, inv_res)
            row = 0
            if use_footprint and (check_all or pc >= possible):
                pc = int(footprint_cost(grid, x, y, traj[2, t, i], footprint, ox, oy, res))
                row = 1
            if pc == 0:
                continue
            if _in_collision(pc, use_footprint, track_unknown):
                hit[i] = True
                continue
            raw[i] += margin_lut[row, pc]
            if not near_goal:
                rep[i] += repulsion_lut[row, pc]
    rep_min = np.inf
    all_hit = True
    for i in range(batch):
        rep_min = min(rep_min, rep[i])
        all_hit &= hit[i]
    for i in range(batch):
        r = collision if hit[i] else raw[i]
        v = critical_weight * r + repulsion_weight * (rep[i] - rep_min) / n_steps
        costs[i] += v if power == 1.0 else v ** power
    return all_hit


def obstacle_distance_luts(inflation_radius: float, scaling: float, inscribed: float,
                           margin: float) -> tuple[Float32Array, Float32Array]:
    """Per-cost ``max(margin - d, 0)`` and ``inflation_radius - d`` tables, ``(2, 256)``.

    ``d(c) = (k r_in - ln c + ln 253) / k`` for a footprint cost (row 1) and
    ``d(c) - r_in`` for a point cost (row 0) (Nav2 ``distanceToObstacle``); all zero
    without inflation (Nav2 then skips the distance terms).
    """
    margin_lut = np.zeros((2, 256), dtype=np.float32)
    repulsion_lut = np.zeros((2, 256), dtype=np.float32)
    if inflation_radius <= 0.0 or scaling <= 0.0:
        return margin_lut, repulsion_lut
    c = np.arange(1, 256, dtype=np.float64)
    d_fp = (scaling * inscribed - np.log(c) + _LOG_253) / scaling
    for row, d in ((0, d_fp - inscribed), (1, d_fp)):
        margin_lut[row, 1:] = np.maximum(margin - d, 0.0)
        repulsion_lut[row, 1:] = inflation_radius - d
    return margin_lut, repulsion_lut


class _CollisionCriticParams(CriticParams):
    """Keys shared by the two costmap critics."""

    consider_footprint: bool = False
    near_goal_distance: float = Field(0.5, ge=0.0)
    inflation_layer_name: str = ""
    inflation_radius: float = Field(0.55, ge=0.0)
    cost_scaling_factor: float = Field(10.0, ge=0.0)


class _CollisionCritic(Critic):
    params: CostCriticParams | ObstaclesCriticParams
    #: CostCritic skips the potential-field shortcut when inflation < circumscribed radius
    cap_to_radius: ClassVar[bool]

    def __init__(self, params: CriticParams, controller: Any, model: MotionModel,
                 shape: RobotShape) -> None:
        super().__init__(params, controller, model, shape)
        if self.params.enabled and self.params.consider_footprint \
                and shape.circumscribed_radius == 0.0:
            raise ConfigError(
                "consider_footprint is true but the controller was given no footprint",
                key_path=f"{self.name}.consider_footprint",
                suggestion="pass footprint=Footprint(...) to the controller or set it false")
        self.possible = self.possible_collision_cost()

    def possible_collision_cost(self) -> float:
        """Nav2 ``findCircumscribedCost``: the inflation cost at the circumscribed
        radius; -1 without inflation and 0 (always check) for CostCritic when the
        inflation radius is smaller than the circumscribed radius."""
        p, shape = self.params, self.shape
        if p.inflation_radius <= 0.0 or p.cost_scaling_factor <= 0.0:
            return -1.0
        if self.cap_to_radius and p.inflation_radius < shape.circumscribed_radius:
            return 0.0
        return inflation_cost(shape.circumscribed_radius, shape.inscribed_radius,
                              p.cost_scaling_factor)


class CostCriticParams(_CollisionCriticParams):
    """``CostCritic``: sums costmap cost along every ``trajectory_point_step``-th pose.

    Poses at or above ``near_collision_cost`` add ``critical_cost``; a collision (LETHAL,
    INSCRIBED for a point robot, unknown unless the costmap tracks unknown space) replaces
    the sum with ``collision_cost``.  The term is ``(sum * cost_weight / 254 / n) **
    cost_power`` with ``n`` the number of evaluated poses.  Within ``near_goal_distance``
    of the goal only critical and collision costs count.
    """

    cost_power: int = Field(1, ge=1)
    cost_weight: float = Field(3.81, ge=0.0)
    critical_cost: float = Field(300.0, ge=0.0)
    near_collision_cost: int = Field(253, ge=1, le=255)
    collision_cost: float = Field(1000000.0, ge=0.0)
    trajectory_point_step: int = Field(2, ge=1)


@register_critic("CostCritic")
class CostCritic(_CollisionCritic):
    """Stay in low-cost space; never collide."""

    params_model = CostCriticParams
    cap_to_radius: ClassVar[bool] = True
    params: CostCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not p.enabled:
            return
        cm = data.costmap
        n_eval = data.trajectories.shape[1] // p.trajectory_point_step
        if n_eval == 0:
            return
        if cost_critic(data.trajectories, cm.data, cm.origin_x, cm.origin_y, cm.resolution,
                       data.track_unknown, self.shape.polygon, p.consider_footprint,
                       self.possible, p.trajectory_point_step, p.near_collision_cost,
                       p.critical_cost, p.collision_cost,
                       data.goal_distance < p.near_goal_distance,
                       p.cost_weight / 254.0 / n_eval, float(p.cost_power), data.costs):
            data.fail, data.failed_by = True, self.name


class ObstaclesCriticParams(_CollisionCriticParams):
    """``ObstaclesCritic``: distance-to-obstacle terms recovered from inflated cost.

    ``distance = (k * r_inscribed - ln(cost) + ln(253)) / k`` (minus ``r_inscribed`` for
    a point check), ``k = cost_scaling_factor``.  Poses closer than
    ``collision_margin_distance`` add ``margin - distance`` (scaled by
    ``critical_weight``); every inflated pose adds ``inflation_radius - distance``
    (scaled by ``repulsion_weight``, normalised by the batch minimum and the horizon).
    A colliding trajectory scores ``critical_weight * collision_cost``.
    """

    cost_power: int = Field(1, ge=1)
    repulsion_weight: float = Field(1.5, ge=0.0)
    critical_weight: float = Field(20.0, ge=0.0)
    collision_cost: float = Field(100000.0, ge=0.0)
    collision_margin_distance: float = Field(0.10, ge=0.0)


@register_critic("ObstaclesCritic")
class ObstaclesCritic(_CollisionCritic):
    """Keep a margin from obstacles, prefer open space; never collide."""

    params_model = ObstaclesCriticParams
    cap_to_radius: ClassVar[bool] = False
    params: ObstaclesCriticParams

    def __init__(self, params: CriticParams, controller: Any, model: MotionModel,
                 shape: RobotShape) -> None:
        super().__init__(params, controller, model, shape)
        p = self.params
        self.margin_lut, self.repulsion_lut = obstacle_distance_luts(
            p.inflation_radius, p.cost_scaling_factor, shape.inscribed_radius,
            p.collision_margin_distance)

    def score(self, data: CriticData) -> None:
        p = self.params
        if not p.enabled:
            return
        cm = data.costmap
        if obstacles_critic(data.trajectories, cm.data, cm.origin_x, cm.origin_y,
                            cm.resolution, data.track_unknown, self.shape.polygon,
                            p.consider_footprint, self.possible, self.margin_lut,
                            self.repulsion_lut, p.collision_cost,
                            data.goal_distance < p.near_goal_distance, p.critical_weight,
                            p.repulsion_weight, float(p.cost_power), data.costs):
            data.fail, data.failed_by = True, self.name
