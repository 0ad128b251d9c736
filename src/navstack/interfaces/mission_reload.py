"""Reload checks of a map saved by the map-by-poses mission (the Nav2 lab's task).

* **map_server**: the saved YAML + PGM is loaded as nav2_map_server would
  (:func:`~navstack.core.map_files.load_map`) and compared cell by cell with the SLAM map
  it came from; then a fresh stack navigates on it with AMCL from the spawn pose to a
  goal, and AMCL's estimate at the end is compared with the true pose.
* **SLAM localization mode**: a fresh stack with slam_toolbox in ``localization`` mode
  deserializes the saved pose graph (``match_type: localize``, initial pose = spawn) and
  navigates to the same goal; its estimate is compared with the true pose.

A check passes when the goal is reached and the estimate is within ``max_error`` of the
truth.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from navstack.core.errors import NavstackError
from navstack.core.map_files import load_map
from navstack.core.msgs import OccupancyGrid, Pose2D, PoseStamped
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.stack import NavStack
from navstack.interfaces.stack_description import AmclLocalization, SlamLocalization

__all__ = ["check_reload"]


def _drive(stack: NavStack, goal: Pose2D, timeout: float) -> tuple[str, float]:
    """Navigate to ``goal``; returns (status, estimate error [m] at the end); a failed
    status carries the navigator's reason after a colon."""
    nav = Navigator(stack)
    nav.goToPose(PoseStamped.from_pose2d(goal, "map", stack.now))
    t0 = stack.now
    while not nav.isTaskComplete():
        if stack.now - t0 > timeout:
            nav.cancelTask()
            break
    true = stack.sim.sim.pose
    try:
        est = nav.robot_pose()
    except NavstackError:
        return "NO_POSE", math.inf
    status = {TaskResult.SUCCEEDED: "SUCCEEDED", TaskResult.FAILED: "FAILED",
              TaskResult.CANCELED: "CANCELED"}.get(nav.getResult(), "UNKNOWN")
    result = nav.getTaskResult()
    if status != "SUCCEEDED" and result is not None and result.error_msg:
        status += f": {result.error_msg}"
    return status, math.hypot(est.x - true.x, est.y - true.y)


def _agreement(saved: OccupancyGrid, slam: OccupancyGrid) -> float:
    """Fraction of the saved map's cells whose class (unknown / free / occupied) is the
    same in the SLAM map at the same place (the saved map is cropped, SLAM's padded)."""

    def classes(g: OccupancyGrid) -> np.ndarray:
        d = np.asarray(g.data).reshape(g.info.height, g.info.width)
        return np.where(d < 0, 0, np.where(d >= 65, 2, 1))

    a, b = saved.info, slam.info
    rows, cols = np.mgrid[0:a.height, 0:a.width]
    x = a.origin.position.x + (cols + 0.5) * a.resolution
    y = a.origin.position.y + (rows + 0.5) * a.resolution
    bc = np.floor((x - b.origin.position.x) / b.resolution).astype(np.int64)
    br = np.floor((y - b.origin.position.y) / b.resolution).astype(np.int64)
    inside = (br >= 0) & (br < b.height) & (bc >= 0) & (bc < b.width)
    if not inside.any():
        return 0.0
    other = np.zeros(inside.shape, dtype=np.int64)
    other[inside] = classes(slam)[br[inside], bc[inside]]
    return float(((classes(saved) == other) & inside).sum() / inside.size)


def check_reload(world: str, robot: str, nav2: str | Path, files: dict[str, str],
                 slam_map: OccupancyGrid | None, slam_params: dict[str, Any],
                 goal: Pose2D, seed: int = 1, timeout: float = 180.0,
                 max_error: float = 0.15) -> dict[str, Any]:
    """Both reload checks (module docstring); returns their figures."""
    out: dict[str, Any] = {"goal": [goal.x, goal.y, goal.theta]}
    saved = load_map(files["map_yaml"])
    out["map_server_cells_agree"] = round(_agreement(saved, slam_map), 4) if slam_map else 0.0
    amcl = NavStack(world, robot, nav2, seed=seed + 100,
                    localization=AmclLocalization({"random_seed": seed + 100}),
                    map_grid=saved).start()
    status, err = _drive(amcl, goal, timeout)
    out.update(map_server_goal=status, map_server_amcl_error_m=round(err, 4),
               map_server_ok=status == "SUCCEEDED" and err <= max_error)
    if "posegraph" in files:
        params = {**slam_params, "mode": "localization"}
        loc = NavStack(world, robot, nav2, seed=seed + 200,
                       localization=SlamLocalization(params)).start()
        assert loc.slam is not None
        spawn = loc.description.spawn
        loc.slam.load(files["posegraph"], match_type="localize",
                      initial_pose=(spawn.x, spawn.y, spawn.theta))
        loc.run_for(0.5)  # map -> odom reaches TF, the first scans are matched
        status, err = _drive(loc, goal, timeout)
        out.update(slam_localization_goal=status, slam_localization_error_m=round(err, 4),
                   slam_localization_ok=status == "SUCCEEDED" and err <= max_error)
    else:
        out.update(slam_localization_ok=False,
                   slam_localization_goal="no serialized pose graph was saved")
    return out
