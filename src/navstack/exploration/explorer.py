"""``FrontierExplorer``: the decisions of frontier exploration, without a bus.

explore_lite's ``makePlan`` loop, as a pure state machine the mission layer (or a test,
or the benchmark's reference) calls ``planner_frequency`` times per second:

1. search the frontiers of the current map from the robot (:func:`find_frontiers`,
   blacklisted cells removed);
2. watch the goal being pursued: blacklist its frontier when the robot has come no
   closer to it for ``progress_timeout`` (explore_lite) or has not moved
   ``stuck_distance`` in ``stuck_timeout`` (turning in place or recovering, navstack);
   drop it when its frontier has been observed (its cells are no longer frontier);
3. pick the best target (:mod:`.strategies`) and say whether to send a new goal:
   explore_lite semantics re-send whenever the best goal moves, the information-gain
   strategy keeps its target unless another is ``retarget_hysteresis`` better (and the
   goal it sent while that goal is still an approach cell within ``retarget_hysteresis``
   of the target's best viewpoint), and
   looks ahead: within ``lookahead_distance`` (path) of the goal it drives to -- once
   the unknown area visible from that goal is down to ``lookahead_gain_fraction`` of
   what it was chosen for -- it sends the next target, so the robot does not slow to a
   stop at every viewpoint;
4. when no reachable frontier is left: retry once-blacklisted frontiers that are
   reachable again (``max_goal_attempts``), else report DONE with what was left
   (unreachable frontiers -- e.g. seen through a gap narrower than the robot -- and
   blacklisted ones, each with its reason).

A goal given up because its frontier was observed is simply replaced
(``Decision.blacklisted`` False: the mission sends the next goal without stopping); one
given up by a watchdog is blacklisted (``blacklisted`` True: the mission stops the robot
and escapes first).

The mission reports how each goal ended (:meth:`goal_finished`): an aborted goal
blacklists its frontier (explore_lite ``reachedGoal``); a reached one is checked
``arrival_settle_time`` later -- if its frontier is still unknown it cannot be observed
from there and is blacklisted, so the robot never oscillates on a spot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from navstack.exploration.blacklist import Blacklist
from navstack.exploration.frontiers import Frontier, FrontierSet, find_frontiers
from navstack.exploration.gain import visible_unknown
from navstack.exploration.grid_view import FloatArray, GridView
from navstack.exploration.params import ExploreParams
from navstack.exploration.strategies import ExplorationStrategy, Target, make_strategy
from navstack.exploration.wavefront import Wavefront, dilate

__all__ = ["Decision", "DecisionKind", "FrontierExplorer"]


class DecisionKind(Enum):
    SEND = "send"
    """Send ``target.goal`` to the navigator (a new target, or the target's goal moved)."""
    KEEP = "keep"
    """Keep pursuing the current goal."""
    WAIT = "wait"
    """Nothing to pursue yet (no map, or a reached frontier is being judged)."""
    DONE = "done"
    """No reachable frontier is left; ``reason`` says what was left, if anything."""


@dataclass(frozen=True)
class Decision:
    kind: DecisionKind
    target: Target | None
    reason: str
    frontiers: FrontierSet | None
    cancelled: str = ""
    """Why the previous goal was given up, if it was (to cancel it on the navigator)."""
    blacklisted: bool = False
    """The goal given up (``cancelled``) was a failure -- no progress, stuck -- and its
    frontier is blacklisted; otherwise its frontier was simply observed."""


@dataclass
class _Pursuit:
    target: Target
    points: FloatArray
    started: float
    best_distance: float
    last_progress: float
    anchor: tuple[float, float]
    anchor_time: float
    sent_distance: float = math.inf
    """Path distance [m] to the goal when it was sent (or last moved)."""
    sent_gain: float = 0.0
    """Its information gain [m^2] then."""


@dataclass
class _Arrival:
    points: FloatArray
    goal: tuple[float, float]
    time: float


@dataclass
class ExplorerStats:
    goals_sent: int = 0
    goals_succeeded: int = 0
    goals_failed: int = 0
    blacklisted: int = 0
    retries: int = 0
    plans: int = 0


@dataclass
class FrontierExplorer:
    """Decision loop of frontier exploration (module docstring)."""

    params: ExploreParams = field(default_factory=ExploreParams)
    strategy: ExplorationStrategy | None = None

    def __post_init__(self) -> None:
        p = self.params
        if self.strategy is None:
            self.strategy = make_strategy(p)
        self.blacklist = Blacklist(p.blacklist_tolerance, p.max_goal_attempts)
        self.stats = ExplorerStats()
        self.events: list[tuple[float, str]] = []
        self._wavefront = Wavefront()
        self._pursuit: _Pursuit | None = None
        self._arrivals: list[_Arrival] = []
        self.last: FrontierSet | None = None

    # --- queries -------------------------------------------------------------------------
    @property
    def target(self) -> Target | None:
        return self._pursuit.target if self._pursuit is not None else None

    def _log(self, now: float, text: str) -> None:
        self.events.append((now, text))

    # --- the loop --------------------------------------------------------------------------
    def plan(self, view: GridView, robot: tuple[float, float, float], now: float) -> Decision:
        """One ``makePlan``: search, watch the current goal, choose (module docstring)."""
        assert self.strategy is not None
        p = self.params
        self.stats.plans += 1
        if not view.free.any():
            return Decision(DecisionKind.WAIT, None, "no observed free space yet", None)
        fs = self._search(view, robot)
        self._judge_arrivals(view, fs, now)
        fs = self._search(view, robot) if self._blacklist_changed else fs
        cancelled = self._watch(view, fs, robot, now)
        failed = bool(cancelled) and self._blacklist_changed
        if cancelled:
            fs = self._search(view, robot)
        pending = self._pending_mask(view)
        ranked = [t for t in self.strategy.rank(fs, view, robot)
                  if not _covers(pending, view, t.frontier)]
        if not ranked:
            if pending is not None:
                return Decision(DecisionKind.WAIT, None,
                                "waiting for the map at a reached frontier", fs, cancelled, failed)
            released = self.blacklist.release_retryable()
            if released:
                self.stats.retries += len(released)
                for e in released:
                    self._log(now, f"retrying {e.describe()}")
                fs = self._search(view, robot)
                ranked = self.strategy.rank(fs, view, robot)
            if not ranked:
                self._pursuit = None
                return Decision(DecisionKind.DONE, None, self._done_reason(fs), fs, cancelled,
                                failed)
        best = ranked[0]
        current = self._current_in(ranked, view)
        if current is not None:
            assert self._pursuit is not None
            lite = self.strategy.follows_best
            if lite:  # explore_lite follows the best frontier every plan
                keep = best.frontier.label == current.frontier.label
            else:
                keep = not self.strategy.better(best.score, current.score,
                                                p.retarget_hysteresis)
                ahead = self._look_ahead(ranked, current, fs, view, now) if keep else None
                if ahead is not None:
                    self._start(ahead, view, robot, now)
                    return Decision(DecisionKind.SEND, ahead, "look-ahead", fs, cancelled, failed)
            if keep:
                old_goal = self._pursuit.target.goal
                self._pursuit.target = current
                self._pursuit.points = current.frontier.points(view)
                # explore_lite re-sends when its goal moves at all; the viewpoint of the
                # information-gain target is updated when it moves by a viewpoint spacing
                tol = 2.0 * view.resolution if lite else p.viewpoint_spacing
                if not _near(current.goal, old_goal, tol) and (
                        lite or not self._still_good(old_goal, current, fs, view, robot)):
                    self._pursuit.sent_distance = current.distance
                    self._pursuit.sent_gain = current.gain
                    return Decision(DecisionKind.SEND, current, "goal moved", fs, cancelled, failed)
                self._pursuit.target = Target(current.frontier, old_goal, current.distance,
                                              current.score, current.gain)
                return Decision(DecisionKind.KEEP, current, "", fs, cancelled, failed)
        self._start(best, view, robot, now)
        return Decision(DecisionKind.SEND, best, "new target", fs, cancelled, failed)

    def _look_ahead(self, ranked: list[Target], current: Target, fs: FrontierSet,
                    view: GridView, now: float) -> Target | None:
        """The next target when the robot is within ``lookahead_distance`` (path) of the
        goal it drives to (params); the current one is then judged like a reached goal.
        The distance is the pursued goal's, not the frontier's best viewpoint now: that
        one recedes as the robot approaches (the frontier moves as it is seen), and the
        robot would slow down for the goal it was sent before the look-ahead fired."""
        p = self.params
        if p.lookahead_distance <= 0.0 or self._pursuit is None:
            return None
        if self._pursuit.sent_distance <= p.lookahead_distance:
            return None  # sent from within the band: looking ahead would skip it at once
        r, c = view.cell_of(*self._pursuit.target.goal)
        d = float(fs.distances[r, c]) if view.inside(r, c) else math.inf
        if min(d, current.distance) > p.lookahead_distance:
            return None
        if self._pursuit.sent_gain > 0.0 and view.inside(r, c):
            # move on only once most of what the goal was chosen for has been seen: a
            # frontier left half seen is pursued again later, from the far side
            left = float(visible_unknown(view, np.array([r]), np.array([c]),
                                         p.sensor_range)[0]) * view.resolution ** 2
            if left > p.lookahead_gain_fraction * self._pursuit.sent_gain:
                return None
        others = [t for t in ranked if t.frontier.label != current.frontier.label]
        if not others:
            return None
        self._arrivals.append(_Arrival(self._pursuit.points, self._pursuit.target.goal, now))
        self._pursuit = None
        return others[0]

    def _still_good(self, old_goal: tuple[float, float], current: Target, fs: FrontierSet,
                    view: GridView, robot: tuple[float, float, float]) -> bool:
        """Whether the goal already sent for the current target is as good a viewpoint as
        its best one now, within ``retarget_hysteresis``: then it stays, instead of the
        goal hopping between two near-equal viewpoints at every plan (each hop a new
        goal, and the robot stops to start it).  It must still be one of the frontier's
        approach cells (near enough to it, and roomy where those are asked for)."""
        strategy = self.strategy
        assert strategy is not None
        r, c = view.cell_of(*old_goal)
        f = current.frontier
        if not np.any((f.approach_rows == r) & (f.approach_cols == c)):
            return False
        old = strategy.viewpoint_utility(fs, view, robot, old_goal)
        new = strategy.viewpoint_utility(fs, view, robot, current.goal)
        if old is None or new is None or old <= 0.0:
            return False
        return not strategy.better(new, old, self.params.retarget_hysteresis)

    def goal_finished(self, status: str, reason: str, now: float) -> None:
        """The navigator ended the goal: ``status`` SUCCEEDED / FAILED / CANCELED."""
        pursuit = self._pursuit
        if pursuit is None:
            return
        if status == "SUCCEEDED":
            self.stats.goals_succeeded += 1
            self._arrivals.append(_Arrival(pursuit.points, pursuit.target.goal, now))
            self._pursuit = None
        elif status == "FAILED":
            self.stats.goals_failed += 1
            self._blacklist(pursuit.points, f"navigation failed: {reason}", now)
            self._pursuit = None

    def abandon(self, reason: str, now: float) -> None:
        """Blacklist the current target for ``reason`` (e.g. a mission-level watchdog)."""
        if self._pursuit is not None:
            self._blacklist(self._pursuit.points, reason, now)
            self._pursuit = None

    # --- internals ------------------------------------------------------------------------
    _blacklist_changed = False

    def _search(self, view: GridView, robot: tuple[float, float, float]) -> FrontierSet:
        p = self.params
        self._blacklist_changed = False
        fs = find_frontiers(view, (robot[0], robot[1]), min_frontier_size=p.min_frontier_size,
                            frontier_reach=p.frontier_reach,
                            start_search_radius=p.start_search_radius,
                            blacklist=self.blacklist.mask(view), wavefront=self._wavefront,
                            goal_clearance=p.goal_clearance or 0.0, goal_reach=p.goal_reach)
        self.last = fs
        return fs

    def _blacklist(self, points: FloatArray, reason: str, now: float,
                   blame: bool = True) -> None:
        entry = self.blacklist.add(points, reason, now, blame)
        self.stats.blacklisted += 1
        self._blacklist_changed = True
        self._log(now, f"blacklisted {entry.describe()}")

    def _start(self, target: Target, view: GridView, robot: tuple[float, float, float],
               now: float) -> None:
        self._pursuit = _Pursuit(target, target.frontier.points(view), now, target.distance,
                                 now, (robot[0], robot[1]), now, target.distance,
                                 target.gain)
        self.stats.goals_sent += 1

    def _watch(self, view: GridView, fs: FrontierSet, robot: tuple[float, float, float],
               now: float) -> str:
        """Progress / stuck / observed checks of the current pursuit; returns why it was
        given up ('' if it continues or there is none)."""
        pur = self._pursuit
        if pur is None:
            return ""
        p = self.params
        if not _still_frontier(view, fs, pur.points, p.frontier_reach):
            self._pursuit = None
            return "its frontier was observed"
        r, c = view.cell_of(*pur.target.goal)
        d = float(fs.distances[r, c]) if view.inside(r, c) else math.inf
        if d < pur.best_distance - 0.05:
            pur.best_distance, pur.last_progress = d, now
        if math.hypot(robot[0] - pur.anchor[0], robot[1] - pur.anchor[1]) >= p.stuck_distance:
            pur.anchor, pur.anchor_time = (robot[0], robot[1]), now
        blame = True
        if now - pur.last_progress > p.progress_timeout:
            reason = f"no progress toward it for {p.progress_timeout:.0f} s (progress_timeout)"
        elif now - pur.anchor_time > p.stuck_timeout:
            reason = (f"the robot moved less than {p.stuck_distance:.2f} m in "
                      f"{p.stuck_timeout:.0f} s (stuck or turning in place)")
            away = math.hypot(robot[0] - pur.target.goal[0], robot[1] - pur.target.goal[1])
            if away > p.stuck_blame_distance:  # wedged on the way: not the frontier's fault
                blame = False
                reason += f", {away:.1f} m from the goal"
        else:
            return ""
        self._blacklist(pur.points, reason, now, blame)
        self._pursuit = None
        return reason

    def _judge_arrivals(self, view: GridView, fs: FrontierSet, now: float) -> None:
        """Frontier cells still unknown near a goal reached ``arrival_settle_time`` ago
        cannot be observed from there: blacklist those cells (the rest of the frontier
        stays a candidate)."""
        keep = []
        radius = 2.0 * self.params.frontier_reach
        rows, cols = np.nonzero(fs.mask)
        pts = view.centres(rows, cols)
        for a in self._arrivals:
            if now - a.time < self.params.arrival_settle_time:
                keep.append(a)
                continue
            near = np.hypot(pts[:, 0] - a.goal[0], pts[:, 1] - a.goal[1]) <= radius
            if near.sum() >= 3:
                self._blacklist(pts[near], "its goal was reached but these cells stayed "
                                           "unknown (not observable from there)", now)
        self._arrivals = keep

    def _pending_mask(self, view: GridView) -> np.ndarray | None:
        if not self._arrivals:
            return None
        mask = np.zeros(view.shape, dtype=bool)
        for a in self._arrivals:
            _rasterize(mask, view, a.points)
        return dilate(mask, math.ceil(self.params.frontier_reach / view.resolution))

    def _current_in(self, ranked: list[Target], view: GridView) -> Target | None:
        pur = self._pursuit
        if pur is None:
            return None
        mask = np.zeros(view.shape, dtype=bool)
        _rasterize(mask, view, pur.points)
        mask = dilate(mask, 2)
        for t in ranked:
            if mask[t.frontier.rows, t.frontier.cols].any():
                return t
        return None

    def _done_reason(self, fs: FrontierSet) -> str:
        parts = ["no reachable frontier left"]
        if fs.unreachable:
            items = "; ".join(
                f"{f.size_m:.2f} m at ({f.centroid[0]:.2f}, {f.centroid[1]:.2f})"
                for f in fs.unreachable)
            parts.append(f"{len(fs.unreachable)} unreachable (no traversable path: "
                         f"behind an opening narrower than the robot): {items}")
        bl = self.blacklist.describe()
        if bl:
            parts.append(f"{len(bl)} blacklisted: " + "; ".join(bl))
        return "; ".join(parts)


def _rasterize(mask: np.ndarray, view: GridView, points: FloatArray) -> None:
    rows = np.floor((points[:, 1] - view.origin_y) / view.resolution).astype(np.int64)
    cols = np.floor((points[:, 0] - view.origin_x) / view.resolution).astype(np.int64)
    h, w = view.shape
    ok = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
    mask[rows[ok], cols[ok]] = True


def _still_frontier(view: GridView, fs: FrontierSet, points: FloatArray,
                    reach: float) -> bool:
    """Whether frontier cells (after the blacklist) remain near ``points``."""
    mask = np.zeros(view.shape, dtype=bool)
    _rasterize(mask, view, points)
    mask = dilate(mask, max(1, math.ceil(reach / view.resolution / 2)))
    return bool((mask & fs.mask).sum() >= 3)


def _covers(pending: np.ndarray | None, view: GridView, f: Frontier) -> bool:
    if pending is None:
        return False
    return bool(pending[f.rows, f.cols].mean() > 0.5)


def _near(a: tuple[float, float], b: tuple[float, float], tol: float) -> bool:
    return math.hypot(a[0] - b[0], a[1] - b[1]) <= tol
