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
            "goal_to_first_motion_s": [0.1],
            "max_spin_in_place_s": 5.0}


ARENA_REFS = {"arena": {"reference_time_to_90_s": 10.0, "reference_time_to_95_s": 14.0}}


def _arena_cases(lite_t90: float, gain_t90: float) -> list[dict]:
    """Five arena runs of each strategy, every one succeeding with these times to 90 %."""
    return ([_case("arena", "explore_lite", s, lite_t90) for s in range(1, 6)]
            + [_case("arena", "information_gain", s, gain_t90) for s in range(1, 6)])


def _summary(cases: list[dict]) -> BenchResult:
    res = BenchResult("exploration")
    summarize(cases, ARENA_REFS, res)
    return res


def test_the_reference_is_the_greedy_explorer_at_the_navigation_speed() -> None:
    assert "exploration" in available_suites()
    ref = reference("arena")
    assert ref["reference_speed_m_s"] == pytest.approx(0.26)
    assert 0.0 < ref["reference_time_to_90_s"] < ref["reference_time_to_95_s"] < 60.0


def test_budgets_per_strategy_and_of_the_better_strategy_per_world() -> None:
    cases = _arena_cases(18.0, 15.0)
    m = _summary(cases).metrics
    assert m["arena.explore_lite.ratio_to_reference"] == pytest.approx(1.8)
    assert m["arena.information_gain.ratio_to_reference"] == pytest.approx(1.5)
    assert m["explore_lite.success"] == 5 and m["budgets_met"] == 1.0
    # one failure in five is below 14/15; a slower better strategy breaks its budget
    cases[0] = _case("arena", "explore_lite", 1, 18.0, ok=False)
    cases[5:] = [_case("arena", "information_gain", s, 25.0) for s in range(1, 6)]
    res = _summary(cases)
    assert res.metrics["budgets_met"] == 0.0
    notes = "\n".join(res.notes)
    assert "budget: explore_lite succeeded in 4 of 5 runs" in notes
    assert "budget: arena information_gain median time to 90 % is 2.50 x the reference" in notes
    assert "information_gain median time to 90 % 25 s is not below explore_lite's 18 s" in notes
    assert "run arena explore_lite seed 1: FAILED" in notes and notes.count(": lost") == 1
    assert math.isfinite(res.metrics["slam_map_latency_p95_s"])


def test_explore_lite_is_the_peer_its_time_ratio_is_reported_not_budgeted() -> None:
    res = _summary(_arena_cases(29.0, 15.0))
    assert res.metrics["arena.explore_lite.ratio_to_reference"] == pytest.approx(2.9)
    assert res.metrics["budgets_met"] == 1.0
    assert res.notes == ["peer: arena explore_lite median time to 90 % is 2.90 x the "
                         "reference (its semantics; not budgeted)"]


def test_goal_to_first_motion_p95_is_over_every_goal_of_the_bench() -> None:
    """A run sends 1-6 goals to a standing robot: its own p95 is its slowest start.  The
    budget is on the p95 of all goals; the worst run's p95 is reported beside it."""
    cases = _arena_cases(18.0, 15.0)
    for c in cases:
        c["goal_to_first_motion_s"] = [0.1] * 9 + [0.7 if c["seed"] == 1 else 0.1]
        c["goal_to_first_motion_p95_s"] = 0.43 if c["seed"] == 1 else 0.1
    m = _summary(cases).metrics
    assert m["goal_to_first_motion_samples"] == 100
    assert m["goal_to_first_motion_p95_s"] == pytest.approx(0.1)
    assert m["goal_to_first_motion_worst_run_p95_s"] == pytest.approx(0.43)
    assert m["budgets_met"] == 1.0
    for c in cases:  # one slow start in ten for every run: p95 over the budget
        c["goal_to_first_motion_s"][-1] = 0.7
    res = _summary(cases)
    assert res.metrics["budgets_met"] == 0.0
    assert "budget: goal-to-first-motion p95 0.70 s > 0.4 s" in "\n".join(res.notes)


def test_workers_must_be_positive() -> None:
    with pytest.raises(ConfigError, match="--workers must be at least 1, got 0"):
        run(False, None, worlds=["arena"], workers=0)


def test_unknown_strategy_and_localization_are_named() -> None:
    with pytest.raises(ConfigError, match="unknown exploration strategy greedy"):
        run(False, None, worlds=["arena"], strategies=["greedy"])
    with pytest.raises(ConfigError, match="unknown localization 'amcl'"):
        run(False, None, worlds=["arena"], localization="amcl")


def test_the_cli_selects_worlds_seeds_and_strategies() -> None:
    from typer.testing import CliRunner

    from navstack.app import app

    res = CliRunner().invoke(app, ["bench", "exploration", "--seeds", "1,x"])
    assert res.exit_code == 2 and "--seeds takes a comma list of integers, got '1,x'" in \
        res.output
    res = CliRunner().invoke(app, ["bench", "exploration", "--worlds", "arena",
                                   "--strategies", "greedy"])
    assert res.exit_code == 2 and "unknown exploration strategy greedy" in res.output
