"""The perception missions of issue 17 as py_trees trees, and a loop that ticks a tree.

* :func:`marker_frame_tree` (Nav2 lab, ``marker-frame`` in the office): go near the
  tagged obstacle, look around until its marker is on the map, approach it to refine the
  estimate (the marker map publishes ``map -> aruco_marker_<id>`` as a static frame), then
  return to the start;
* :func:`package_retrieval_tree` (TurtleBot course, ``package-retrieval`` in the arena):
  look for the target package from the viewpoints of
  :func:`~navstack.missions.search_viewpoints.search_viewpoints` (turning in place at each,
  stopping as soon as the target is on the map), take the target's ring out of the
  costmaps, drive to a pose in front of it, dock until it is in the gripper's reach,
  grip, and return home with it.  The other packages stay in the costmaps through the
  package cloud, so the planner routes around them.

:func:`run_tree` ticks a tree on the stack's scheduler (``period`` of simulated time)
until it ends or ``timeout`` passes.  It is the stand-in for the mission layer's runner
(``navstack mission NAME``, being built on branch i16-missions): the lead wires these
trees into it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import py_trees
from py_trees.common import ParallelPolicy, Status
from scipy.ndimage import distance_transform_edt

from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.core.rotations import quaternion_to_matrix
from navstack.missions.marker_behaviours import (
    ApproachMarker,
    DockToPackage,
    DriveStraightTo,
    Grip,
    IgnorePackage,
    MarkerContext,
    NavigateTo,
    SpinSearch,
    WaitFor,
)
from navstack.runtime.node import Runtime

__all__ = ["TreeOutcome", "marker_frame_tree", "package_retrieval_tree", "run_tree",
           "standoff_pose"]


def _retry(name: str, child: py_trees.behaviour.Behaviour) -> py_trees.behaviour.Behaviour:
    """Whatever the child's outcome, go on (a search step that found nothing)."""
    return py_trees.decorators.FailureIsSuccess(name=name, child=child)


def marker_frame_tree(ctx: MarkerContext, marker_id: int, view: Pose2D, home: Pose2D,
                      approach_distance: float = 1.0, min_inliers_wait: float = 3.0
                      ) -> py_trees.behaviour.Behaviour:
    """The Nav2 lab's vision task (module docstring)."""
    on_map = lambda: marker_id in ctx.markers  # noqa: E731
    look = py_trees.composites.Selector("detect the marker", memory=True, children=[
        WaitFor("already on the map", ctx, on_map, timeout=1.0),
        SpinSearch("look around", ctx, on_map)])
    return py_trees.composites.Sequence("marker-frame", memory=True, children=[
        NavigateTo("go near the tagged obstacle", ctx, lambda: view),
        look,
        ApproachMarker("approach the marker", ctx, marker_id, approach_distance),
        _retry("refine the frame", WaitFor("refine", ctx, lambda: False,
                                           timeout=min_inliers_wait)),
        _home_with_retry(ctx, home, [view]),
        _settle(ctx, home)])


def _settle(ctx: MarkerContext, home: Pose2D) -> py_trees.behaviour.Behaviour:
    """The last centimetres home: the navigator stops within its goal tolerance (0.25 m);
    the start pose is to be reached, so drive straight onto it (it is free: we left it)."""
    return DriveStraightTo("onto the start", ctx, lambda: (home.x, home.y), 0.0,
                           max_distance=0.5, final_yaw=home.theta, tolerance=0.03)


def standoff_pose(ctx: MarkerContext, package_id: int, grid: OccupancyGrid, distance: float,
                  clearance: float = 0.35, avoid: float = 0.5,
                  exclude: tuple[Pose2D, ...] = ()) -> Pose2D | None:
    """A pose ``distance`` from the package's centre, facing it square-on through one of
    its four faces (so the gripper meets a face, not a corner), with ``clearance`` to walls
    in ``grid`` and ``avoid`` to every other known package; the face nearest to the robot,
    faces behind the package counting the way round (if none is free, the nearest free of
    24 directions).  Poses within 0.2 m of one in ``exclude`` (tried already) are
    skipped."""
    target = ctx.package_xy(package_id)
    robot = ctx.robot_pose()
    found = ctx.packages.get(package_id)
    if target is None or robot is None or found is None:
        return None
    r = quaternion_to_matrix(found.pose.pose.orientation)
    facing = math.atan2(r[1, 2], r[0, 2])
    info = grid.info
    blocked = np.asarray(grid.data) != 0
    dist = distance_transform_edt(~blocked) * info.resolution
    others = [xy for pid, xy in ((p, ctx.package_xy(p)) for p in ctx.packages)
              if pid != package_id and xy is not None]
    faces = [facing + k * 0.5 * math.pi for k in range(4)]
    around = list(np.linspace(-math.pi, math.pi, 24, endpoint=False))
    return (_nearest_free(target, faces, robot, dist, grid, others, distance, clearance, avoid,
                          exclude)
            or _nearest_free(target, around, robot, dist, grid, others, distance, clearance,
                             avoid, exclude))


def _nearest_free(target: tuple[float, float], directions: list[float], robot: Pose2D,
                  dist: np.ndarray, grid: OccupancyGrid, others: list[tuple[float, float]],
                  distance: float, clearance: float, avoid: float,
                  exclude: tuple[Pose2D, ...]) -> Pose2D | None:
    best: tuple[float, Pose2D] | None = None
    for a in directions:
        x = target[0] + distance * math.cos(a)
        y = target[1] + distance * math.sin(a)
        r, c = grid.world_to_cell(x, y)
        if not (0 <= r < dist.shape[0] and 0 <= c < dist.shape[1]) or dist[r, c] < clearance:
            continue
        if any(math.hypot(x - ox, y - oy) < avoid for ox, oy in others):
            continue
        if any(math.hypot(x - p.x, y - p.y) < 0.2 for p in exclude):
            continue
        # the distance to drive, going round the package when it stands between the robot
        # and the standoff point (the package's ring must not be skirted at close range)
        cost = math.hypot(x - robot.x, y - robot.y)
        to_robot = math.atan2(robot.y - target[1], robot.x - target[0])
        apart = abs(math.atan2(math.sin(a - to_robot), math.cos(a - to_robot)))
        cost += distance * max(0.0, apart - 0.5 * math.pi) * 2.0
        if best is None or cost < best[0]:
            best = (cost, Pose2D(x, y, math.atan2(target[1] - y, target[0] - x)))
    return best[1] if best is not None else None


def _const(pose: Pose2D) -> Callable[[], Pose2D]:
    return lambda: pose


def package_retrieval_tree(ctx: MarkerContext, target_id: int, viewpoints: list[Pose2D],
                           home: Pose2D, grid: OccupancyGrid, grip_distance: float,
                           standoff: float = 0.5) -> py_trees.behaviour.Behaviour:
    """The TurtleBot course's retrieval (module docstring)."""
    found = lambda: target_id in ctx.packages  # noqa: E731
    steps: list[py_trees.behaviour.Behaviour] = [
        _retry("look from the start", SpinSearch("turn at the start", ctx, found))]
    for i, vp in enumerate(viewpoints):
        steps.append(_retry(f"viewpoint {i}", py_trees.composites.Sequence(
            f"look from viewpoint {i}", memory=True, children=[
                NavigateTo(f"go to viewpoint {i}", ctx, _const(vp)),
                SpinSearch(f"turn at viewpoint {i}", ctx, found)])))
    search = py_trees.composites.Parallel(
        "search", policy=ParallelPolicy.SuccessOnOne(), children=[
            WaitFor("target seen", ctx, found),
            py_trees.composites.Sequence("viewpoints", memory=True, children=steps)])
    tried: list[Pose2D] = []

    def standoff_goal() -> Pose2D | None:
        pose = standoff_pose(ctx, target_id, grid, standoff, exclude=tuple(tried))
        if pose is not None:
            tried.append(pose)
        return pose

    def standoff_xy() -> tuple[float, float] | None:
        return (tried[-1].x, tried[-1].y) if tried else None

    # up to three approach directions: where the navigator cannot reach one (a tight spot
    # for the wide rear body), another side of the package often is reachable
    attempts = [py_trees.composites.Sequence(f"approach {i}", memory=True, children=[
        NavigateTo("in front of the target", ctx, standoff_goal),
        # the navigator stops within its goal tolerance: settle on the standoff pose so
        # the docking runs square to the package's face
        DriveStraightTo("onto the standoff pose", ctx, standoff_xy, 0.0, max_distance=0.5,
                        tolerance=0.02)]) for i in range(3)]
    return py_trees.composites.Sequence("package-retrieval", memory=True, children=[
        search,
        WaitFor("target found", ctx, found, timeout=0.0),
        py_trees.composites.Selector("reach the target", memory=True, children=attempts),
        # only now, next to it, does the target leave the costmaps (earlier the planner
        # would route through it)
        IgnorePackage("target off the costmap", ctx, target_id),
        DockToPackage("dock", ctx, target_id, grip_distance, speed=0.04),
        Grip("grip", ctx),
        _home_with_retry(ctx, home, viewpoints),
        _settle(ctx, home)])


def _home_with_retry(ctx: MarkerContext, home: Pose2D, viewpoints: list[Pose2D]
                     ) -> py_trees.behaviour.Behaviour:
    """Home; if the navigator gives up (a tight spot, a person in a door), once more by
    way of the viewpoint nearest home: the stuck spot is left behind and the plan starts
    afresh."""
    attempts: list[py_trees.behaviour.Behaviour] = [
        NavigateTo("return to the start", ctx, lambda: home)]
    if viewpoints:
        near = min(viewpoints, key=lambda v: math.hypot(v.x - home.x, v.y - home.y))
        attempts.append(py_trees.composites.Sequence("home via open space", memory=True,
                                                     children=[
            NavigateTo("to open space", ctx, _const(near)),
            NavigateTo("return to the start again", ctx, lambda: home)]))
    return py_trees.composites.Selector("return home", memory=True, children=attempts)


@dataclass
class TreeOutcome:
    """How a tree run ended."""

    status: Status
    duration: float
    ticks: int
    failed: str = ""
    """Name and message of the behaviour that failed, if any."""


def run_tree(runtime: Runtime, root: py_trees.behaviour.Behaviour, timeout: float,
             period: float = 0.1) -> TreeOutcome:
    """Tick ``root`` every ``period`` s of simulated time until it ends or ``timeout``."""
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup()
    start = runtime.now
    ticks = 0
    status = Status.RUNNING
    while runtime.now - start < timeout:
        tree.tick()
        ticks += 1
        status = root.status
        if status in (Status.SUCCESS, Status.FAILURE):
            break
        runtime.scheduler.run_until(runtime.now + period)
    failed = ""
    if status is Status.FAILURE:
        node = root  # follow the failure down: the failed child of each failed composite
        while list(node.children):
            failing = [c for c in node.children if c.status is Status.FAILURE]
            if not failing:
                break
            node = failing[-1]
        failed = f"{node.name}: {node.feedback_message or getattr(node, 'reason', '')}"
    elif status is Status.RUNNING:
        root.stop(Status.INVALID)
        failed = f"timed out after {timeout:.0f} s"
    return TreeOutcome(status, runtime.now - start, ticks, failed)
