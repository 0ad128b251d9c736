"""Packages on the floor and the gripper that carries them, inside the simulator.

:class:`PackageWorld` keeps every package's current pose (they start where the world
puts them), which one the gripper holds, and the robot's contacts with the others.
Packages are below the lidar plane, so the lidar never sees them; the robot's body does
touch them: a step that would make the footprint overlap a package is blocked like a
step into a wall and counted in :attr:`PackageWorld.collisions` (per package, one count
per contact episode, as the simulator counts wall contacts).

The gripper (:class:`~navstack.sim.robot.GripperParams`): :meth:`PackageWorld.close`
attaches the package whose centre lies in the reach zone in front of the robot, after
``close_time``; it then keeps its pose relative to ``base_link`` (lifted: it no longer
touches the floor or the robot) until :meth:`PackageWorld.open` puts it down where it is.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import distance_transform_edt

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.sim.collision import polygon_hits_moving
from navstack.sim.markers import PackageSpec
from navstack.sim.robot import GripperParams
from navstack.sim.world import World

FloatArray = NDArray[np.float64]
_NO_CIRCLES = np.zeros((0, 3))


class PackageWorld:
    """Package poses, the gripper state and package contacts (module docstring)."""

    def __init__(self, packages: tuple[PackageSpec, ...], gripper: GripperParams,
                 footprint: FloatArray) -> None:
        self.specs = packages
        self.params = gripper
        self.poses: list[Pose2D] = [p.pose for p in packages]
        self.front = float(np.max(footprint[:, 0]))
        self.radius = float(np.max(np.hypot(footprint[:, 0], footprint[:, 1])))
        self.closed = False
        self.carried: int | None = None
        self._offset = Pose2D()
        self.closing_until = -math.inf
        self._pending: int | None = None
        self.collisions = [0] * len(packages)
        self._last_contact = [-math.inf] * len(packages)
        self.contact_release_s = 0.5

    # --- gripper ------------------------------------------------------------------------
    def in_reach(self, robot: Pose2D) -> int | None:
        """Index of the package nearest to the gripper within the reach zone, or None."""
        p = self.params
        best, best_d = None, math.inf
        c, s = math.cos(robot.theta), math.sin(robot.theta)
        for i, pose in enumerate(self.poses):
            if i == self.carried:
                continue
            dx, dy = pose.x - robot.x, pose.y - robot.y
            ahead = c * dx + s * dy - self.front
            side = -s * dx + c * dy
            if p.reach_min <= ahead <= p.reach_max and abs(side) <= p.half_width:
                d = math.hypot(ahead, side)
                if d < best_d:
                    best, best_d = i, d
        return best

    def close(self, robot: Pose2D, now: float) -> int | None:
        """Start closing; the package in reach now (if any) is held once ``close_time``
        has passed (:meth:`update`).  Returns that package's index."""
        self.closed = True
        if self.carried is not None:
            return self.carried
        self._pending = self.in_reach(robot)
        self.closing_until = now + self.params.close_time
        return self._pending

    def open(self) -> int | None:
        """Open: the carried package (returned) is put down where it is."""
        self.closed = False
        released, self.carried, self._pending = self.carried, None, None
        return released

    def update(self, robot: Pose2D, now: float) -> None:
        """Finish a closing gripper and move the carried package with the robot."""
        if self._pending is not None and now >= self.closing_until:
            i = self._pending
            self._pending = None
            if self.in_reach(robot) == i:  # still there when the jaws meet
                self.carried = i
                self._offset = robot.inverse().compose(self.poses[i])
        if self.carried is not None:
            self.poses[self.carried] = robot.compose(self._offset)

    # --- contacts -----------------------------------------------------------------------
    def polygons(self) -> list[FloatArray]:
        """Footprint polygons ``(4, 2)`` of the packages at their current poses."""
        return [spec.polygon_at(pose) for spec, pose in zip(self.specs, self.poses, strict=True)]

    def contact(self, footprint_world: FloatArray, robot: Pose2D, now: float) -> bool:
        """Whether the robot footprint (world frame) overlaps a package it does not carry;
        counts a new collision per package after ``contact_release_s`` without contact."""
        hit = False
        for i, (spec, pose) in enumerate(zip(self.specs, self.poses, strict=True)):
            if i == self.carried:
                continue
            reach = self.radius + 0.5 * math.hypot(spec.size[0], spec.size[1])
            if math.hypot(pose.x - robot.x, pose.y - robot.y) > reach:
                continue
            box = spec.polygon_at(pose)[None, :, :]
            if polygon_hits_moving(np.ascontiguousarray(footprint_world), _NO_CIRCLES, box):
                if now - self._last_contact[i] > self.contact_release_s:
                    self.collisions[i] += 1
                self._last_contact[i] = now
                hit = True
        return hit

    @property
    def total_collisions(self) -> int:
        return sum(self.collisions)


__all__ = ["PackageWorld"]


def place_packages(world: World, rng: np.random.Generator, ids: tuple[int, ...] = (3, 4),
                   dictionary: str = "DICT_4X4_50", clearance: float = 0.6,
                   spacing: float = 0.7, from_start: float = 0.8) -> tuple[PackageSpec, ...]:
    """The TurtleBot course's packages (10 x 5 x 5 cm, 5 cm markers of ``dictionary`` on
    every face, one per marker id of ``ids``) at random free spots of ``world``: at least
    ``clearance`` [m] from walls and obstacles, ``spacing`` from each other and
    ``from_start`` from the spawn, random yaw.  With 0.6 m a package's 0.3 m ring leaves
    0.45 m to a wall: the TurtleBot3 Waffle Pi's 0.306 m body and a 5 cm costmap cell on
    each side.  (At 0.5 m the 0.35 m gaps were wide enough for the planner, which plans
    with the footprint's 0.11 m inscribed radius, and too narrow for the controller's
    footprint check: 4 of 20 runs of ``navstack bench retrieval`` stalled there.)"""
    dist = distance_transform_edt(~world.occupied) * world.resolution
    free = np.argwhere(dist >= clearance)
    placed: list[tuple[float, float]] = []
    out = []
    for pid in ids:
        spot = None
        for _ in range(1000 if len(free) else 0):
            r, c = free[rng.integers(len(free))]
            x, y = world.cell_center(int(r), int(c))
            if (math.hypot(x - world.spawn.x, y - world.spawn.y) >= from_start
                    and all(math.hypot(x - px, y - py) >= spacing for px, py in placed)):
                spot = (x, y)
                break
        if spot is None:
            raise ConfigError(f"no free spot for package {pid} in world '{world.name}' "
                              f"({clearance} m from obstacles, {spacing} m apart, "
                              f"{from_start} m from the start)", key_path="packages")
        placed.append(spot)
        out.append(PackageSpec(f"package_{pid}", pid, dictionary, spot[0], spot[1],
                               float(rng.uniform(-math.pi, math.pi))))
    return tuple(out)
