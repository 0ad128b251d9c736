"""Health measurements on hand-made arrays with known answers (exact binary fractions)."""

from __future__ import annotations

import math

import numpy as np

from navstack.costmap.costmap_2d import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
)
from navstack.interfaces.health.analysis import (
    blocked_fraction,
    follow_stats,
    pose_stds,
    progress_trip,
    rate_over,
    tf_staleness,
)


def test_rate_counts_messages_inside_the_intervals_only() -> None:
    times = (np.arange(16) * 0.125).astype(np.float64)  # 0 .. 1.875 s, 8 Hz
    # [0, 1] holds 9 samples, [1.5, 2] holds 4 (1.5, 1.625, 1.75, 1.875): 13 in 1.5 s
    assert rate_over(times, [(0.0, 1.0), (1.5, 2.0)]) == 13 / 1.5
    assert rate_over(times, []) == 0.0


def _odom(t: np.ndarray, x: np.ndarray, vx: np.ndarray, wz: np.ndarray | None = None
          ) -> np.ndarray:
    z = np.zeros_like(t)
    return np.column_stack((t, x, z, z, vx, z if wz is None else wz))


def test_follow_stats_counts_commands_the_twist_answers() -> None:
    t = np.arange(40) * 0.125  # 0 .. 4.875 s
    cmd = np.column_stack((t, np.full(40, 0.5), np.zeros(40)))
    # the base answers from t = 1.0 on at 0.4 m/s (80 %): commands whose response time
    # t + 0.25 is >= 1.0 are followed, t = 0.75 .. 4.625 -> 32 of the 38 judged commands
    # (the last two have no odometry 0.25 s later)
    vx = np.where(t >= 1.0, 0.4, 0.0)
    n, followed = follow_stats(cmd, _odom(t, 0.4 * t, vx), [(0.0, 5.0)], min_linear=0.05,
                               min_angular=0.1, ratio=0.3, lag=0.25)
    assert (n, followed) == (38, 32)
    # a base that turns the wrong way or crawls below 30 % follows nothing
    for wrong in (-0.4, 0.1):
        n, followed = follow_stats(cmd, _odom(t, t, np.full(40, wrong)), [(0.0, 5.0)],
                                   min_linear=0.05, min_angular=0.1, ratio=0.3, lag=0.25)
        assert followed == 0 and n == 38
    # turning in place: an angular command followed by the yaw rate
    spin = np.column_stack((t, np.zeros(40), np.full(40, 1.0)))
    n, followed = follow_stats(spin, _odom(t, t * 0, t * 0, np.full(40, 0.9)), [(2.0, 3.0)],
                               min_linear=0.05, min_angular=0.1, ratio=0.3, lag=0.25)
    assert (n, followed) == (9, 9)


def test_progress_trip_replays_the_simple_progress_checker() -> None:
    t = np.arange(161) * 0.125  # 0 .. 20 s
    still = _odom(t, np.zeros_like(t), np.zeros_like(t))
    # goal from t=2: the baseline is taken at 2.0 and the rule trips at the first sample
    # more than 10 s later
    assert progress_trip(still, [(2.0, 20.0)], 0.5, 10.0) == (12.125, 2.0)
    # a 0.6 m move at t=5 moves the baseline there
    x = np.where(t >= 5.0, 0.6, 0.0)
    assert progress_trip(_odom(t, x, t * 0), [(2.0, 20.0)], 0.5, 10.0) == (15.125, 5.0)
    # moving 0.5 m is not "more than" the radius
    x = np.where(t >= 5.0, 0.5, 0.0)
    assert progress_trip(_odom(t, x, t * 0), [(2.0, 20.0)], 0.5, 10.0) == (12.125, 2.0)
    # two short goals never trip: the baseline restarts between them
    assert progress_trip(still, [(0.0, 8.0), (9.0, 17.0)], 0.5, 10.0) is None
    assert progress_trip(still, [], 0.5, 10.0) is None


def test_tf_staleness_is_the_oldest_the_newest_sample_got() -> None:
    samples = np.array([[0.0, 0.25], [1.0, 1.25], [2.0, 2.25]])
    # just before t=1 the newest stamp is 0.25 (0.75 s old), before t=2 it is 1.25
    # (0.75 s), at now=5 it is 2.25: 2.75 s old
    assert tf_staleness(samples, 0.0, 5.0) == (2.75, 5.0)
    assert tf_staleness(samples, 0.0, 2.5) == (0.75, 1.0)
    # future-dated samples (map -> odom with transform_tolerance) have negative age
    future = np.array([[0.0, 0.5], [0.25, 0.75], [0.5, 1.0]])
    assert tf_staleness(future, 0.0, 0.5) == (-0.25, 0.25)
    assert tf_staleness(samples, 0.0, -1.0) == (math.inf, -1.0)


def test_blocked_fraction_ignores_unknown_cells() -> None:
    grid = np.full((4, 5), FREE_SPACE, dtype=np.uint8)
    grid[0, :] = NO_INFORMATION  # 5 unknown -> 15 known
    grid[1, :3] = LETHAL_OBSTACLE
    grid[2, :3] = INSCRIBED_INFLATED_OBSTACLE
    grid[3, 0] = 252  # high but passable
    assert blocked_fraction(grid) == (15, 6 / 15)
    assert blocked_fraction(np.full((2, 2), NO_INFORMATION, dtype=np.uint8)) == (0, 0.0)


def test_pose_stds_reads_x_y_yaw_variances() -> None:
    cov = np.zeros((6, 6))
    cov[0, 0], cov[1, 1], cov[5, 5] = 0.25, 0.0625, 0.01
    assert pose_stds(cov) == (0.5, 0.25, 0.1)
    assert pose_stds(cov.ravel()) == (0.5, 0.25, 0.1)
