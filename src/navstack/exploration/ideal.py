"""An idealised explorer on a known true world: the exploration benchmark's reference.

The robot is a point that drives at ``speed`` along shortest grid paths and turns
instantly, localisation is perfect, and its lidar (``beams`` rays of ``sensor_range``
every ``1 / rate_hz`` s, as the real one) marks every cell a ray passes as observed.
Which frontier it drives to is decided either greedily -- the frontier nearest by path,
to its nearest approach cell (Yamauchi 1997's strategy, the reference the exploration
benchmark compares against) -- or by a :class:`~navstack.exploration.explorer.
FrontierExplorer` (its decisions then run without a navigation stack, which tests the
decision loop in seconds).

:func:`reachable_free_space` is the benchmark's ground truth of what exploration should
observe.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from navstack.exploration.explorer import DecisionKind, FrontierExplorer
from navstack.exploration.grid_view import BoolArray, FloatArray, GridView
from navstack.exploration.params import ExploreParams
from navstack.exploration.wavefront import Wavefront

__all__ = ["IdealResult", "IdealRobot", "observe", "reachable_free_space", "run_ideal"]


@nb.njit(cache=True)
def _observe_kernel(occupied: NDArray[np.bool_], observed: NDArray[np.bool_], r0: float,
                    c0: float, range_cells: float, beams: int) -> int:
    h, w = occupied.shape
    steps = math.ceil(range_cells * 4.0)
    new = 0
    for b in range(beams):
        a = 2.0 * math.pi * b / beams
        dr = math.sin(a) * 0.25
        dc = math.cos(a) * 0.25
        for s in range(steps + 1):
            r = math.floor(r0 + dr * s)
            c = math.floor(c0 + dc * s)
            if r < 0 or r >= h or c < 0 or c >= w:
                break
            if not observed[r, c]:
                observed[r, c] = True
                new += 1
            if occupied[r, c]:
                break
    return new


def observe(occupied: BoolArray, observed: BoolArray, x: float, y: float, resolution: float,
            origin_x: float, origin_y: float, sensor_range: float, beams: int = 360) -> int:
    """Mark in ``observed`` the cells the rays from ``(x, y)`` pass through, up to and
    including the first occupied cell; returns how many were new."""
    return int(_observe_kernel(occupied, observed, (y - origin_y) / resolution,
                               (x - origin_x) / resolution, sensor_range / resolution, beams))


def reachable_free_space(occupied: BoolArray, resolution: float, origin_x: float,
                         origin_y: float, spawn_xy: tuple[float, float], half_width: float,
                         sensor_range: float) -> BoolArray:
    """Free cells exploration should observe: those of the spawn's free region within
    ``sensor_range`` of a cell where the robot fits (clearance > ``half_width``) and that
    is connected to the spawn through such cells."""
    free = ~occupied
    clearance = ndimage.distance_transform_edt(free, sampling=resolution)
    r = math.floor((spawn_xy[1] - origin_y) / resolution)
    c = math.floor((spawn_xy[0] - origin_x) / resolution)
    fits, _ = ndimage.label(clearance > half_width)
    if fits[r, c] == 0:  # spawned in a tight spot: start from the nearest roomy cell
        rr, cc = np.nonzero(fits)
        k = int(np.argmin((rr - r) ** 2 + (cc - c) ** 2))
        r, c = int(rr[k]), int(cc[k])
    reach = fits == fits[r, c]
    near = ndimage.distance_transform_edt(~reach, sampling=resolution) <= sensor_range
    region, _ = ndimage.label(free, structure=np.ones((3, 3), bool))
    return np.asarray(near & (region == region[r, c]))


@dataclass(frozen=True)
class IdealRobot:
    """What the idealised robot can do (the real robot's lidar and top speed)."""

    speed: float = 0.26
    sensor_range: float = 3.5
    beams: int = 360
    rate_hz: float = 5.0
    inscribed_radius: float = 0.2
    """Where the robot centre may go: farther than this from an observed obstacle."""
    min_frontier_size: float = 0.5
    replan_period: float = 1.0


@dataclass
class IdealResult:
    """Trace of an idealised run: times and observed fractions of ``target``."""

    times: list[float] = field(default_factory=list)
    fractions: list[float] = field(default_factory=list)
    path_length: float = 0.0
    duration: float = 0.0
    finished: bool = False
    reason: str = ""
    trajectory: list[tuple[float, float]] = field(default_factory=list)

    def time_to(self, fraction: float) -> float:
        """First time [s] the observed fraction reached ``fraction`` (inf if never)."""
        for t, f in zip(self.times, self.fractions, strict=True):
            if f >= fraction - 1e-12:
                return t
        return math.inf


def run_ideal(occupied: BoolArray, resolution: float, origin_x: float, origin_y: float,
              spawn_xy: tuple[float, float], robot: IdealRobot | None = None,
              target: BoolArray | None = None, explorer: FrontierExplorer | None = None,
              max_time: float = 7200.0) -> IdealResult:
    """Explore the true world ``occupied`` from ``spawn_xy`` (module docstring).

    ``target``: the cells whose observed fraction is traced (default: all free cells).
    ``explorer``: decide with it instead of greedy nearest-frontier.
    """
    rb = robot or IdealRobot()
    if explorer is None:  # the greedy nearest-frontier reference
        explorer = FrontierExplorer(ExploreParams(
            strategy="nearest", min_frontier_size=rb.min_frontier_size,
            planner_frequency=1.0 / rb.replan_period, sensor_range=rb.sensor_range))
    observed = np.zeros_like(occupied, dtype=bool)
    goal_cells = target if target is not None else ~occupied
    total = max(int(goal_cells.sum()), 1)
    res = IdealResult()
    wf = Wavefront()
    x, y = spawn_xy
    t = 0.0
    dt = 1.0 / rb.rate_hz
    step = rb.speed * dt

    def sense() -> None:
        observe(occupied, observed, x, y, resolution, origin_x, origin_y, rb.sensor_range,
                rb.beams)
        res.times.append(t)
        res.fractions.append(float((observed & goal_cells).sum()) / total)
        res.trajectory.append((x, y))

    sense()
    goal: tuple[int, int] | None = None
    path: FloatArray = np.zeros((0, 2))
    next_plan = 0.0
    while t < max_time:
        if t >= next_plan or len(path) == 0:
            view = GridView.from_truth(occupied, observed, resolution, origin_x, origin_y,
                                       rb.inscribed_radius)
            decision = explorer.plan(view, (x, y, 0.0), t)
            if decision.kind is DecisionKind.DONE:
                res.finished, res.reason = True, decision.reason
                break
            if decision.kind is DecisionKind.SEND and decision.target is not None:
                goal = view.cell_of(*decision.target.goal)
            elif decision.kind is DecisionKind.WAIT:
                goal = None
            path = np.zeros((0, 2))
            if goal is not None:
                r, c = view.cell_of(x, y)
                dist, start, _ = wf.distances_from_any(view.traversable, (r, c), resolution,
                                                       1.0 / resolution)
                if start is not None and math.isfinite(dist[goal]):
                    cells = wf.path_to(goal)
                    path = view.centres(cells[:, 0], cells[:, 1])
                    path = np.vstack(([[x, y]], path))
                else:
                    explorer.goal_finished("FAILED", "no path", t)
            next_plan = t + rb.replan_period
        if len(path) <= 1:
            if goal is not None:
                explorer.goal_finished("SUCCEEDED", "", t)
                goal = None
            t += dt
            sense()
            path = np.zeros((0, 2))
            continue
        # advance `step` metres along the path
        remaining = step
        while remaining > 1e-12 and len(path) > 1:
            seg = path[1] - np.array([x, y])
            d = float(np.hypot(*seg))
            if d <= remaining:
                x, y = float(path[1, 0]), float(path[1, 1])
                res.path_length += d
                remaining -= d
                path = path[1:]
            else:
                x += float(seg[0]) * remaining / d
                y += float(seg[1]) * remaining / d
                res.path_length += remaining
                remaining = 0.0
        t += dt
        sense()
    res.duration = t
    return res
