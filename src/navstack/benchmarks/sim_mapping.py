"""Map a simulated world while navigating, and score the result against ground truth.

The robot follows the world's waypoint route with :class:`~navstack.interfaces.stack.NavStack`
in SLAM mode (no map given; navigation plans on the live ``/map``).  Every
``sample_period`` the SLAM estimate of the robot pose (``map -> odom`` composed with the
odometry) is compared with the simulator's true pose, and at the end the SLAM map is
compared with the world raster:

* ``ate_m``: RMS absolute trajectory error, *without* alignment -- the SLAM map frame
  starts at the spawn pose, so it is the world frame;
* ``map``: :func:`~navstack.mapping.map_metrics.occupancy_iou` at 0.05 m of the map SLAM
  saves (the graph's scans at their final poses).

Used by ``navstack bench slam`` (``sim_ate_m``, ``sim_map_iou``) and the integration tests.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navstack.core.errors import TransformError
from navstack.mapping.map_metrics import MapScore, absolute_trajectory_error, occupancy_iou
from navstack.mapping.slam import SlamStats
from navstack.sim.robot import RobotParams

__all__ = ["GoalRun", "SimMappingResult", "run_goal", "run_sim_mapping"]


@dataclass
class SimMappingResult:
    """What a simulated mapping run measured."""

    ate_m: float
    ate_max_m: float
    map: MapScore
    goals: list[tuple[str, str, str]] = field(default_factory=list)  # name, status, reason
    stats: SlamStats = field(default_factory=SlamStats)
    sim_time_s: float = 0.0
    collisions: int = 0
    samples: int = 0


def run_sim_mapping(slam: Mapping[str, Any] | None = None, *, world: str = "office",
                    robot: str | RobotParams = "diff_drive", seed: int = 1,
                    goals: Sequence[str] | None = None, goal_timeout_s: float = 240.0,
                    sample_period: float = 0.5,
                    costmap_overrides: Mapping[str, Any] | None = None) -> SimMappingResult:
    """Drive the waypoint route (``goals``: names, default the packaged office order) with
    SLAM on; return trajectory and map scores.  ``costmap_overrides`` set keys of both
    costmaps' parameters, dotted for plugin sections (``inflation_layer.inflation_radius``)."""
    from navstack.interfaces.api import Navigator, TaskResult
    from navstack.interfaces.demo import default_waypoints_path
    from navstack.interfaces.stack import NavStack
    from navstack.interfaces.stack_description import SlamLocalization
    from navstack.navigation.waypoint_follower import load_waypoints

    nav2 = _nav2_with(costmap_overrides or {})
    stack = NavStack(world, robot, nav2, seed=seed,
                     localization=SlamLocalization(dict(slam or {}))).start()
    assert stack.slam is not None
    slam_node = stack.slam
    nav = Navigator(stack)
    estimate: list[tuple[float, float]] = []
    truth: list[tuple[float, float]] = []

    def sample() -> None:
        mapper = slam_node.mapper
        if mapper is None or not mapper.nodes:
            return
        try:
            odom = stack.runtime.tf.lookup_pose2d("odom", "base_link")
        except TransformError:
            return
        est = mapper.pose_of(np.array([odom.x, odom.y, odom.theta]))
        true = stack.sim.sim.pose
        estimate.append((float(est[0]), float(est[1])))
        truth.append((true.x, true.y))

    stack.runtime.scheduler.create_timer(sample_period, sample, first_at=stack.now)
    route = load_waypoints(default_waypoints_path())
    if goals is not None:
        by_name = dict(route)
        route = [(name, by_name[name]) for name in goals]
    outcomes: list[tuple[str, str, str]] = []
    names = {TaskResult.SUCCEEDED: "SUCCEEDED", TaskResult.FAILED: "FAILED",
             TaskResult.CANCELED: "CANCELED"}
    for name, pose in route:
        start = stack.now
        if not nav.goToPose(pose):
            outcomes.append((name, "REJECTED", nav.last_error))
            continue
        while not nav.isTaskComplete():
            if stack.now - start > goal_timeout_s:
                nav.cancelTask()
        result = nav.getTaskResult()
        outcomes.append((name, names.get(nav.getResult(), "UNKNOWN"),
                         result.error_msg if result is not None else ""))
    est = np.array(estimate)
    tru = np.array(truth)
    zeros = np.zeros((len(est), 1))
    ate = absolute_trajectory_error(np.hstack([est, zeros]), np.hstack([tru, zeros]),
                                    align=False)
    if slam_node.mapper is None or not slam_node.mapper.nodes:
        raise RuntimeError("SLAM produced no map: no scan was processed")
    # the map SLAM saves (its graph's scans; /slam_toolbox/save_map), not the live one
    grid = slam_node.mapper.build_map().to_occupancy_grid(
        crop=True, free_thresh=slam_node.params.map_free_thresh)
    score = occupancy_iou(grid, stack.world.to_occupancy_grid())
    return SimMappingResult(ate.rms_m, ate.max_m, score, outcomes, slam_node.mapper.stats,
                            stack.now, stack.sim.sim.collisions, len(est))


@dataclass(frozen=True)
class GoalRun:
    """One navigation goal from the spawn: final status, simulated time [s], the
    navigator's recovery count, collisions and (SLAM) maps published."""

    status: str
    time_s: float
    recoveries: int
    collisions: int
    map_updates: int


def run_goal(goal: tuple[float, float, float], *, slam: bool, world: str = "office",
             robot: str = "diff_drive", seed: int = 1, timeout_s: float = 300.0) -> GoalRun:
    """Drive from the spawn to ``goal`` (x, y, yaw) with ``NavStack(world, robot,
    localization="slam")`` (SLAM's live map) or, ``slam=False``, on the true map with
    perfect localization."""
    from navstack.core.msgs import Pose2D, PoseStamped
    from navstack.interfaces.api import Navigator
    from navstack.interfaces.stack import NavStack

    stack = NavStack(world, robot, seed=seed,
                     localization="slam" if slam else "perfect").start()
    nav = Navigator(stack)
    start = stack.now
    if not nav.goToPose(PoseStamped.from_pose2d(Pose2D(*goal), stamp=stack.now)):
        return GoalRun("REJECTED", 0.0, 0, 0, 0)
    recoveries = 0
    while not nav.isTaskComplete():
        feedback = nav.getFeedback()
        recoveries = max(recoveries, int(getattr(feedback, "number_of_recoveries", 0) or 0))
        if stack.now - start > timeout_s:
            nav.cancelTask()
    result = nav.getTaskResult()
    status = result.status.name if result is not None else "UNKNOWN"
    return GoalRun(status, stack.now - start, recoveries, stack.sim.sim.collisions,
                   stack.slam.maps_published if stack.slam is not None else 0)


def _nav2_with(costmap_overrides: Mapping[str, Any]) -> dict[str, Any]:
    """The packaged Nav2 parameters with ``costmap_overrides`` applied to both costmaps."""
    import copy

    from navstack.interfaces.stack import default_nav2_params_path
    from navstack.runtime.config import load_yaml

    nav = copy.deepcopy(load_yaml(default_nav2_params_path()))
    for costmap in ("global_costmap", "local_costmap"):
        section = nav[costmap][costmap]["ros__parameters"]
        for dotted, value in costmap_overrides.items():
            *parents, key = dotted.split(".")
            node = section
            for part in parents:
                node = node.setdefault(part, {})
            node[key] = value
    return nav
