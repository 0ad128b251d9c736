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
* :func:`first_footprint_collision`: the first pose whose footprint, grown by a tracking
  ``margin``, covers a ``LETHAL_OBSTACLE`` cell (poses within ``skip_start`` of the start
  and ``skip_goal`` of the goal are not judged: the robot is already there, or turns in
  place onto the goal heading there);
* :func:`plan_footprint_checked`: plan; while the path has such a pose, mark a disc of
  ``block_radius`` around it LETHAL in a copy of the costmap and plan again (up to
  ``replans`` times).  The first collision-free path is returned; if none is found (the
  goal lies beyond the only gap) the planner's own first path is, so the check never
  turns a reachable goal into a failure.
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

__all__ = ["FootprintCheckResult", "densify", "first_footprint_collision", "path_headings",
           "plan_footprint_checked"]


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


def first_footprint_collision(costmap: Costmap2D, xy: FloatArray, footprint: Footprint,
                              margin: float, window: float, skip_start: float,
                              skip_goal: float, shift: float = 0.0
                              ) -> tuple[float, float] | None:
    """The first point (x, y) of the path ``xy`` ``(N, 2)`` (densified to half a cell)
    where ``footprint`` grown by ``margin`` and turned to :func:`path_headings` covers a
    lethal cell and still does when moved sideways by any offset up to ``shift`` (in
    half-cell steps): a gap too narrow for the body, not a path that merely hugs an
    obstacle the follower can keep off (module docstring); None if there is none."""
    if len(xy) == 0:
        return None
    xy = densify(xy, 0.5 * costmap.resolution)
    d_start = np.hypot(xy[:, 0] - xy[0, 0], xy[:, 1] - xy[0, 1])
    d_goal = np.hypot(xy[:, 0] - xy[-1, 0], xy[:, 1] - xy[-1, 1])
    judged = np.nonzero((d_start > skip_start) & (d_goal > skip_goal))[0]
    if len(judged) == 0:
        return None
    body = Footprint.from_polygon(footprint.polygon, padding=margin) if margin > 0 \
        else footprint
    theta = path_headings(xy, window)[judged]
    poses = np.column_stack((xy[judged], theta))
    hit = np.nonzero(footprint_costs(costmap, poses, body) == LETHAL_OBSTACLE)[0]
    if len(hit) == 0:
        return None
    n = max(1, math.ceil(shift / (0.5 * costmap.resolution)))
    offsets = np.linspace(-shift, shift, 2 * n + 1) if shift > 0 else np.zeros(1)
    th = poses[hit, 2][:, None]
    shifted = np.stack((poses[hit, 0][:, None] - offsets * np.sin(th),
                        poses[hit, 1][:, None] + offsets * np.cos(th),
                        np.broadcast_to(th, (len(hit), len(offsets)))), axis=-1)
    cost = footprint_costs(costmap, np.ascontiguousarray(shifted.reshape(-1, 3)), body)
    stuck = np.nonzero(np.all(cost.reshape(len(hit), len(offsets)) == LETHAL_OBSTACLE,
                              axis=1))[0]
    if len(stuck) == 0:
        return None
    k = int(judged[hit[stuck[0]]])
    return float(xy[k, 0]), float(xy[k, 1])


@dataclass
class FootprintCheckResult:
    """What :func:`plan_footprint_checked` did: the path, how many plans it took, the
    blocked points (x, y) and whether the returned path passed the check."""

    path: Path
    plans: int
    blocked: list[tuple[float, float]] = field(default_factory=list)
    clear: bool = True


def plan_footprint_checked(plan: Callable[[Costmap2D], Path], costmap: Costmap2D,
                           footprint: Footprint, margin: float = 0.05,
                           replans: int = 8, block_radius: float = 0.1,
                           window: float = 0.15, skip_start: float = 0.15,
                           skip_goal: float = 0.25, shift: float = 0.15
                           ) -> FootprintCheckResult:
    """``plan(costmap)``, then replan around the points where the oriented footprint does
    not fit (module docstring).  Errors of the first plan propagate; a replan that fails
    ends the search (the first path is returned)."""
    first = plan(costmap)
    path = first
    work: Costmap2D | None = None
    blocked: list[tuple[float, float]] = []
    for k in range(replans + 1):
        xy = np.ascontiguousarray(path.as_array()[:, :2])
        # judged on the real costmap: the blocked discs are not obstacles for the body
        hit = first_footprint_collision(costmap, xy, footprint, margin, window, skip_start,
                                        skip_goal, shift)
        if hit is None:
            return FootprintCheckResult(path, k + 1, blocked, True)
        if k == replans:
            break
        # the disc must leave the start and goal cells free (the planner would refuse)
        x, y = hit
        clear = min(math.hypot(x - e[0], y - e[1]) for e in (xy[0], xy[-1]))
        radius = min(block_radius, clear - 2.0 * costmap.resolution)
        if radius < costmap.resolution:
            break
        if work is None:
            work = costmap.copy()
        _block_disc(work, x, y, radius)
        blocked.append((x, y))
        try:
            path = plan(work)
        except PlannerError:
            break
    return FootprintCheckResult(first, len(blocked) + 1, blocked, False)


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
