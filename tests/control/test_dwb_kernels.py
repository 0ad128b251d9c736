"""DWB's compiled kernels give exactly what the numpy formulations they replace give.

The references below are the numpy implementations the kernels replaced (issue 21,
item 6); equality is exact (``array_equal`` / ``==``), because the navigation bench's
results must not move when the loop gets faster.
"""

from __future__ import annotations

import numpy as np
import pytest

from navstack.control.dwb.critic_base import CriticContext, first_failure, reject_scores
from navstack.control.dwb.critics_map_grid import (
    _plan_run_cells,
    blocking_cost,
)
from navstack.control.dwb.dwb_controller import DWBLocalPlanner
from navstack.control.dwb.grid import adjust_plan_resolution, plan_run_end, world_to_cells
from navstack.control.dwb.params import TrajectoryGeneratorParams
from navstack.control.dwb.trajectory_generator import StandardTrajectoryGenerator
from navstack.core.msgs import Pose2D, Twist2D
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION
from navstack.navigation.bt_nodes import distance_remaining
from tests.control.scenes import empty_costmap, left_arc


def _ref_world_to_cells(cm, x, y):  # type: ignore[no-untyped-def]
    fx = np.floor((x - cm.origin_x) / cm.resolution)
    fy = np.floor((y - cm.origin_y) / cm.resolution)
    inside = (fx >= 0) & (fx < cm.size_x) & (fy >= 0) & (fy < cm.size_y)
    return (np.clip(fx, 0, cm.size_x - 1).astype(np.int64),
            np.clip(fy, 0, cm.size_y - 1).astype(np.int64), inside)


def _ref_adjust(plan: np.ndarray, resolution: float) -> np.ndarray:
    if len(plan) < 2:
        return plan.copy()
    diff = np.diff(plan, axis=0)
    dist = np.hypot(diff[:, 0], diff[:, 1])
    steps = np.where(dist ** 2 > resolution ** 2,
                     np.ceil((dist - resolution) / resolution) + 1.0, 1.0).astype(np.int64)
    seg = np.repeat(np.arange(len(steps)), steps)
    starts = np.concatenate(([0], np.cumsum(steps)[:-1]))
    j = (np.arange(len(seg)) - starts[seg] + 1).astype(np.float64)
    out = np.empty((len(seg) + 1, 3))
    out[0] = plan[0]
    out[1:] = plan[seg] + (j / steps[seg])[:, None] * diff[seg]
    out[np.cumsum(steps)] = plan[1:]
    return out


def _ref_distance_remaining(xy: np.ndarray, x: float, y: float) -> float:
    if len(xy) < 2:
        return 0.0
    a, d = xy[:-1], np.diff(xy, axis=0)
    seg2 = np.einsum("ij,ij->i", d, d)
    rel = np.array([x, y]) - a
    t = np.clip(np.einsum("ij,ij->i", rel, d) / np.where(seg2 > 0.0, seg2, 1.0), 0.0, 1.0)
    gap = rel - t[:, None] * d
    k = int(np.argmin(np.einsum("ij,ij->i", gap, gap)))
    seg_len = np.sqrt(seg2)
    return float((1.0 - t[k]) * seg_len[k] + seg_len[k + 1:].sum())


def _random_plan(rng: np.random.Generator, m: int) -> np.ndarray:
    plan = np.cumsum(rng.normal(0.0, rng.choice([0.02, 0.1, 0.3]), (m, 3)), axis=0)
    if m > 3:
        plan[2] = plan[1]  # a zero-length gap
    return plan


def test_cells_and_densified_plan_match_numpy() -> None:
    rng = np.random.default_rng(0)
    cm = empty_costmap(80)
    for _ in range(200):
        x, y = rng.uniform(-4, 4, (2, 7, 9))
        for got, want in zip(world_to_cells(cm, x, y), _ref_world_to_cells(cm, x, y),
                             strict=True):
            assert got.dtype == want.dtype and np.array_equal(got, want)
        plan = _random_plan(rng, int(rng.integers(0, 40)))
        assert np.array_equal(adjust_plan_resolution(plan, 0.05), _ref_adjust(plan, 0.05))


def test_plan_run_end_is_the_last_cell_of_the_run() -> None:
    rng = np.random.default_rng(1)
    cm = empty_costmap(60)
    cm.data[rng.random(cm.data.shape) < 0.03] = NO_INFORMATION
    cm.data[35:40, :] = NO_INFORMATION
    found_some = 0
    for _ in range(500):
        plan = _random_plan(rng, int(rng.integers(0, 40)))
        run_x, run_y = _plan_run_cells(plan, cm)
        found, ex, ey = plan_run_end(np.ascontiguousarray(plan), cm.resolution, cm.origin_x,
                                     cm.origin_y, cm.data, NO_INFORMATION)
        assert found == (len(run_x) > 0)
        if found:
            found_some += 1
            assert (ex, ey) == (run_x[-1], run_y[-1])
    assert found_some > 100


@pytest.mark.parametrize("params", [
    TrajectoryGeneratorParams(),
    TrajectoryGeneratorParams(min_vel_x=-0.3, min_vel_y=-0.2, max_vel_y=0.2, vx_samples=7,
                              vy_samples=5, min_speed_xy=0.0, min_speed_theta=0.1),
    TrajectoryGeneratorParams(vx_samples=1, vtheta_samples=3, max_speed_xy=-1.0),
])
def test_velocity_window_matches_numpy(params: TrajectoryGeneratorParams) -> None:
    rng = np.random.default_rng(2)
    gen = StandardTrajectoryGenerator(params)
    for limit in (0.0, 50.0):
        gen.set_speed_limit(limit, True)
        for _ in range(300):
            cur = Twist2D(*(rng.uniform(-0.6, 0.6, 3) * (rng.random(3) < 0.7)))
            got, want = gen.sample_velocities(cur), gen.sample_velocities_numpy(cur)
            assert got.shape == want.shape and np.array_equal(got, want)


def _ref_grid_last(critic, batch, ctx) -> np.ndarray:  # type: ignore[no-untyped-def]
    """MapGridCritic.score's numpy formulation for ``aggregation_type: last``."""
    mx, my, inside = critic._cells(batch, ctx.costmap)
    blocked = ctx.costmap.data[my, mx] >= blocking_cost(ctx.costmap, ctx.pose)
    vals = np.where(blocked, critic.obstacle_score, critic.values[my, mx])
    codes = np.where(inside, 0, 1)
    if critic.stop_on_failure:
        codes = np.where(codes > 0, codes,
                         np.where(vals == critic.obstacle_score, 2,
                                  np.where(vals == critic.unreachable_score, 3, 0)))
    scores = (vals[:, 0] if critic._last_only()
              else vals[np.arange(len(batch)), batch.lengths - 1])
    return reject_scores(scores, first_failure(codes))


def _ref_base_obstacle(batch, ctx) -> np.ndarray:  # type: ignore[no-untyped-def]
    cm = ctx.costmap
    mx, my, inside = world_to_cells(cm, batch.poses[:, :, 0], batch.poses[:, :, 1])
    cost = cm.data[my, mx]
    limit = blocking_cost(cm, ctx.pose)
    codes = np.where(~inside, 1,
                     np.where(cost == NO_INFORMATION, 3, np.where(cost >= limit, 2, 0)))
    scores = cost.astype(np.float64)[np.arange(len(batch)), batch.lengths - 1]
    return reject_scores(scores, first_failure(codes))


def test_critic_kernels_match_numpy_with_obstacles_and_unknown_space() -> None:
    cm = empty_costmap(60)
    cm.data[28:34, 40:44] = LETHAL_OBSTACLE
    cm.data[26:36, 38:46] = np.maximum(cm.data[26:36, 38:46], 253)
    cm.data[:, 55:] = NO_INFORMATION
    dwb = DWBLocalPlanner()
    path = left_arc(1.2)
    pose, vel = Pose2D(0.0, 0.0, 0.1), Twist2D(0.2, 0.0, 0.3)
    dwb.compute(pose, vel, path, cm)  # prepares plan pruning like a real cycle
    plan = dwb.transform_global_plan(pose, cm)
    batch = dwb.generator.generate(pose, vel)
    g = dwb._plan[-1]
    ctx = CriticContext(pose, vel, Pose2D(*map(float, g)), plan, cm, 0.0, batch)
    checked = 0
    for critic in dwb.critics:
        critic.prepare(ctx)
        got = critic.score(batch, ctx)
        if type(critic).__name__ == "BaseObstacleCritic":
            want = _ref_base_obstacle(batch, ctx)
        elif hasattr(critic, "values"):
            want = _ref_grid_last(critic, batch, ctx)
        else:
            continue
        assert np.array_equal(got, want), critic.name
        checked += 1
    assert checked == 5  # BaseObstacle, GoalAlign, PathAlign, PathDist, GoalDist
    assert (dwb.critics[2].score(batch, ctx) < 0).any()  # some samples hit the box


def test_distance_remaining_matches_numpy() -> None:
    rng = np.random.default_rng(4)
    for _ in range(500):
        xy = np.ascontiguousarray(_random_plan(rng, int(rng.integers(0, 300)))[:, :2])
        x, y = rng.normal(0.0, 1.0, 2)
        assert distance_remaining(xy, x, y) == _ref_distance_remaining(xy, x, y)
