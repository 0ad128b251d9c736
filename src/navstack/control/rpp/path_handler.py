"""Plan pruning and transformation of Regulated Pure Pursuit (Nav2 ``PathHandler``).

:meth:`PathHandler.transform_global_plan` does what Nav2's ``transformGlobalPlan`` does,
with the plan and pose already in the costmap frame:

1. the closest plan pose to the robot is searched among the poses up to the first one
   after ``max_robot_pose_search_dist`` of integrated path length (so a path that loops
   back near the robot does not capture it), keeping at least two poses ahead when the
   closest is the last one searched;
2. the part from there to the first pose farther from the robot than half the larger
   costmap side is returned in the robot frame ``(M, 3)``;
3. the poses before the closest one are dropped for good (pruning).

Errors are ``InvalidPath`` (Nav2 ``nav2_core::InvalidPath``) naming the cause.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import InvalidPath
from navstack.core.geometry import se2_compose, se2_inverse
from navstack.core.msgs import Path, Pose2D
from navstack.costmap.costmap_2d import Costmap2D

FloatArray = NDArray[np.float64]


def first_after_integrated_distance(xy: FloatArray, distance: float) -> int:
    """Index of the first pose whose integrated distance from ``xy[0]`` exceeds
    ``distance``, or ``len(xy)`` (Nav2 ``first_after_integrated_distance``)."""
    if len(xy) < 2:
        return len(xy)
    beyond = np.nonzero(np.cumsum(np.hypot(*np.diff(xy, axis=0).T)) > distance)[0]
    return int(beyond[0]) + 1 if len(beyond) else len(xy)


class PathHandler:
    """Holds the global plan (costmap frame) and its pruning state."""

    def __init__(self) -> None:
        self.path: Path | None = None
        self._plan = np.zeros((0, 3))
        self._start = 0

    def set_plan(self, path: Path) -> None:
        """Take a new plan; pruning restarts from its first pose."""
        self.path = path
        self._plan = np.array(path.as_array(), dtype=np.float64)
        self._start = 0

    @property
    def remaining(self) -> FloatArray:
        """The plan from the last pruning point on, ``(N, 3)`` costmap frame."""
        return self._plan[self._start:]

    def transform_global_plan(self, pose: Pose2D, costmap: Costmap2D,
                              max_robot_pose_search_dist: float,
                              reject_unit_path: bool = False) -> tuple[FloatArray, FloatArray]:
        """``(plan in the robot frame, same poses in the costmap frame)``, both ``(M, 3)``."""
        plan = self.remaining
        if len(plan) == 0:
            raise InvalidPath("received a plan with zero poses; replan")
        if reject_unit_path and len(plan) == 1:
            raise InvalidPath("received a plan with a single pose, but "
                              "interpolate_curvature_after_goal needs two; replan")
        xy = plan[:, :2]
        upper = first_after_integrated_distance(xy, max_robot_pose_search_dist)
        d_robot = np.hypot(xy[:, 0] - pose.x, xy[:, 1] - pose.y)
        begin = int(np.argmin(d_robot[:upper])) if upper > 0 else 0
        if upper > 0 and len(plan) > 1 and begin == upper - 1:
            begin = max(0, upper - 2)
        max_extent = max(costmap.size_x_m, costmap.size_y_m) / 2.0
        far = np.nonzero(d_robot[begin:] > max_extent)[0]
        end = begin + int(far[0]) if len(far) else len(plan)
        self._start += begin
        local = plan[begin:end]
        if len(local) == 0:
            raise InvalidPath(
                f"no pose of the plan lies within {max_extent:.2f} m (half the costmap) of the "
                f"robot at ({pose.x:.2f}, {pose.y:.2f}); the robot has left the path — replan")
        robot = se2_compose(se2_inverse(pose.as_array()), local)
        return robot, local
