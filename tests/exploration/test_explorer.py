"""The exploration decision loop, run on true worlds with the idealised robot.

The idealised robot (exploration/ideal.py) drives at the TurtleBot's speed with instant
turns and a perfect 3.5 m lidar, so these runs take seconds; they check the decisions --
finishing, what is reported as left, never stopping while a reachable frontier remains --
on the exploration regression worlds.  The same worlds run on the full stack in
tests/missions/test_explore_regressions.py.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from navstack.exploration import DecisionKind, ExploreParams, FrontierExplorer, GridView
from navstack.exploration.ideal import IdealRobot, reachable_free_space, run_ideal
from navstack.sim.worlds import load_world


def _run(world: str, strategy: str):  # type: ignore[no-untyped-def]
    w = load_world(world)
    target = reachable_free_space(w.occupied, w.resolution, w.origin_x, w.origin_y,
                                  (w.spawn.x, w.spawn.y), 0.15, 3.5)
    ex = FrontierExplorer(ExploreParams(strategy=strategy))
    res = run_ideal(w.occupied, w.resolution, w.origin_x, w.origin_y,
                    (w.spawn.x, w.spawn.y), IdealRobot(), target, ex, max_time=600.0)
    return res, ex


@pytest.mark.parametrize("strategy", ["information_gain", "explore_lite", "nearest"])
@pytest.mark.parametrize("world", ["arena", "explore_facing_wall", "explore_dead_end"])
def test_regression_worlds_are_explored_completely(world: str, strategy: str) -> None:
    res, ex = _run(world, strategy)
    assert res.finished, res.reason
    assert res.fractions[-1] >= 0.97
    assert res.duration < 120.0
    assert ex.stats.goals_sent >= 1


@pytest.mark.parametrize("strategy", ["information_gain", "explore_lite"])
def test_narrow_door_ends_naming_the_unreachable_frontier(strategy: str) -> None:
    res, _ = _run("explore_narrow_door", strategy)
    assert res.finished
    assert res.duration < 120.0
    assert "unreachable (no traversable path: behind an opening narrower than the robot)" \
        in res.reason
    # the reported frontier lies behind the gap (the wall is at y = 3.0)
    where = res.reason.split("narrower than the robot): ")[1]
    y = float(where.split("at (")[1].split(",")[1].split(")")[0])
    assert y > 3.0


def test_greedy_reference_explores_the_arena() -> None:
    w = load_world("arena")
    target = reachable_free_space(w.occupied, w.resolution, w.origin_x, w.origin_y,
                                  (w.spawn.x, w.spawn.y), 0.15, 3.5)
    res = run_ideal(w.occupied, w.resolution, w.origin_x, w.origin_y,
                    (w.spawn.x, w.spawn.y), IdealRobot(), target)
    assert res.finished and res.fractions[-1] >= 0.97
    assert res.time_to(0.9) < res.time_to(0.95) < res.duration
    # the 5 Hz samples cut the path's corners: their chords are a little shorter
    chords = sum(((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2) ** 0.5
                 for a, b in itertools.pairwise(res.trajectory))
    assert chords <= res.path_length <= 1.1 * chords


def _one_frontier_view() -> GridView:
    unknown = np.zeros((20, 40), bool)
    unknown[:, 30:] = True
    free = ~unknown
    return GridView(unknown, free, free.copy(), 0.1)


def test_a_failed_frontier_is_retried_once_before_exploration_ends() -> None:
    view = _one_frontier_view()
    ex = FrontierExplorer(ExploreParams(max_goal_attempts=2))
    first = ex.plan(view, (0.5, 1.0, 0.0), 0.0)
    assert first.kind is DecisionKind.SEND and first.target is not None
    assert 2.65 <= first.target.goal[0] <= 2.95  # within frontier_reach of the frontier
    ex.goal_finished("FAILED", "a person blocked the way", 5.0)
    # the only frontier is blacklisted once: it is released and tried again, not dropped
    second = ex.plan(view, (0.5, 1.0, 0.0), 6.0)
    assert second.kind is DecisionKind.SEND
    assert ex.stats.retries == 1
    ex.goal_finished("FAILED", "a person blocked the way", 9.0)
    done = ex.plan(view, (0.5, 1.0, 0.0), 10.0)
    assert done.kind is DecisionKind.DONE
    assert "1 blacklisted: frontier at (3.05, 1.00) (20 cells, tried 2x)" in done.reason
    assert "tried 2x): navigation failed: a person blocked the way" in done.reason


def test_progress_and_stuck_watchdogs_blacklist_the_goal() -> None:
    view = _one_frontier_view()
    ex = FrontierExplorer(ExploreParams(progress_timeout=30.0, stuck_timeout=15.0,
                                        max_goal_attempts=1))
    assert ex.plan(view, (0.5, 1.0, 0.0), 0.0).kind is DecisionKind.SEND
    # the robot turns in place: no displacement for more than stuck_timeout
    assert ex.plan(view, (0.5, 1.0, 1.0), 10.0).kind is DecisionKind.KEEP
    stuck = ex.plan(view, (0.5, 1.0, 2.0), 16.0)
    assert stuck.cancelled.startswith("the robot moved less than 0.25 m in 15 s")
    assert stuck.blacklisted
    assert stuck.kind is DecisionKind.DONE
    # progress_timeout: the robot moves, but no closer to the goal
    ex2 = FrontierExplorer(ExploreParams(progress_timeout=30.0, stuck_timeout=100.0,
                                         max_goal_attempts=1))
    assert ex2.plan(view, (0.5, 1.0, 0.0), 0.0).kind is DecisionKind.SEND
    for k in range(1, 7):  # pacing up and down across the strip
        d = ex2.plan(view, (0.5, 0.3 + 0.2 * (k % 2) * 7, 0.0), 6.0 * k)
    assert d.cancelled.startswith("no progress toward it for 30 s (progress_timeout)")


def test_a_robot_wedged_far_from_its_goal_does_not_use_up_the_frontier() -> None:
    """Stuck 6 m from the goal (wedged on the way, as office information gain seed 5 was
    twice in rooms C and F): the frontier is set aside and retried without counting
    toward ``max_goal_attempts``; after ``2 * max_goal_attempts`` tries it is given up."""
    unknown = np.zeros((20, 80), bool)
    unknown[:, 70:] = True
    free = ~unknown
    view = GridView(unknown, free, free.copy(), 0.1)
    ex = FrontierExplorer(ExploreParams(stuck_timeout=15.0, max_goal_attempts=1))
    assert ex.plan(view, (0.5, 1.0, 0.0), 0.0).kind is DecisionKind.SEND
    stuck = ex.plan(view, (0.5, 1.0, 2.0), 16.0)
    assert stuck.blacklisted and stuck.cancelled.endswith(", 6.3 m from the goal")
    assert stuck.kind is DecisionKind.SEND  # retried at once: it was the only frontier
    assert ex.stats.retries == 1
    again = ex.plan(view, (0.5, 1.0, 2.0), 32.0)
    assert again.blacklisted and again.kind is DecisionKind.DONE
    assert "(20 cells, tried 2x): the robot moved less than 0.25 m in 15 s" in again.reason
    # stuck next to the goal: the frontier's own failure, no retry with one attempt
    near = FrontierExplorer(ExploreParams(stuck_timeout=15.0, max_goal_attempts=1))
    near.plan(view, (5.0, 1.0, 0.0), 0.0)
    assert near.plan(view, (5.0, 1.0, 2.0), 16.0).kind is DecisionKind.DONE


def _two_frontiers(right_unknown_cols: slice) -> GridView:
    """A 4 x 2 m room: a thin frontier on the left wall (x = 0) and unknown space
    ``right_unknown_cols`` on the right."""
    unknown = np.zeros((20, 40), bool)
    unknown[:, 0] = True
    unknown[:, right_unknown_cols] = True
    free = ~unknown
    return GridView(unknown, free, free.copy(), 0.1)


def test_information_gain_looks_ahead_once_its_goal_has_shown_what_it_was_sent_for() -> None:
    """Within ``lookahead_distance`` (path) of the goal it drives to, the information-gain
    strategy sends the next target -- no slow-down to a stop at the viewpoint -- but only
    once the unknown area visible from that goal has shrunk to ``lookahead_gain_fraction``
    of what it was; the target it leaves is judged like a reached goal."""
    unseen = _two_frontiers(slice(30, 40))    # the right metre unknown
    seen = _two_frontiers(slice(30, 31))      # all but a strip of it observed
    ex = FrontierExplorer(ExploreParams(strategy="information_gain", lookahead_distance=1.0,
                                        lookahead_gain_fraction=0.5))
    first = ex.plan(unseen, (1.0, 1.0, 0.0), 0.0)
    assert first.kind is DecisionKind.SEND and first.target is not None
    goal_x = first.target.goal[0]
    assert 2.65 <= goal_x <= 3.0 and first.target.distance > 1.0  # the large right one
    # 0.75 m from the goal, nothing more seen: keep driving to it
    near = (goal_x - 0.75, 1.0, 0.0)
    assert ex.plan(unseen, near, 1.0).kind is DecisionKind.KEEP
    # the same spot once most of the right side is known: on to the left frontier
    ahead = ex.plan(seen, near, 2.0)
    assert ahead.kind is DecisionKind.SEND and ahead.reason == "look-ahead"
    assert ahead.target is not None and ahead.target.goal[0] < 0.5
    assert len(ex._arrivals) == 1  # the right one is judged like a reached goal
    # without the look-ahead the robot keeps its goal until it arrives
    ex0 = FrontierExplorer(ExploreParams(strategy="information_gain", lookahead_distance=0.0))
    ex0.plan(unseen, (1.0, 1.0, 0.0), 0.0)
    assert ex0.plan(seen, near, 2.0).kind is DecisionKind.KEEP


def test_a_goal_sent_from_within_the_look_ahead_band_is_not_skipped() -> None:
    """A target sent less than ``lookahead_distance`` away is driven to: looking ahead at
    once would drop every short goal before the robot got there."""
    seen = _two_frontiers(slice(30, 31))
    ex = FrontierExplorer(ExploreParams(strategy="information_gain", lookahead_distance=1.0,
                                        lookahead_gain_fraction=1.0))
    first = ex.plan(seen, (2.2, 1.0, 0.0), 0.0)
    assert first.kind is DecisionKind.SEND and first.target is not None
    assert first.target.goal[0] > 2.5 and first.target.distance < 1.0
    assert ex.plan(seen, (2.3, 1.0, 0.0), 1.0).kind is DecisionKind.KEEP


def test_an_observed_frontier_is_given_up_without_blacklisting() -> None:
    """The mission only stops and escapes after a failed goal (``blacklisted``); a goal
    whose frontier was observed on the way is simply replaced by the next one."""
    view = _one_frontier_view()
    ex = FrontierExplorer(ExploreParams(strategy="explore_lite"))
    assert ex.plan(view, (0.5, 1.0, 0.0), 0.0).kind is DecisionKind.SEND
    free = np.ones((20, 40), bool)
    done = ex.plan(GridView(~free, free, free.copy(), 0.1), (1.5, 1.0, 0.0), 1.0)
    assert done.cancelled == "its frontier was observed"
    assert not done.blacklisted and ex.stats.blacklisted == 0


def test_information_gain_keeps_a_sent_goal_that_is_still_a_good_viewpoint() -> None:
    """The best viewpoint of the target moves as the robot does; a goal already sent is
    kept while it scores within ``retarget_hysteresis`` of the best one -- re-sending it
    at every plan made the robot stop and restart (office seed 2 flipped between two
    viewpoints 0.54 m apart every second) -- and moved once it is clearly worse."""
    unknown = np.zeros((60, 40), bool)  # a 4 x 6 m room, its right metre unknown
    unknown[:, 30:] = True
    free = ~unknown
    view = GridView(unknown, free, free.copy(), 0.1)
    ex = FrontierExplorer(ExploreParams(strategy="information_gain", lookahead_distance=0.0))
    first = ex.plan(view, (1.0, 3.2, 0.0), 0.0)
    assert first.kind is DecisionKind.SEND and first.target is not None
    sent = first.target.goal
    assert sent[1] > 3.0
    # the robot has moved 1.2 m down: the best viewpoint is now 1.2 m lower, but the one
    # sent is nearly as good (within 25 %): kept
    kept = ex.plan(view, (1.0, 2.0, 0.0), 1.0)
    assert kept.kind is DecisionKind.KEEP and kept.target is not None
    assert kept.target.goal[1] < sent[1] - 1.0  # the best one did move
    assert ex.target is not None and ex.target.goal == sent
    # 2.9 m down: the goal sent is 1.4 m farther than the best one: moved
    moved = ex.plan(view, (1.0, 0.3, 0.0), 2.0)
    assert moved.kind is DecisionKind.SEND and moved.reason == "goal moved"
    assert moved.target is not None and moved.target.goal[1] < 2.0
