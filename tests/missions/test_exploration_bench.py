"""``navstack bench exploration``: the reference explorer and the budget arithmetic (the
runs themselves are the benchmark's; the regression worlds run in CI)."""

from __future__ import annotations

import math

import pytest

from navstack.benchmarks.common import BenchResult
from navstack.benchmarks.exploration import reference, run, summarize
from navstack.benchmarks.runner import available_suites
from navstack.core.errors import ConfigError


def _case(world: str, strategy: str, seed: int, t90: float, ok: bool = True) -> dict:
    return {"world": world, "strategy": strategy, "seed": seed, "success": ok,
            "status": "SUCCEEDED" if ok else "FAILED", "reason": "" if ok else "lost",
            "time_to_90_s": t90, "time_to_95_s": t90 * 1.2, "observed_fraction": 0.97,
            "map_iou": 0.9, "path_length_m": 10.0, "collisions": 0, "home_distance_m": 0.1,
            "slam_map_latency_p95_s": 0.6, "goal_to_first_motion_p95_s": 0.1,
            "max_spin_in_place_s": 5.0}


def test_the_reference_is_the_greedy_explorer_at_the_navigation_speed() -> None:
    assert "exploration" in available_suites()
    ref = reference("arena")
    assert ref["reference_speed_m_s"] == pytest.approx(0.26)
    assert 0.0 < ref["reference_time_to_90_s"] < ref["reference_time_to_95_s"] < 60.0


def test_budgets_per_strategy_per_world_and_the_better_strategy() -> None:
    refs = {"arena": {"reference_time_to_90_s": 10.0, "reference_time_to_95_s": 14.0}}
    cases = [_case("arena", "explore_lite", s, 18.0) for s in range(1, 6)]
    cases += [_case("arena", "information_gain", s, 15.0) for s in range(1, 6)]
    res = BenchResult("exploration")
    summarize(cases, refs, res)
    m = res.metrics
    assert m["arena.explore_lite.ratio_to_reference"] == pytest.approx(1.8)
    assert m["arena.information_gain.ratio_to_reference"] == pytest.approx(1.5)
    assert m["explore_lite.success"] == 5 and m["budgets_met"] == 1.0
    # one failure in five is below 14/15; a slower better strategy breaks its budget
    cases[0] = _case("arena", "explore_lite", 1, 18.0, ok=False)
    cases[5:] = [_case("arena", "information_gain", s, 25.0) for s in range(1, 6)]
    res = BenchResult("exploration")
    summarize(cases, refs, res)
    assert res.metrics["budgets_met"] == 0.0
    notes = "\n".join(res.notes)
    assert "budget: explore_lite succeeded in 4 of 5 runs" in notes
    assert "budget: arena information_gain median time to 90 % is 2.50 x the reference" in notes
    assert "information_gain median time to 90 % 25 s is not below explore_lite's 18 s" in notes
    assert "run arena explore_lite seed 1: FAILED" in notes and notes.count(": lost") == 1
    assert math.isfinite(res.metrics["slam_map_latency_p95_s"])


def test_workers_must_be_positive() -> None:
    with pytest.raises(ConfigError, match="--workers must be at least 1, got 0"):
        run(False, None, worlds=["arena"], workers=0)
