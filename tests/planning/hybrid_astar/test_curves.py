"""Dubins and Reeds-Shepp shortest paths against closed-form lengths and invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.planning.hybrid_astar.curves import (
    DUBIN,
    REEDS_SHEPP,
    sample,
    sample_path,
    shortest,
    shortest_path,
)

R = 1.7  # an arbitrary turning radius: every closed form below scales with it


@pytest.mark.parametrize("model", [DUBIN, REEDS_SHEPP])
def test_straight_line_is_the_distance(model: int) -> None:
    assert shortest(model, (1.0, 2.0, 0.3), (1.0 + 10 * math.cos(0.3), 2.0 + 10 * math.sin(0.3),
                                              0.3), R)[0] == pytest.approx(10.0, abs=1e-9)


@pytest.mark.parametrize("model", [DUBIN, REEDS_SHEPP])
def test_u_turn_is_half_a_circle(model: int) -> None:
    # (0, 0, 0) -> (0, 2r, pi): a left half circle of radius r, length pi r
    assert shortest(model, (0.0, 0.0, 0.0), (0.0, 2 * R, math.pi), R)[0] == pytest.approx(
        math.pi * R, abs=1e-9)
    assert shortest(model, (0.0, 0.0, 0.0), (0.0, -2 * R, math.pi), R)[0] == pytest.approx(
        math.pi * R, abs=1e-9)


@pytest.mark.parametrize("model", [DUBIN, REEDS_SHEPP])
def test_quarter_turn_then_straight(model: int) -> None:
    d = shortest(model, (0.0, 0.0, 0.0), (R, R + 5.0, math.pi / 2), R)[0]
    assert d == pytest.approx(math.pi * R / 2 + 5.0, abs=1e-9)


def test_going_backwards_needs_reverse_or_two_half_turns() -> None:
    # Reeds-Shepp backs up 5 m; Dubins must turn around (pi r), drive 5, turn back (pi r)
    d_rs, _, lengths = shortest(REEDS_SHEPP, (0.0, 0.0, 0.0), (-5.0, 0.0, 0.0), R)
    assert d_rs == pytest.approx(5.0, abs=1e-9)
    assert np.all(lengths[lengths != 0.0] < 0.0)  # every segment driven in reverse
    d_db = shortest(DUBIN, (0.0, 0.0, 0.0), (-5.0, 0.0, 0.0), R)[0]
    assert d_db == pytest.approx(5.0 + 2 * math.pi * R, abs=1e-9)


def test_turning_in_place_is_impossible() -> None:
    # reversing the heading on the spot: Dubins needs the CCC loop of 7 pi r / 3,
    # Reeds-Shepp three arcs of pi / 3 with two cusps (pi r); both >= pi r, never 0
    d_db = shortest(DUBIN, (0.0, 0.0, 0.0), (0.0, 0.0, math.pi), R)[0]
    d_rs = shortest(REEDS_SHEPP, (0.0, 0.0, 0.0), (0.0, 0.0, math.pi), R)[0]
    assert d_db == pytest.approx(7 * math.pi * R / 3, abs=1e-9)
    assert d_rs == pytest.approx(math.pi * R, abs=1e-9)


def test_random_paths_reach_the_goal_with_bounded_curvature() -> None:
    rng = np.random.default_rng(4)
    for i in range(300):
        start = (*rng.uniform(-3, 3, 2), rng.uniform(-math.pi, math.pi))
        goal = (*rng.uniform(-6, 6, 2), rng.uniform(-math.pi, math.pi))
        lengths = {}
        for model in (DUBIN, REEDS_SHEPP):
            d, _, segs = shortest(model, start, goal, R)
            poses, direction = sample(model, start, goal, R, 0.05)
            end = poses[-1]
            assert math.hypot(end[0] - goal[0], end[1] - goal[1]) < 1e-9, (i, model)
            assert abs(math.remainder(end[2] - goal[2], 2 * math.pi)) < 1e-9
            assert np.sum(np.abs(segs)) * R == pytest.approx(d, abs=1e-9)
            steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
            assert steps.max() <= 0.05 + 1e-9
            # a chord c of an arc of radius >= r turns the heading by <= 2 asin(c / 2r)
            dth = np.abs(np.remainder(np.diff(poses[:, 2]) + math.pi, 2 * math.pi) - math.pi)
            assert np.all(dth <= 2 * np.arcsin(np.minimum(1.0, steps / (2 * R))) + 1e-9)
            if model == DUBIN:
                assert np.all(direction == 1)
            lengths[model] = d
        assert lengths[REEDS_SHEPP] <= lengths[DUBIN] + 1e-9
        # Reeds-Shepp distance is symmetric
        assert shortest(REEDS_SHEPP, goal, start, R)[0] == pytest.approx(
            lengths[REEDS_SHEPP], abs=1e-7)


def test_reeds_shepp_candidates_come_shortest_first_and_all_reach_the_goal() -> None:
    """``above``: the next Reeds-Shepp word after one of that length (analytic shots try
    them in turn); each is a valid path to the goal, and they run out with ``inf``."""
    rng = np.random.default_rng(7)
    counts = []
    for _ in range(100):
        start = (*rng.uniform(-3, 3, 2), rng.uniform(-math.pi, math.pi))
        goal = (*rng.uniform(-3, 3, 2), rng.uniform(-math.pi, math.pi))
        types, segs = np.empty(5, dtype=np.int64), np.empty(5)
        d, n = -1.0, 0
        while True:
            prev = d
            d = shortest_path(REEDS_SHEPP, *start, *goal, R, types, segs, prev)
            if d == math.inf:
                break
            if prev < 0.0:
                assert d == pytest.approx(shortest(REEDS_SHEPP, start, goal, R)[0], abs=1e-12)
            assert d > prev
            assert np.sum(np.abs(segs)) * R == pytest.approx(d, abs=1e-9)
            out, direction = np.empty((2000, 3)), np.empty(2000, dtype=np.int8)
            k = sample_path(*start, types, segs, R, 0.05, out, direction)
            assert math.hypot(out[k - 1, 0] - goal[0], out[k - 1, 1] - goal[1]) < 1e-9
            assert abs(math.remainder(out[k - 1, 2] - goal[2], 2 * math.pi)) < 1e-9
            n += 1
        counts.append(n)
    assert min(counts) >= 2 and max(counts) <= 48
