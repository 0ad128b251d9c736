"""Oriented-footprint check of a grid planner's path, with replanning around the gaps the
body does not fit (the planner server's ``footprint_check``).

NavFn and Smac 2D plan a point: a cell is blocked only within the footprint's inscribed
radius of an obstacle (Nav2's ``INSCRIBED_INFLATED_OBSTACLE``).  For a body whose axle is
not centred that radius is far smaller than the half-width -- the TurtleBot3 Waffle Pi's
base_link sits 0.076 m behind its front edge, 0.153 m from its sides and 0.205 m ahead of
its rear -- so the planner routes through gaps between a wall end and a package's
virtual obstacle that the 0.306 m wide body passes only when tracked to the centimetre,
and Regulated Pure Pursuit then stops at the gap ("collision ahead") through every
recovery.  Nav2's answer for such robots is a planner that checks the oriented footprint
(Smac Hybrid-A* / State Lattice, "non-circular robots" in its tuning guide); this is the
cheap form of it for the grid planners:

* :func:`path_headings`: the heading the robot has along the path (the chord over
  ``+-window`` metres, what a pure-pursuit follower drives);
* :func:`footprint_misfits`: the poses whose footprint, grown by a tracking ``margin``,
  covers a ``LETHAL_OBSTACLE`` cell (poses within ``skip_start`` of the start and
  ``skip_goal`` of the goal are not judged: the robot is already there, or turns in place
  onto the goal heading there), each with the smallest sideways shift (up to ``shift``)
  that fits -- none for a *gap* too narrow for the body, one for a path that *hugs* an
  obstacle (pure pursuit cuts such a curve towards the obstacle);
  :func:`first_footprint_collision` is the first gap;
* :func:`plan_footprint_checked`: plan; while the path has a gap, mark a disc of
  ``block_radius`` around its first one LETHAL in a copy of the costmap and plan again;
  once it has none, push it off the obstacles it hugs (a disc on the obstacle's side of
  each hug, reaching past the shift that fits; the copy is not re-inflated, so the
  planner skirts the disc itself) and plan again -- up to ``replans``
  times in all.  The first path that fits everywhere is returned, else the first
  without gaps, else the planner's own first path (the goal lies beyond the only gap):
  the check never turns a reachable goal into a failure.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import PlannerError
from navstack.core.msgs import Path
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from navstack.costmap.footprint import footprint_costs

FloatArray = NDArray[np.float64]

__all__ = ["FootprintCheckResult", "Misfit", "densify", "first_footprint_collision",
           "footprint_misfits", "path_headings", "plan_footprint_checked"]


def path_headings(xy: FloatArray, window: float) -> FloatArray:
    """Heading at each point of a path ``(N, 2)``: the direction of the chord from the
    point ``window`` metres back to the point ``window`` metres ahead (clipped to the
    ends); 0 for a single point."""
    n = len(xy)
    if n < 2:
        return np.zeros(n)
    seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
    s = np.concatenate(([0.0], np.cumsum(seg)))
    back = np.clip(np.searchsorted(s, s - window, side="left"), 0, n - 1)
    ahead = np.clip(np.searchsorted(s, s + window, side="right") - 1, 0, n - 1)
    # a chord of zero length (repeated points): fall back to the whole path's direction
    same = ahead == back
    ahead[same] = n - 1
    back[same] = 0
    d = xy[ahead] - xy[back]
    return np.arctan2(d[:, 1], d[:, 0])


def densify(xy: FloatArray, step: float) -> FloatArray:
    """The polyline ``xy`` ``(N, 2)`` with points inserted so that none are more than
    ``step`` apart (a planner's path may be sparse: NavFn's gradient path keeps a point
    every few cells)."""
    if len(xy) < 2:
        return xy
    seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
    parts = [xy[:1]]
    for i, length in enumerate(seg):
        k = max(1, math.ceil(length / step))
        t = np.arange(1, k + 1)[:, None] / k
        parts.append(xy[i] + t * (xy[i + 1] - xy[i]))
    return np.vstack(parts)


@dataclass(frozen=True)
class Misfit:
    """A path pose (x, y, theta) where the grown footprint covers a lethal cell;
    ``shift`` is the smallest sideways shift (positive to the left) at which it fits, None
    if none up to the limit does (a gap)."""

    x: float
    y: float
    theta: float
    shift: float | None


def footprint_misfits(costmap: Costmap2D, xy: FloatArray, footprint: Footprint,
                      margin: float, window: float, skip_start: float, skip_goal: float,
                      shift: float = 0.0) -> list[Misfit]:
    """The misfits of the path ``xy`` ``(N, 2)`` (densified to half a cell) in path order:
    poses where ``footprint`` grown by ``margin`` and turned to :func:`path_headings`
    covers a lethal cell, with the smallest sideways shift in half-cell steps up to
    ``shift`` that fits (module docstring)."""
    if len(xy) == 0:
        return []
    xy = densify(xy, 0.5 * costmap.resolution)
    d_start = np.hypot(xy[:, 0] - xy[0, 0], xy[:, 1] - xy[0, 1])
    d_goal = np.hypot(xy[:, 0] - xy[-1, 0], xy[:, 1] - xy[-1, 1])
    judged = np.nonzero((d_start > skip_start) & (d_goal > skip_goal))[0]
    if len(judged) == 0:
        return []
    body = Footprint.from_polygon(footprint.polygon, padding=margin) if margin > 0 \
        else footprint
    theta = path_headings(xy, window)[judged]
    poses = np.column_stack((xy[judged], theta))
    hit = np.nonzero(footprint_costs(costmap, poses, body) == LETHAL_OBSTACLE)[0]
    if len(hit) == 0:
        return []
    n = max(1, math.ceil(shift / (0.5 * costmap.resolution)))
    offsets = np.linspace(-shift, shift, 2 * n + 1) if shift > 0 else np.zeros(1)
    th = poses[hit, 2][:, None]
    shifted = np.stack((poses[hit, 0][:, None] - offsets * np.sin(th),
                        poses[hit, 1][:, None] + offsets * np.cos(th),
                        np.broadcast_to(th, (len(hit), len(offsets)))), axis=-1)
    cost = footprint_costs(costmap, np.ascontiguousarray(shifted.reshape(-1, 3)), body)
    fits = cost.reshape(len(hit), len(offsets)) != LETHAL_OBSTACLE
    out = []
    for i, k in enumerate(hit):
        ok = offsets[fits[i]]
        best = float(ok[np.argmin(np.abs(ok))]) if len(ok) else None
        out.append(Misfit(float(poses[k, 0]), float(poses[k, 1]), float(poses[k, 2]), best))
    return out


def first_footprint_collision(costmap: Costmap2D, xy: FloatArray, footprint: Footprint,
                              margin: float, window: float, skip_start: float,
                              skip_goal: float, shift: float = 0.0
                              ) -> tuple[float, float] | None:
    """The first gap (x, y) of :func:`footprint_misfits`: a pose where no sideways shift
    up to ``shift`` fits either; None if there is none."""
    for m in footprint_misfits(costmap, xy, footprint, margin, window, skip_start,
                               skip_goal, shift):
        if m.shift is None:
            return m.x, m.y
    return None


@dataclass
class FootprintCheckResult:
    """What :func:`plan_footprint_checked` did: the path, how many plans it took, the
    centres of the discs it marked (blocks and pushes), whether the returned path fits
    everywhere (``clear``), whether it has no gap (``gap_free``) and whether it is not the
    planner's first path (``replaced``)."""

    path: Path
    plans: int
    blocked: list[tuple[float, float]] = field(default_factory=list)
    clear: bool = True
    gap_free: bool = True
    replaced: bool = False


def plan_footprint_checked(plan: Callable[[Costmap2D], Path], costmap: Costmap2D,
                           footprint: Footprint, margin: float = 0.05,
                           replans: int = 8, block_radius: float = 0.1,
                           window: float = 0.15, skip_start: float = 0.15,
                           skip_goal: float = 0.25, shift: float = 0.15,
                           push_spacing: float = 0.1) -> FootprintCheckResult:
    """``plan(costmap)``, then replan around the gaps the oriented footprint does not fit
    and off the obstacles it hugs (module docstring).  Errors of the first plan
    propagate; a replan that fails ends the search."""
    first = plan(costmap)
    path = first
    gap_free: Path | None = None
    work: Costmap2D | None = None
    blocked: list[tuple[float, float]] = []
    plans = 1
    for k in range(replans + 1):
        xy = np.ascontiguousarray(path.as_array()[:, :2])
        # judged on the real costmap: the discs are not obstacles for the body
        misfits = footprint_misfits(costmap, xy, footprint, margin, window, skip_start,
                                    skip_goal, shift)
        if not misfits:
            return FootprintCheckResult(path, plans, blocked, True, True, path is not first)
        gaps = [m for m in misfits if m.shift is None]
        if not gaps and gap_free is None:
            gap_free = path
        if k == replans:
            break
        discs = (_gap_disc(gaps[0], xy, costmap, block_radius) if gaps else
                 _push_discs(misfits, xy, costmap, block_radius, push_spacing))
        discs = [d for d in discs
                 if all(math.hypot(d[0] - bx, d[1] - by) > 0.25 * costmap.resolution
                        for bx, by in blocked)]
        if not discs:
            break  # nothing new to mark: the search cannot do better
        if work is None:
            work = costmap.copy()
        for x, y, r in discs:
            _block_disc(work, x, y, r)
            blocked.append((x, y))
        try:
            path = plan(work)
        except PlannerError:
            break
        plans += 1
    if gap_free is not None:
        return FootprintCheckResult(gap_free, plans, blocked, False, True,
                                    gap_free is not first)
    return FootprintCheckResult(first, plans, blocked, False, False, False)


def _room(x: float, y: float, xy: FloatArray, costmap: Costmap2D) -> float:
    """Distance from (x, y) to the nearer end of the path, less two cells: a disc must
    leave the start and goal cells free (the planner would refuse them)."""
    return min(math.hypot(x - e[0], y - e[1]) for e in (xy[0], xy[-1])) \
        - 2.0 * costmap.resolution


def _gap_disc(gap: Misfit, xy: FloatArray, costmap: Costmap2D,
              block_radius: float) -> list[tuple[float, float, float]]:
    """The disc that closes a gap: on the path point, as large as the ends allow."""
    radius = min(block_radius, _room(gap.x, gap.y, xy, costmap))
    return [] if radius < costmap.resolution else [(gap.x, gap.y, radius)]


def _push_discs(hugs: list[Misfit], xy: FloatArray, costmap: Costmap2D, radius: float,
                spacing: float) -> list[tuple[float, float, float]]:
    """Discs on the obstacle's side of the hugs (at least ``spacing`` apart along the
    path), each reaching a cell past the shifted pose that fits, so that the replanned
    path passes there or farther out."""
    out: list[tuple[float, float, float]] = []
    last: tuple[float, float] | None = None
    for m in hugs:
        if m.shift is None or m.shift == 0.0:
            continue
        if last is not None and math.hypot(m.x - last[0], m.y - last[1]) < spacing:
            continue
        # the disc's edge a cell beyond the shift that fits (the copy is not re-inflated:
        # the planner skirts the disc's own cells, by whole cells)
        side = math.copysign(1.0, m.shift)
        off = m.shift + side * (costmap.resolution - radius)
        x = m.x - off * math.sin(m.theta)
        y = m.y + off * math.cos(m.theta)
        if _room(x, y, xy, costmap) < radius:
            continue
        out.append((x, y, radius))
        last = (m.x, m.y)
    return out


def _block_disc(costmap: Costmap2D, x: float, y: float, radius: float) -> None:
    """Mark every cell whose centre lies within ``radius`` of (x, y) LETHAL."""
    res = costmap.resolution
    cx = (x - costmap.origin_x) / res
    cy = (y - costmap.origin_y) / res
    r = radius / res
    x0, x1 = max(0, math.floor(cx - r)), min(costmap.size_x, math.ceil(cx + r) + 1)
    y0, y1 = max(0, math.floor(cy - r)), min(costmap.size_y, math.ceil(cy + r) + 1)
    if x0 >= x1 or y0 >= y1:
        return
    gx, gy = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
    inside = np.hypot(gx - cx, gy - cy) <= max(r, 0.5)
    costmap.data[y0:y1, x0:x1][inside] = LETHAL_OBSTACLE
