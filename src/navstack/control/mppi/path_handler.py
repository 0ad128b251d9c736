"""Plan pruning for MPPI (Nav2 ``mppi::PathHandler``).

Each cycle the controller sees only the part of the plan it can act on:

1. the pose of the plan nearest to the robot is searched among the poses within
   ``max_robot_pose_search_dist`` of integrated path length from the plan's start
   (default: half the costmap size), so a plan that loops back past the robot does
   not capture it;
2. the local plan runs from that pose for ``prune_distance`` of path length and stops
   at the first pose outside the costmap;
3. poses behind the nearest one are dropped for good.

With ``enforce_path_inversion`` the plan is cut after its first cusp (a pose where the
direction of travel reverses, negative dot product of consecutive segments), so the
robot must reach the cusp - within ``inversion_xy_tolerance`` and
``inversion_yaw_tolerance`` - before the rest of the plan is released.

navstack's controller server re-expresses the plan in the costmap frame whenever the
``odom`` drift moves it; a plan with the same shape as the current one (same segment
lengths and turns, i.e. a rigid motion of it) keeps the pruning progress instead of
restarting it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.control.mppi.errors import MPPIInvalidPath
from navstack.control.mppi.params import MPPIParams
from navstack.core.geometry import angle_diff
from navstack.costmap.costmap_2d import Costmap2D

FloatArray = NDArray[np.float64]


def first_after_integrated_distance(xy: FloatArray, begin: int, dist: float) -> int:
    """Index of the first pose whose path length from ``begin`` exceeds ``dist``, or
    ``len(xy)`` (``nav2_util::geometry_utils::first_after_integrated_distance``)."""
    if begin >= len(xy) - 1:
        return len(xy)
    seg = np.hypot(np.diff(xy[begin:, 0]), np.diff(xy[begin:, 1]))
    beyond = np.nonzero(np.cumsum(seg) > dist)[0]
    return begin + int(beyond[0]) + 1 if len(beyond) else len(xy)


def first_inversion_end(xy: FloatArray) -> int:
    """One past the first cusp of ``xy`` (``findFirstPathInversion``), or ``len(xy)``."""
    if len(xy) < 3:
        return len(xy)
    d = np.diff(xy, axis=0)
    dots = np.einsum("ij,ij->i", d[:-1], d[1:])
    cusps = np.nonzero(dots < 0.0)[0]
    return int(cusps[0]) + 2 if len(cusps) else len(xy)


def _rigidly_moved(old: FloatArray, new: FloatArray) -> bool:
    """Whether ``new`` is ``old`` under a rigid motion (same lengths, turns, spacing)."""
    if old.shape != new.shape or len(old) < 2:
        return False
    seg_old = np.hypot(*np.diff(old[:, :2], axis=0).T)
    seg_new = np.hypot(*np.diff(new[:, :2], axis=0).T)
    if not np.allclose(seg_old, seg_new, atol=1e-6):
        return False
    turn_old = angle_diff(old[1:, 2], old[:-1, 2])
    turn_new = angle_diff(new[1:, 2], new[:-1, 2])
    span_old = math.dist(old[0, :2], old[-1, :2])
    span_new = math.dist(new[0, :2], new[-1, :2])
    return bool(np.allclose(turn_old, turn_new, atol=1e-6)) and abs(span_old - span_new) < 1e-6


class PathHandler:
    """Holds the plan and hands out the pruned local plan each cycle."""

    def __init__(self, params: MPPIParams) -> None:
        self.params = params
        self._plan = np.zeros((0, 3))
        self._global_start = 0  # Nav2 global_plan_ = plan[global_start:]
        self._start = 0          # global_plan_up_to_inversion_ = plan[start:end]
        self._end = 0

    @property
    def plan(self) -> FloatArray:
        """The plan as last given ``(N, 3)``."""
        return self._plan

    @property
    def remaining(self) -> FloatArray:
        """The part of the plan not yet pruned, up to the next cusp (if enforced)."""
        return self._plan[self._start:self._end]

    def set_path(self, plan: FloatArray) -> None:
        """Take a plan ``(N, 3)`` in the costmap frame (``PathHandler::setPath``)."""
        plan = np.array(plan, dtype=np.float64).reshape(-1, 3)
        if _rigidly_moved(self._plan, plan):
            self._plan = plan
            return
        self._plan = plan
        self._global_start = self._start = 0
        self._end = self._inversion_end(0)

    def _inversion_end(self, begin: int) -> int:
        if not self.params.enforce_path_inversion:
            return len(self._plan)
        return begin + first_inversion_end(self._plan[begin:, :2])

    def goal(self) -> FloatArray:
        """The plan's last pose (x, y, yaw) (``getTransformedGoal``)."""
        if len(self._plan) == 0:
            raise MPPIInvalidPath("received a plan with zero poses; replan")
        return self._plan[-1]

    def transform_path(self, pose: tuple[float, float, float],
                       costmap: Costmap2D) -> FloatArray:
        """The local plan ``(M, 3)`` for this cycle; prunes passed poses
        (``PathHandler::transformPath``)."""
        p = self.params
        plan = self._plan[self._start:self._end]
        if len(plan) == 0:
            raise MPPIInvalidPath("received a plan with zero poses; replan")
        search = p.max_robot_pose_search_dist
        if search is None:
            search = max(costmap.size_x, costmap.size_y) * costmap.resolution * 0.5
        xy = plan[:, :2]
        upper = first_after_integrated_distance(xy, 0, search)
        d = np.hypot(xy[:upper, 0] - pose[0], xy[:upper, 1] - pose[1])
        closest = int(np.argmin(d))
        end = first_after_integrated_distance(xy, closest, p.prune_distance)
        local = plan[closest:end]
        _, _, inside = costmap.world_to_map_array(local[:, :2])
        outside = np.nonzero(~inside)[0]
        if len(outside):
            local = local[:int(outside[0])]
        self._start += closest
        if p.enforce_path_inversion and self._end < len(self._plan):
            cusp = self._plan[self._end - 1]
            if (math.hypot(pose[0] - cusp[0], pose[1] - cusp[1]) <= p.inversion_xy_tolerance
                    and abs(angle_diff(cusp[2], pose[2])) <= p.inversion_yaw_tolerance):
                self._global_start = self._start = self._end
                self._end = self._inversion_end(self._start)
        if len(local) == 0:
            raise MPPIInvalidPath(
                f"no pose of the plan near the robot at ({pose[0]:.2f}, {pose[1]:.2f}) lies "
                f"inside the costmap; the robot has left the path or the plan is in another "
                f"frame - replan")
        return np.ascontiguousarray(local)
