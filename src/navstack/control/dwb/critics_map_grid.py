"""Distance-map critics: ``dwb_critics::MapGridCritic`` and its four Nav2 subclasses.

Each cycle a wavefront (:func:`navstack.control.dwb.grid.wavefront`) spreads over the
costmap from seed cells — the pruned plan for ``PathDist``/``PathAlign``, its last pose
on the costmap for ``GoalDist``/``GoalAlign`` — giving every cell the Manhattan cell
distance to its seed.  A trajectory scores the value at its last pose
(``aggregation_type: last``, Nav2's default), or the sum/product over its poses.
``PathDist``/``GoalDist`` (``stop_on_failure``) reject a trajectory that touches an
obstacle cell or a cell the wave never reached; the ``*Align`` critics score the point
``forward_point_distance`` ahead of the last pose instead and only reject it off the
map.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, TypeVar

import numba
import numpy as np
from numpy.typing import NDArray
from pydantic import field_validator

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
from navstack.control.dwb.grid import (
    Wavefront,
    adjust_plan_resolution,
    plan_run_end,
    world_to_cells,
)
from navstack.control.dwb.params import DWBParams
from navstack.control.dwb.trajectory_generator import TrajectoryBatch
from navstack.core.msgs import Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)

IntArray = NDArray[np.int64]


class MapGridParams(CriticParams):
    """``<critic>.aggregation_type``: ``last`` (default), ``sum`` or ``product``."""

    aggregation_type: str = "last"

    @field_validator("aggregation_type")
    @classmethod
    def _known(cls, v: str) -> str:
        v = v.lower()
        if v not in ("last", "sum", "product"):
            raise ValueError(f"aggregation_type must be last, sum or product, got '{v}'")
        return v


class AlignParams(MapGridParams):
    """``forward_point_distance`` [m]: how far ahead of the robot centre the nose is scored."""

    forward_point_distance: float = 0.325


G = TypeVar("G", bound=MapGridParams)


def plan_run_cells(plan: FloatArray, costmap: Costmap2D,
                   cache: dict[Any, Any] | None = None) -> tuple[IntArray, IntArray]:
    """Cells of the first contiguous run of the (densified) plan on known costmap cells.

    Follows ``PathDistCritic::prepare``: poses before the run (off the map or unknown)
    are skipped, and the run ends at the first pose leaving it again.  With ``cache``
    (the cycle's :attr:`CriticContext.cache`) critics sharing a plan compute it once.
    """
    key = ("plan_run", id(plan))
    if cache is not None and key in cache:
        run: tuple[IntArray, IntArray] = cache[key]
        return run
    run = _plan_run_cells(plan, costmap)
    if cache is not None:
        cache[key] = run
    return run


def _plan_run_cells(plan: FloatArray, costmap: Costmap2D) -> tuple[IntArray, IntArray]:
    dense = adjust_plan_resolution(plan, costmap.resolution)
    mx, my, inside = world_to_cells(costmap, dense[:, 0], dense[:, 1])
    ok = inside & (costmap.data[my, mx] != NO_INFORMATION)
    if not ok.any():
        return mx[:0], my[:0]
    start = int(np.argmax(ok))
    rest = ~ok[start:]
    end = start + (int(np.argmax(rest)) if rest.any() else len(rest))
    return mx[start:end], my[start:end]


def blocking_cost(costmap: Costmap2D, pose: Pose2D) -> int:
    """Lowest cost that blocks a trajectory cell: INSCRIBED, or LETHAL while the robot
    starts the cycle inside the inscribed band (so it may drive out; see BaseObstacle)."""
    here = costmap.world_to_map(pose.x, pose.y)
    if here is not None and costmap.data[here[1], here[0]] == INSCRIBED_INFLATED_OBSTACLE:
        return LETHAL_OBSTACLE
    return INSCRIBED_INFLATED_OBSTACLE


class MapGridCritic(TrajectoryCritic[G]):
    """Scores trajectories with a per-cycle distance map (``MapGridCritic``).

    The wave is stopped once every cell this cycle's trajectories can score has its
    value (see :meth:`Wavefront.compute`), which keeps a cycle well under a
    millisecond on a 200x200 costmap.  Trajectory cells that are themselves lethal,
    inscribed or unknown are labelled "collision" directly from their cost.
    """

    reasons = ("off grid", "collision", "unreachable area")
    stop_on_failure: ClassVar[bool] = True
    forward_point: ClassVar[bool] = False

    def __init__(self, name: str, params: G, dwb: DWBParams,
                 footprint: Footprint | None = None) -> None:
        super().__init__(name, params, dwb, footprint)
        self._wave = Wavefront()
        self.values: FloatArray | None = None
        self.obstacle_score = 0.0
        self.unreachable_score = 1.0

    def _last_only(self) -> bool:
        return self.params.aggregation_type == "last" and not self.stop_on_failure

    def _points(self, batch: TrajectoryBatch, last_only: bool) -> tuple[FloatArray, FloatArray]:
        """World points scored for each sample: ``(N, T)`` or ``(N, 1)``."""
        poses = batch.poses[:, -1:, :] if last_only else batch.poses
        return poses[..., 0], poses[..., 1]

    def _cells(self, batch: TrajectoryBatch,
               costmap: Costmap2D) -> tuple[IntArray, IntArray, NDArray[np.bool_]]:
        last_only = self._last_only()
        if self.forward_point or last_only:
            # cached per batch (and carried into sub-batches): PathAlign and GoalAlign
            # score the same nose points, in prepare and in score
            key = f"cells:{type(self)._points.__qualname__}:{last_only}:{self._point_key()}"
            cached = batch.cache.get(key)
            if cached is None:
                xs, ys = self._points(batch, last_only)
                cached = world_to_cells(costmap, xs, ys)
                batch.cache[key] = cached
            mx, my, inside = cached
            return mx, my, inside
        return batch_cells(batch, costmap)

    def _point_key(self) -> float:
        """What besides the batch decides :meth:`_points` (the nose distance)."""
        return 0.0

    def _set_values(self, ctx: CriticContext, seed_x: IntArray, seed_y: IntArray) -> None:
        """Run the wave from the seeds, up to the cells the cycle's trajectories touch."""
        data = ctx.costmap.data
        self.obstacle_score = float(data.size)
        self.unreachable_score = float(data.size + 1)
        need: NDArray[np.bool_] | None = None
        if ctx.batch is not None:
            mx, my, inside = self._cells(ctx.batch, ctx.costmap)
            need = np.zeros(data.shape, dtype=np.bool_)
            # the cells the scoring reads: below the blocking cost, which is LETHAL while
            # the robot starts inside the inscribed band (marking only cells below
            # INSCRIBED there stopped the wave before the robot's own cell, and every
            # sample was "unreachable": the robot could never drive out)
            _mark_needed(data, mx.reshape(-1), my.reshape(-1), inside.reshape(-1),
                         blocking_cost(ctx.costmap, ctx.pose), need)
        self.values = self._wave.compute(data, seed_x, seed_y, True, need)

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        if self.values is None:
            self._set_values(ctx, np.zeros(0, np.int64), np.zeros(0, np.int64))
        assert self.values is not None
        mx, my, inside = self._cells(batch, ctx.costmap)
        if self.params.aggregation_type == "last":
            scores = np.empty(len(batch))
            last = (np.zeros(len(batch), np.int64) if self._last_only()
                    else batch.lengths - 1)
            _last_scores(self.values, ctx.costmap.data, mx, my, inside,
                         blocking_cost(ctx.costmap, ctx.pose), self.obstacle_score,
                         self.unreachable_score, self.stop_on_failure,
                         np.ascontiguousarray(last, dtype=np.int64), scores)
            return scores
        blocked = ctx.costmap.data[my, mx] >= blocking_cost(ctx.costmap, ctx.pose)
        vals = np.where(blocked, self.obstacle_score, self.values[my, mx])
        codes = np.where(inside, 0, 1)
        if self.stop_on_failure:
            codes = np.where(codes > 0, codes,
                             np.where(vals == self.obstacle_score, 2,
                                      np.where(vals == self.unreachable_score, 3, 0)))
        agg = self.params.aggregation_type
        if self._last_only():
            scores = vals[:, 0]
        elif agg == "last":
            scores = vals[np.arange(len(batch)), batch.lengths - 1]
        elif agg == "sum":
            scores = np.where(batch.valid_mask(), vals, 0.0).sum(axis=1)
        else:
            scores = np.where(batch.valid_mask(), vals, 1.0).prod(axis=1)
        return reject_scores(scores, first_failure(codes))


@numba.njit(cache=True)
def _mark_needed(data: NDArray[np.uint8], mx: IntArray, my: IntArray,
                 inside: NDArray[np.bool_], below: int, need: NDArray[np.bool_]) -> None:
    """``need[my, mx] = True`` for the cells on the grid whose cost is below ``below``."""
    for i in range(mx.shape[0]):
        if inside[i] and data[my[i], mx[i]] < below:
            need[my[i], mx[i]] = True


@numba.njit(cache=True)
def _last_scores(values: FloatArray, data: NDArray[np.uint8], mx: IntArray, my: IntArray,
                 inside: NDArray[np.bool_], blocking: int, obstacle: float,
                 unreachable: float, stop_on_failure: bool, last: IntArray,
                 out: FloatArray) -> None:
    """``aggregation_type: last`` scoring in one pass (same result as the numpy path).

    A pose's value is ``obstacle`` on a blocking cell, else the distance map's; the
    first failing pose (off grid 1, then with ``stop_on_failure`` obstacle 2 or
    unreachable 3) rejects the sample with ``-code``, else the score is the value at
    pose ``last[i]``.
    """
    n, t = mx.shape
    for i in range(n):
        code = 0
        score = 0.0
        for k in range(t):
            x, y = mx[i, k], my[i, k]
            v = obstacle if data[y, x] >= blocking else values[y, x]
            if code == 0:
                if not inside[i, k]:
                    code = 1
                elif stop_on_failure:
                    if v == obstacle:
                        code = 2
                    elif v == unreachable:
                        code = 3
            if k == last[i]:
                score = v
        out[i] = -float(code) if code > 0 else score


@register_critic("PathDist")
class PathDistCritic(MapGridCritic[MapGridParams]):
    """Distance (cells) from the trajectory end to the nearest cell of the pruned plan.

    Nav2 ``nav2_params.yaml`` scale: 32.
    """

    params_model = MapGridParams
    default_scale = 32.0

    def prepare(self, ctx: CriticContext) -> bool:
        seed_x, seed_y = plan_run_cells(ctx.plan, ctx.costmap, ctx.cache)
        self._set_values(ctx, seed_x, seed_y)
        return len(seed_x) > 0


@register_critic("GoalDist")
class GoalDistCritic(MapGridCritic[MapGridParams]):
    """Distance (cells) from the trajectory end to the local goal: the last plan cell on the map.

    Nav2 ``nav2_params.yaml`` scale: 24.
    """

    params_model = MapGridParams
    default_scale = 24.0

    def _prepare_goal(self, ctx: CriticContext, plan: FloatArray) -> bool:
        if plan is ctx.plan:
            run_x, run_y = plan_run_cells(plan, ctx.costmap, ctx.cache)
            run_x, run_y = run_x[-1:], run_y[-1:]
        else:  # only the run's last cell is needed: no dense plan is built
            cm = ctx.costmap
            found, ex, ey = plan_run_end(np.ascontiguousarray(plan, dtype=np.float64),
                                         cm.resolution, cm.origin_x, cm.origin_y, cm.data,
                                         NO_INFORMATION)
            run_x = np.array([ex] if found else [], dtype=np.int64)
            run_y = np.array([ey] if found else [], dtype=np.int64)
        self._set_values(ctx, run_x, run_y)
        return len(run_x) > 0

    def prepare(self, ctx: CriticContext) -> bool:
        return self._prepare_goal(ctx, ctx.plan)


class _AlignMixin:
    """Forward-point scoring shared by ``PathAlign`` and ``GoalAlign``."""

    params: Any
    forward_point = True
    zero_scale = False
    resolution = 0.05

    def _points(self, batch: TrajectoryBatch, last_only: bool) -> tuple[FloatArray, FloatArray]:
        poses = batch.poses[:, -1:, :] if last_only else batch.poses
        d = self.params.forward_point_distance
        return (poses[..., 0] + d * np.cos(poses[..., 2]),
                poses[..., 1] + d * np.sin(poses[..., 2]))

    def _point_key(self) -> float:
        return float(self.params.forward_point_distance)

    def _near_goal(self, ctx: CriticContext) -> bool:
        d = self.params.forward_point_distance
        return math.hypot(ctx.pose.x - ctx.goal.x, ctx.pose.y - ctx.goal.y) <= d


@register_critic("PathAlign")
class PathAlignCritic(_AlignMixin, MapGridCritic[AlignParams]):
    """Distance from the robot's nose (``forward_point_distance`` ahead) to the plan.

    Switched off (scale 0) within ``forward_point_distance`` of the goal, where aiming
    the nose at anything destabilises the approach; its effective scale is
    ``resolution * 0.5 * scale`` (``PathAlignCritic::getScale``).  Nav2 scale: 32.
    """

    params_model = AlignParams
    default_scale = 32.0
    stop_on_failure = False

    def prepare(self, ctx: CriticContext) -> bool:
        self.resolution = ctx.costmap.resolution
        self.zero_scale = self._near_goal(ctx)
        if self.zero_scale:
            return True
        seed_x, seed_y = plan_run_cells(ctx.plan, ctx.costmap, ctx.cache)
        self._set_values(ctx, seed_x, seed_y)
        return len(seed_x) > 0

    def get_scale(self) -> float:
        return 0.0 if self.zero_scale else self.resolution * 0.5 * self.params.scale


@register_critic("GoalAlign")
class GoalAlignCritic(_AlignMixin, GoalDistCritic):
    """Distance from the robot's nose to a point ``forward_point_distance`` past the local goal.

    The target is the local goal moved along the robot->goal direction (Nav2: "the robot
    nose is drawn to its final position before it turns to the goal orientation").
    navstack addition: like ``PathAlign`` the critic is switched off within
    ``forward_point_distance`` of the goal, so it does not fight ``RotateToGoal`` over the
    final heading.  Nav2 scale: 24.
    """

    params_model = AlignParams
    default_scale = 24.0
    stop_on_failure = False

    def prepare(self, ctx: CriticContext) -> bool:
        self.zero_scale = self._near_goal(ctx)
        if self.zero_scale or len(ctx.plan) == 0:
            return True
        angle = math.atan2(ctx.goal.y - ctx.pose.y, ctx.goal.x - ctx.pose.x)
        target = ctx.plan.copy()
        d = self.params.forward_point_distance
        target[-1, 0] += d * math.cos(angle)
        target[-1, 1] += d * math.sin(angle)
        return self._prepare_goal(ctx, target)

    def get_scale(self) -> float:
        return 0.0 if self.zero_scale else self.params.scale
