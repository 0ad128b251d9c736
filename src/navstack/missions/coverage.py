"""Coverage search of a known map: the TurtleBot course's package search, as a mission.

``PlanCoverage`` splits the free space of ``/map`` into ``cell_size`` cells kept by the
free-box filter (:func:`~navstack.exploration.coverage.coverage_cells`), moves each
centre to the nearest point where the robot can turn round (``turning_radius`` from
every mapped obstacle, and traversable in the global costmap) within ``snap_radius`` --
the course's +-3-cell box is narrower than a TurtleBot, so a centre 0.16 m from a wall
passes it but cannot take the robot at an arbitrary heading -- (cells with none are
reported unreachable), and orders the visits by
path distance from the robot: nearest neighbour + 2-opt on the closed tour home.
``VisitCells`` drives to each in turn facing one common ``heading`` (the camera looks the
same way everywhere; default: the heading at the start), retries a failed cell once at
the end, and stops early when ``stop_when`` fires (the perception issue's "target seen").
A cell counts as visited when the robot is inside its square, even if the final turn to
the heading failed.  Then the robot returns home, and the
mission fails if any reachable cell was missed, naming each with the reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from py_trees.common import Status
from py_trees.composites import Sequence
from pydantic import Field
from scipy import ndimage

from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.core.params import Params
from navstack.exploration.coverage import (
    coverage_cells,
    order_visits,
    path_distances,
    tour_length,
)
from navstack.exploration.grid_view import GridView
from navstack.exploration.wavefront import nearest_cell
from navstack.missions.behaviours import (
    MissionBehaviour,
    NavigateToPose,
    RememberHome,
    ReturnHome,
)
from navstack.missions.context import MissionContext
from navstack.missions.explore import wait_for_map
from navstack.missions.mission import Mission
from navstack.runtime.bus import LATCHED

__all__ = ["CoverageParams", "CoveragePlan", "PlanCoverage", "VisitCells", "coverage_mission"]

StopCondition = Callable[[], str | None]
"""Returns a description when the search should stop early (e.g. "target seen at ...")."""


class CoverageParams(Params):
    """The course's coverage search: 0.8 m cells, +-3 map cells free around the centre."""

    cell_size: float = Field(0.8, gt=0.0)
    free_box_cells: int = Field(3, ge=0)
    heading: float | None = None
    """Common facing direction [rad, map frame]; None: the robot's heading at the start."""
    map_topic: str = "/map"
    costmap_topic: str = "/global_costmap/costmap"
    free_threshold: int = Field(25, ge=0, le=100)
    """A ``/map`` cell is free when its value is 0..free_threshold (unknown is not)."""
    lethal_threshold: int = Field(99, ge=1, le=100)
    snap_margin: float = Field(0.15, ge=0.0)
    """A cell's goal may move from its centre as far as stays this far [m] inside the
    cell's square (the goal tolerance): the robot arriving there is in the cell."""
    turning_radius: float = Field(0.3, ge=0.0)
    """Clearance [m] from mapped obstacles a goal needs so the robot can turn there (the
    footprint's circumscribed radius; the mission catalog passes the robot's)."""
    settle_time: float = Field(5.0, gt=0.0)
    return_home: bool = True


@dataclass
class CoveragePlan:
    """Cells to visit (in order), and those no path reaches."""

    cells: list[tuple[float, float]]
    """Goals, in visiting order (a centre, or the nearest point to turn round)."""
    centres: list[tuple[float, float]]
    """The cells' centres, in the same order."""
    unreachable: list[tuple[float, float]]
    tour_length: float
    all_cells: int


def plan_coverage(grid: OccupancyGrid, costmap: OccupancyGrid | None, robot: Pose2D,
                  p: CoverageParams) -> CoveragePlan:
    """The coverage plan on ``grid`` (/map) and ``costmap`` (where the robot can stand)."""
    info = grid.info
    data = np.asarray(grid.data, dtype=np.int16).reshape(info.height, info.width)
    free = (data >= 0) & (data <= p.free_threshold)
    o = info.origin.position
    centres = coverage_cells(free, info.resolution, o.x, o.y, p.cell_size, p.free_box_cells)
    view = (GridView.from_occupancy(costmap, lethal_threshold=p.lethal_threshold)
            if costmap is not None else GridView.from_occupancy(grid, inflate_radius=0.2))
    res = view.resolution
    # where the robot can turn: traversable, and turning_radius from every mapped obstacle
    occupied = (data >= 65) | (data < 0)
    clearance = ndimage.distance_transform_edt(~occupied, sampling=info.resolution)
    rows, cols = np.nonzero(view.traversable)
    xy = view.centres(rows, cols)
    gr = np.floor((xy[:, 1] - o.y) / info.resolution).astype(np.int64)
    gc = np.floor((xy[:, 0] - o.x) / info.resolution).astype(np.int64)
    inside = (gr >= 0) & (gr < info.height) & (gc >= 0) & (gc < info.width)
    roomy = np.zeros(len(xy), dtype=bool)
    roomy[inside] = clearance[gr[inside], gc[inside]] >= p.turning_radius
    turnable = np.zeros(view.shape, dtype=bool)
    turnable[rows[roomy], cols[roomy]] = True
    snapped: list[tuple[float, float]] = []
    kept: list[tuple[float, float]] = []
    unreachable: list[tuple[float, float]] = []
    k = max(0, math.floor((p.cell_size / 2 - p.snap_margin) / res))
    for x, y in centres:
        r, c = view.cell_of(x, y)
        window = np.zeros_like(turnable)
        window[max(0, r - k):r + k + 1, max(0, c - k):c + k + 1] = True
        cell = nearest_cell(turnable & window, r, c)
        if cell is None:
            unreachable.append((float(x), float(y)))
            continue
        kept.append((float(x), float(y)))
        snapped.append(view.centre_of(*cell) if cell != (r, c) else (float(x), float(y)))
    pts = np.array([(robot.x, robot.y), *snapped]).reshape(-1, 2)
    dist = path_distances(view.traversable, res, view.origin_x, view.origin_y, pts,
                          snap_radius=1.0)
    order = order_visits(dist, 0)
    reached = set(order)
    unreachable += [kept[i - 1] for i in range(1, len(pts)) if i not in reached]
    length = tour_length(dist, [0, *order])
    return CoveragePlan([snapped[i - 1] for i in order], [kept[i - 1] for i in order],
                        unreachable, length, len(centres))


class PlanCoverage(MissionBehaviour):
    """Compute the plan once the map and costmap are there (module docstring)."""

    def __init__(self, ctx: MissionContext, params: CoverageParams,
                 name: str = "PlanCoverage") -> None:
        super().__init__(ctx, name)
        self.params = params

    def update(self) -> Status:
        p = self.params
        grid = self.ctx.latest(p.map_topic, OccupancyGrid, LATCHED)
        costmap = self.ctx.latest(p.costmap_topic, OccupancyGrid)
        pose = self.ctx.robot_pose()
        if grid is None or costmap is None or pose is None:
            return Status.RUNNING
        plan = plan_coverage(grid, costmap, pose, p)
        if not plan.cells:
            return self.failed(f"no coverage cell to visit: {plan.all_cells} cells pass the "
                               f"free-box filter, {len(plan.unreachable)} unreachable")
        self.ctx.results["coverage_plan"] = plan
        self.ctx.log(f"{self.name}: {len(plan.cells)} cells of {p.cell_size} m to visit "
                     f"({plan.tour_length:.1f} m tour), {len(plan.unreachable)} unreachable")
        return Status.SUCCESS


@dataclass
class CellRecord:
    index: int
    xy: tuple[float, float]
    centre: tuple[float, float]
    status: str = "PENDING"
    reason: str = ""
    time: float = 0.0
    attempts: int = 0


@dataclass
class _Queue:
    order: list[int] = field(default_factory=list)
    retry: list[int] = field(default_factory=list)


class VisitCells(MissionBehaviour):
    """Visit the planned cells facing ``heading`` (module docstring)."""

    def __init__(self, ctx: MissionContext, params: CoverageParams,
                 stop_when: StopCondition | None = None, name: str = "VisitCells") -> None:
        super().__init__(ctx, name)
        self.params = params
        self.stop_when = stop_when
        self.records: list[CellRecord] = []
        self.current: CellRecord | None = None
        self.nav = NavigateToPose(ctx, self._goal, name="VisitCell")
        self._queue = _Queue()
        self._best = (math.inf, 0.0)
        self.stopped_early = ""

    def _heading(self) -> float:
        if self.params.heading is not None:
            return self.params.heading
        home = self.ctx.results.get("home")
        return home.theta if isinstance(home, Pose2D) else 0.0

    def _goal(self) -> Pose2D | None:
        if self.current is None:
            return None
        return Pose2D(self.current.xy[0], self.current.xy[1], self._heading())

    def initialise(self) -> None:
        plan = self.ctx.results.get("coverage_plan")
        pairs = list(zip(plan.cells, plan.centres, strict=True)) \
            if isinstance(plan, CoveragePlan) else []
        self.records = [CellRecord(i, xy, c) for i, (xy, c) in enumerate(pairs)]
        self._queue = _Queue(list(range(len(self.records))), [])
        self.current = None
        self.stopped_early = ""
        self.nav.stop(Status.INVALID)

    def _next(self) -> CellRecord | None:
        q = self._queue
        if q.order:
            return self.records[q.order.pop(0)]
        if q.retry:
            return self.records[q.retry.pop(0)]
        return None

    def update(self) -> Status:
        if self.stop_when is not None:
            fired = self.stop_when()
            if fired:
                self.nav.stop(Status.INVALID)
                self.stopped_early = fired
                self.ctx.results["coverage_stopped_early"] = fired
                self.ctx.log(f"{self.name}: stopping early: {fired}")
                return Status.SUCCESS
        if self.current is None:
            self.current = self._next()
            if self.current is None:
                return Status.SUCCESS
            self.current.attempts += 1
            self._best = (math.inf, self.ctx.now)
        self.nav.tick_once()
        rec = self.current
        pose = self.ctx.robot_pose()
        dist = (math.hypot(pose.x - rec.xy[0], pose.y - rec.xy[1]) if pose is not None
                else math.inf)
        inside = pose is not None and max(abs(pose.x - rec.centre[0]),
                                          abs(pose.y - rec.centre[1])) \
            <= self.params.cell_size / 2
        if dist < self._best[0] - 0.02:
            self._best = (dist, self.ctx.now)
        status = self.nav.status
        settled = (status is Status.RUNNING and inside
                   and self.ctx.now - self._best[1] >= self.params.settle_time)
        if status is Status.RUNNING and not settled:
            done = sum(r.status == "VISITED" for r in self.records)
            self.ctx.feedback(f"{self.name}: cell {done + 1}/{len(self.records)} at "
                              f"({rec.xy[0]:.1f}, {rec.xy[1]:.1f})",
                              visited=done, cells=len(self.records))
            return Status.RUNNING
        if settled:
            self.nav.stop(Status.INVALID)
        if (inside and status is not Status.RUNNING) or settled:
            rec.status, rec.time = "VISITED", self.ctx.now
            if self.ctx.failures and status is Status.FAILURE:
                self.ctx.failures.pop()  # reached it; only the final turn failed
        else:
            rec.reason = (self.ctx.failures.pop().reason if status is Status.FAILURE
                          and self.ctx.failures else f"stopped {dist:.2f} m away")
            if rec.attempts < 2:
                self._queue.retry.append(rec.index)
                self.ctx.log(f"{self.name}: cell at ({rec.xy[0]:.2f}, {rec.xy[1]:.2f}) "
                             f"failed ({rec.reason}); will retry at the end")
            else:
                rec.status = "MISSED"
                self.ctx.log(f"{self.name}: cell at ({rec.xy[0]:.2f}, {rec.xy[1]:.2f}) "
                             f"missed: {rec.reason}")
        self.current = None
        self.nav.stop(Status.INVALID)
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status is Status.INVALID:
            self.nav.stop(Status.INVALID)


class CheckCells(MissionBehaviour):
    """FAILURE naming every missed cell (after the robot went home)."""

    def __init__(self, ctx: MissionContext, visit: VisitCells, name: str = "CheckCells") -> None:
        super().__init__(ctx, name)
        self.visits = visit

    def update(self) -> Status:
        if self.visits.stopped_early:
            return Status.SUCCESS
        missed = [r for r in self.visits.records if r.status != "VISITED"]
        if missed:
            detail = "; ".join(f"({r.xy[0]:.2f}, {r.xy[1]:.2f}): {r.reason}" for r in missed)
            return self.failed(f"{len(missed)} of {len(self.visits.records)} cells not "
                               f"reached: {detail}")
        return Status.SUCCESS


def coverage_mission(ctx: MissionContext, params: CoverageParams | None = None,
                     stop_when: StopCondition | None = None,
                     home_tolerance: float = 0.3) -> Mission:
    """The course's coverage search (module docstring)."""
    p = params or CoverageParams()
    visit = VisitCells(ctx, p, stop_when)
    steps = [wait_for_map(ctx, p.map_topic), RememberHome(ctx), PlanCoverage(ctx, p), visit]
    if p.return_home:
        steps.append(ReturnHome(ctx, tolerance=home_tolerance))
    steps.append(CheckCells(ctx, visit))
    root = Sequence("coverage", memory=True, children=steps)

    def summary() -> dict[str, Any]:
        plan = ctx.results.get("coverage_plan")
        return {"coverage": {
            "cell_size": p.cell_size, "free_box_cells": p.free_box_cells,
            "heading": visit._heading(),
            "cells": [{"xy": list(r.xy), "centre": list(r.centre), "status": r.status,
                       "reason": r.reason,
                       "time": round(r.time, 2), "attempts": r.attempts}
                      for r in visit.records],
            "unreachable": [list(c) for c in plan.unreachable]
            if isinstance(plan, CoveragePlan) else [],
            "tour_length_m": plan.tour_length if isinstance(plan, CoveragePlan) else 0.0,
            "stopped_early": visit.stopped_early}}

    return Mission("coverage", root, ctx, "coverage search of the known map", summary)
