"""Collision lookahead of Regulated Pure Pursuit (Nav2 ``CollisionChecker``).

:meth:`RPPCollisionChecker.first_collision` projects the command ``(v, w)`` forward from
the robot pose with Nav2's Euler steps and returns the first projected pose in collision:

* the current pose is checked first;
* the time step is the time to cross one cell: ``resolution / |v|`` when driving, or, when
  rotating in place (``|v| < 0.01`` and ``|w| > 0.01``), the time for the footprint's
  farthest point (circumscribed radius ``r``) to move one cell,
  ``2 sin(resolution / 2 / r) / |w|``;
* steps ``j = 1, 2, ...`` are taken while ``j * dt < max_allowed_time_to_collision_up_to_carrot``,
  and stop before the first pose farther from the robot than the carrot;
* a pose is in collision when the footprint cost (or, without a footprint, the cell cost
  at the pose) is LETHAL.  A pose whose centre is off the costmap is not (Nav2 warns that
  the costmap is too small), and unknown space (255) is not (Nav2 with
  ``track_unknown_space``; without it a costmap has no unknown cells).

All projected poses are computed at once and costed in one numba call
(:func:`navstack.costmap.footprint.footprint_costs`).

:meth:`RPPCollisionChecker.first_collision_turning` (navstack addition) judges a turn in
place by the angle it must sweep rather than by ``(0, w)`` projected for a time: the
headings from the current one through ``angle``, one footprint step apart (the in-place
step above, ``2 sin(resolution / 2 / r)`` rad), and the final heading.  The verdict then
does not depend on the commanded ``w`` -- the time-based projection of a turn that a
wall blocks flickered between "free" and "collision" as ``w`` varied with the odometry,
so the controller neither turned nor failed (docs/decisions.md, "In-place turns judged
by their sweep").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D
from navstack.costmap.footprint import footprint_costs

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class CollisionHit:
    """The first projected pose in collision: ``pose`` (x, y, theta) in the costmap frame,
    ``time`` [s] after now (0 for the current pose) and its ``cost``."""

    pose: tuple[float, float, float]
    time: float
    cost: int


def project_arc(pose: Pose2D, linear_vel: float, angular_vel: float, dt: float,
                max_time: float, max_dist: float) -> FloatArray:
    """Nav2's forward-simulated poses ``(K, 3)`` at ``dt, 2 dt, ...`` (Euler steps), while
    ``j * dt < max_time`` and no farther than ``max_dist`` from the start."""
    if not (math.isfinite(dt) and dt > 0.0) or max_time <= 0.0:
        return np.zeros((0, 3))
    j = np.arange(1, math.ceil(max_time / dt) + 2, dtype=np.float64)
    j = j[j * dt < max_time]
    if len(j) == 0:
        return np.zeros((0, 3))
    theta_before = pose.theta + (j - 1.0) * dt * angular_vel  # heading during step j
    x = pose.x + np.cumsum(dt * linear_vel * np.cos(theta_before))
    y = pose.y + np.cumsum(dt * linear_vel * np.sin(theta_before))
    theta = pose.theta + j * dt * angular_vel
    far = np.nonzero(np.hypot(x - pose.x, y - pose.y) > max_dist)[0]
    k = int(far[0]) if len(far) else len(j)
    return np.column_stack((x[:k], y[:k], theta[:k]))


class RPPCollisionChecker:
    """Point or footprint collision checks of RPP (module docstring)."""

    def __init__(self, footprint: Footprint | None) -> None:
        self.footprint = footprint
        self.last_arc: FloatArray = np.zeros((0, 3))
        """Projected poses checked in the last call (Nav2's ``lookahead_collision_arc``)."""

    def costs(self, costmap: Costmap2D, poses: FloatArray) -> NDArray[np.int32]:
        """Footprint (or cell) cost of each pose ``(K, 3)``; -1 where the centre is off the
        map (never a collision)."""
        mx, my, inside = costmap.world_to_map_array(poses[:, :2])
        out = np.full(len(poses), -1, dtype=np.int32)
        if not inside.any():
            return out
        if self.footprint is None:
            out[inside] = costmap.data[my[inside], mx[inside]]
        else:
            out[inside] = footprint_costs(costmap, np.ascontiguousarray(poses[inside]),
                                          self.footprint)
        return out

    def time_step(self, costmap: Costmap2D, linear_vel: float, angular_vel: float) -> float:
        """Projection step [s] (module docstring); ``inf`` when the robot is at rest."""
        if abs(linear_vel) < 0.01 and abs(angular_vel) > 0.01:
            return self.turn_step(costmap) / abs(angular_vel)
        return costmap.resolution / abs(linear_vel) if linear_vel != 0.0 else math.inf

    def turn_step(self, costmap: Costmap2D) -> float:
        """Heading step [rad] of an in-place projection: the footprint's farthest point
        moves by about one cell (module docstring)."""
        r = costmap.resolution
        if self.footprint is not None:
            r = max(r, self.footprint.circumscribed_radius)
        return 2.0 * math.sin(costmap.resolution / 2.0 / r)

    def _first_lethal(self, costmap: Costmap2D, poses: FloatArray
                      ) -> tuple[int, CollisionHit] | None:
        """Index and hit of the first of ``poses`` in lethal cost (unknown is free)."""
        cost = self.costs(costmap, poses)
        hit = np.nonzero((cost >= LETHAL_OBSTACLE) & (cost != NO_INFORMATION))[0]
        if len(hit) == 0:
            return None
        k = int(hit[0])
        x, y, th = poses[k]
        return k, CollisionHit((float(x), float(y), float(th)), 0.0, int(cost[k]))

    def first_collision(self, costmap: Costmap2D, pose: Pose2D, linear_vel: float,
                        angular_vel: float, carrot_dist: float,
                        max_time: float) -> CollisionHit | None:
        """The first pose in collision on the projected arc, or None."""
        dt = self.time_step(costmap, linear_vel, angular_vel)
        arc = project_arc(pose, linear_vel, angular_vel, dt, max_time, carrot_dist)
        self.last_arc = arc
        poses = np.vstack(([pose.x, pose.y, pose.theta], arc))
        found = self._first_lethal(costmap, poses)
        if found is None:
            return None
        k, hit = found
        return replace(hit, time=k * dt if k else 0.0)

    def first_collision_turning(self, costmap: Costmap2D, pose: Pose2D,
                                angle: float) -> tuple[float, CollisionHit] | None:
        """The first heading in collision while turning in place by ``angle`` [rad]
        (signed) from ``pose``: ``(angle turned [rad], hit)`` with ``hit.time`` 0, or None
        when the whole sweep is free (module docstring).  The current pose is checked
        first (turned 0)."""
        step = self.turn_step(costmap)
        n = max(1, math.ceil(abs(angle) / step))
        turned = np.append(np.arange(n, dtype=np.float64) * step, abs(angle)) \
            * math.copysign(1.0, angle)
        poses = np.column_stack((np.full(len(turned), pose.x), np.full(len(turned), pose.y),
                                 pose.theta + turned))
        self.last_arc = poses[1:]
        found = self._first_lethal(costmap, poses)
        if found is None:
            return None
        k, hit = found
        return float(turned[k]), hit

    def cost_at(self, costmap: Costmap2D, x: float, y: float) -> int | None:
        """Cell cost at ``(x, y)`` (Nav2 ``costAtPose``), None off the map."""
        cell = costmap.world_to_map(x, y)
        return None if cell is None else int(costmap.data[cell[1], cell[0]])
