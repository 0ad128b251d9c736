"""Obstacle critics: ``dwb_critics::BaseObstacleCritic`` and ``ObstacleFootprintCritic``.

Both reject a trajectory at its first pose that is off the costmap or in an illegal
cell, and otherwise score it by the cost of its *last* pose (``sum_scores: false``,
Nav2's default: the branchless ``score = sum_scores * score + pose_score``) or the sum
over all its poses (``sum_scores: true``).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.control.dwb.critic_base import (
    CriticContext,
    CriticParams,
    FloatArray,
    TrajectoryCritic,
    batch_cells,
    first_failure,
    register_critic,
    reject_scores,
)
from navstack.control.dwb.critics_map_grid import blocking_cost
from navstack.control.dwb.grid import footprint_costs
from navstack.control.dwb.params import DWBParams
from navstack.control.dwb.trajectory_generator import TrajectoryBatch
from navstack.core.errors import ConfigError
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION

IntArray = NDArray[np.int64]


class ObstacleParams(CriticParams):
    """``<critic>.sum_scores``: sum the costs along the trajectory instead of the last one."""

    sum_scores: bool = False
    max_cost: int = Field(252, ge=1, le=252)
    """navstack (``BaseObstacle``): cells costlier than this reject a trajectory like
    inscribed ones, so the robot keeps a clearance beyond its padded footprint (252,
    the default, is Nav2's rule: only inscribed and lethal cells reject).  With an
    inflation ``cost = 252 exp(-k (d - r_inscribed))`` a clearance ``c`` beyond the
    inscribed radius is ``max_cost = 252 exp(-k c)``."""


def _aggregate(costs: FloatArray, batch: TrajectoryBatch, sum_scores: bool) -> FloatArray:
    """Last real pose's cost, or the sum over the real poses, per sample."""
    if sum_scores:
        return np.where(batch.valid_mask(), costs, 0.0).sum(axis=1)
    return costs[np.arange(len(batch)), batch.lengths - 1]


@numba.njit(cache=True)
def _base_last_scores(data: NDArray[np.uint8], mx: IntArray, my: IntArray,
                      inside: NDArray[np.bool_], limit: int, last: IntArray,
                      out: FloatArray) -> None:
    """BaseObstacle with ``sum_scores: false`` in one pass: ``-code`` of the first bad
    pose (off grid 1, unknown 3, cost >= ``limit`` 2), else the cost at pose ``last[i]``."""
    n, t = mx.shape
    for i in range(n):
        code = 0
        for k in range(t):
            if not inside[i, k]:
                code = 1
            else:
                c = data[my[i, k], mx[i, k]]
                if c == NO_INFORMATION:
                    code = 3
                elif c >= limit:
                    code = 2
            if code:
                break
        out[i] = -float(code) if code else float(data[my[i, last[i]], mx[i, last[i]]])


@register_critic("BaseObstacle")
class BaseObstacleCritic(TrajectoryCritic[ObstacleParams]):
    """Cost of the cells under the robot centre; lethal, inscribed or unknown rejects.

    Nav2 default scale in ``nav2_params.yaml``: 0.02.  One navstack departure: when the
    robot *starts* the cycle in an inscribed (not lethal) cell — a person stepped up to
    it, or the costmap shifted by a cell — inscribed cells do not reject, so the robot
    can drive out; Nav2 rejects every sample there and the robot stays stuck until a
    recovery moves it.  Lethal cells always reject.
    """

    params_model = ObstacleParams
    reasons = ("off grid", "collision", "unknown space")
    default_scale = 0.02

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        cm = ctx.costmap
        mx, my, inside = batch_cells(batch, cm)
        limit = blocking_cost(cm, ctx.pose)  # escaping the inscribed band is allowed
        if limit == INSCRIBED_INFLATED_OBSTACLE and self.params.max_cost < 252:
            limit = self.params.max_cost + 1  # the clearance band, escapable as well
            here = cm.world_to_map(ctx.pose.x, ctx.pose.y)
            if here is not None and cm.data[here[1], here[0]] >= limit:
                limit = INSCRIBED_INFLATED_OBSTACLE
        if not self.params.sum_scores:
            scores = np.empty(len(batch))
            _base_last_scores(cm.data, mx, my, inside, limit,
                              np.ascontiguousarray(batch.lengths - 1, dtype=np.int64), scores)
            return scores
        cost = cm.data[my, mx]
        codes = np.where(~inside, 1,
                         np.where(cost == NO_INFORMATION, 3, np.where(cost >= limit, 2, 0)))
        scores = _aggregate(cost.astype(np.float64), batch, self.params.sum_scores)
        return reject_scores(scores, first_failure(codes))


@register_critic("ObstacleFootprint")
class ObstacleFootprintCritic(TrajectoryCritic[ObstacleParams]):
    """Max cost on the rasterised footprint outline at each pose; lethal/unknown rejects.

    Inscribed cost does not reject here (the outline is what must stay clear), which is
    what lets a polygonal robot use narrower gaps than ``BaseObstacle`` allows.
    """

    params_model = ObstacleParams
    reasons = ("off grid", "footprint off grid", "collision", "unknown space")
    default_scale = 0.02

    def __init__(self, name: str, params: ObstacleParams, dwb: DWBParams,
                 footprint: Footprint | None = None) -> None:
        if footprint is None:
            raise ConfigError(
                "the ObstacleFootprint critic needs the robot footprint",
                key_path=f"{name}",
                suggestion="pass footprint=Footprint.from_polygon(...) or "
                           "Footprint.from_radius(r) to the DWB controller")
        super().__init__(name, params, dwb, footprint)
        self._polygon = np.ascontiguousarray(footprint.polygon, dtype=np.float64)

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        cm = ctx.costmap
        real = batch.valid_mask()
        costs_real, codes_real = footprint_costs(
            np.ascontiguousarray(batch.poses[real]), self._polygon, cm.data,
            cm.origin_x, cm.origin_y, cm.resolution)
        costs = np.zeros(real.shape)
        codes = np.zeros(real.shape, dtype=np.int64)
        costs[real] = costs_real
        codes[real] = codes_real
        scores = _aggregate(costs, batch, self.params.sum_scores)
        return reject_scores(scores, first_failure(codes))
