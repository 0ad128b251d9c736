"""The perception missions of issue 17 on the mission layer (:class:`Mission`, run by
:class:`~navstack.missions.mission.MissionRunner`, ``navstack mission NAME``).

* :func:`marker_frame_mission` (Nav2 lab, ``marker-frame`` in the office): remember the
  start, go near the tagged obstacle, look around until its marker is on the map,
  approach it to refine the estimate (the marker map publishes
  ``map -> aruco_marker_<id>`` as a static frame), then return to the start;
* :func:`package_retrieval_mission` (TurtleBot course, ``package-retrieval`` in the
  arena): look for the target package from the viewpoints of
  :func:`~navstack.missions.search_viewpoints.search_viewpoints` (turning in place at
  each, stopping as soon as the target is on the map), drive to a pose in front of it,
  take its ring out of the costmaps, dock until it is in the gripper's reach, grip, and
  return home with it.  The other packages stay in the costmaps through the package
  cloud, so the planner routes around them.

Both end with :func:`return_home`: the mission layer's :class:`ReturnHome`, once more by
way of open space if that fails, then the last centimetres straight onto the start.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import ParallelPolicy
from scipy.ndimage import distance_transform_edt

from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.core.rotations import quaternion_to_matrix
from navstack.missions.behaviours import NavigateToPose, RememberHome, ReturnHome, WaitFor
from navstack.missions.marker_behaviours import (
    ApproachMarker,
    DockToPackage,
    DriveStraightTo,
    Grip,
    IgnorePackage,
    MarkerContext,
    SpinSearch,
)
from navstack.missions.mission import Mission

__all__ = ["marker_frame_mission", "package_retrieval_mission", "return_home",
           "standoff_pose"]

HOME = "home"


def _go_on(name: str, child: Behaviour) -> Behaviour:
    """Whatever the child's outcome, go on (a search step that found nothing)."""
    return py_trees.decorators.FailureIsSuccess(name=name, child=child)


def _home(ctx: MarkerContext) -> Pose2D | None:
    home = ctx.results.get(HOME)
    return home if isinstance(home, Pose2D) else None


def _home_xy(ctx: MarkerContext) -> tuple[float, float] | None:
    home = _home(ctx)
    return None if home is None else (home.x, home.y)


def return_home(ctx: MarkerContext, open_space: list[Pose2D]) -> Behaviour:
    """Home (stored by :class:`RememberHome`) with :class:`ReturnHome` (one goal: a
    failed goal has already run all the navigator's recoveries, about two minutes, and a
    second one from the same spot fails the same way); if the navigator gives up (a
    tight spot, a person in a door), again by way of the pose of
    ``open_space`` nearest home -- the stuck spot is left behind and the plan starts
    afresh; then straight onto the start (the navigator stops within its goal tolerance,
    the start is free: the robot left it)."""
    attempts: list[Behaviour] = [ReturnHome(ctx, HOME, attempts=1, name="return home")]
    if open_space:
        attempts.append(py_trees.composites.Sequence("home via open space", memory=True,
                                                     children=[
            NavigateToPose(ctx, lambda: _nearest(open_space, _home(ctx)),
                           name="to open space"),
            ReturnHome(ctx, HOME, attempts=2, name="return home again")]))
    return py_trees.composites.Sequence("back to the start", memory=True, children=[
        py_trees.composites.Selector("return home", memory=True, children=attempts),
        _SettleHome(ctx)])


def _nearest(poses: list[Pose2D], to: Pose2D | None) -> Pose2D | None:
    if to is None:
        return None
    return min(poses, key=lambda v: math.hypot(v.x - to.x, v.y - to.y))


class _SettleHome(DriveStraightTo):
    """The last centimetres onto the stored home, ending with its heading."""

    def __init__(self, ctx: MarkerContext) -> None:
        super().__init__(ctx, lambda: _home_xy(ctx), 0.0, max_distance=0.5, tolerance=0.03,
                         name="onto the start")
        self.mctx = ctx

    def initialise(self) -> None:
        super().initialise()
        home = _home(self.mctx)
        self.final_yaw = home.theta if home is not None else None


def marker_frame_mission(ctx: MarkerContext, marker_id: int, view: Pose2D,
                         approach_distance: float = 1.0, refine_time: float = 3.0
                         ) -> Mission:
    """The Nav2 lab's vision task (module docstring)."""
    on_map = lambda: marker_id in ctx.markers  # noqa: E731
    look = py_trees.composites.Selector("detect the marker", memory=True, children=[
        WaitFor(ctx, on_map, 1.0, f"marker {marker_id} on the map", name="already mapped"),
        SpinSearch(ctx, on_map, f"marker {marker_id}", name="look around")])
    # in front of the marker for refine_time: more sightings for the marker map's filter
    refine = WaitFor(ctx, lambda: ctx.now - refine.start >= refine_time, refine_time + 1.0,
                     f"{refine_time:.0f} s of sightings", name="refine the frame")
    root = py_trees.composites.Sequence("marker-frame", memory=True, children=[
        RememberHome(ctx, HOME),
        NavigateToPose(ctx, view, name="go near the tagged obstacle"),
        look,
        ApproachMarker(ctx, marker_id, approach_distance, name="approach the marker"),
        refine,
        return_home(ctx, [view])])

    def summary() -> dict[str, Any]:
        found = ctx.marker_facing(marker_id)
        return {"marker_id": marker_id,
                "marker": None if found is None else [round(v, 4) for v in found]}

    return Mission("marker-frame", root, ctx, "go near the tagged obstacle, publish its "
                   "marker's static frame, return to the start", summary)


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


def package_retrieval_mission(ctx: MarkerContext, target_id: int,
                              viewpoints: list[Pose2D], grid: OccupancyGrid,
                              grip_distance: float, standoff: float = 0.5) -> Mission:
    """The TurtleBot course's retrieval (module docstring)."""
    found = lambda: target_id in ctx.packages  # noqa: E731
    what = f"package {target_id}"
    steps: list[Behaviour] = [
        _go_on("look from the start", SpinSearch(ctx, found, what, name="turn at the start"))]
    for i, vp in enumerate(viewpoints):
        steps.append(_go_on(f"viewpoint {i}", py_trees.composites.Sequence(
            f"look from viewpoint {i}", memory=True, children=[
                NavigateToPose(ctx, vp, name=f"go to viewpoint {i}"),
                SpinSearch(ctx, found, what, name=f"turn at viewpoint {i}")])))
    search = py_trees.composites.Parallel(
        "search", policy=ParallelPolicy.SuccessOnOne(), children=[
            WaitFor(ctx, found, math.inf, f"{what} seen", name="target seen"),
            py_trees.composites.Sequence("viewpoints", memory=True, children=steps)])
    tried: list[Pose2D] = []

    def standoff_goal() -> Pose2D | None:
        pose = standoff_pose(ctx, target_id, grid, standoff, exclude=tuple(tried))
        if pose is not None:
            tried.append(pose)
        return pose

    def standoff_xy() -> tuple[float, float] | None:
        return (tried[-1].x, tried[-1].y) if tried else None

    def standoff_yaw() -> float | None:
        return tried[-1].theta if tried else None  # facing the target

    # up to three approach directions: where the navigator cannot reach one (a tight spot
    # for the wide rear body), another side of the package often is reachable
    attempts = [py_trees.composites.Sequence(f"approach {i}", memory=True, children=[
        NavigateToPose(ctx, standoff_goal, name="in front of the target"),
        # the navigator stops within its goal tolerance: settle on the standoff pose so
        # the docking runs square to the package's face
        DriveStraightTo(ctx, standoff_xy, 0.0, max_distance=0.5, tolerance=0.02,
                        final_yaw=standoff_yaw, name="onto the standoff pose")])
        for i in range(3)]
    root = py_trees.composites.Sequence("package-retrieval", memory=True, children=[
        RememberHome(ctx, HOME),
        search,
        WaitFor(ctx, found, 0.0, f"{what} on the map", name="target found"),
        py_trees.composites.Selector("reach the target", memory=True, children=attempts),
        # only now, next to it, does the target leave the costmaps (earlier the planner
        # would route through it)
        IgnorePackage(ctx, target_id, name="target off the costmap"),
        DockToPackage(ctx, target_id, grip_distance, speed=0.04, name="dock"),
        Grip(ctx, name="grip"),
        return_home(ctx, viewpoints)])

    def summary() -> dict[str, Any]:
        return {"target_id": target_id, "viewpoints": len(viewpoints),
                "gripper": ctx.gripper_status,
                "target": ctx.package_xy(target_id)}

    return Mission("package-retrieval", root, ctx, "find the target package, avoid the "
                   "others, grip it and bring it home", summary)
