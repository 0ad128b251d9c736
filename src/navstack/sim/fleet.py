"""Several robots in one simulated world: shared physics, mutual sensing, robot-robot contact.

``FleetSimulator`` holds one :class:`~navstack.sim.simulator.Simulator` per robot, all in
the same :class:`~navstack.sim.world.World` at the same instant.  Each robot's ``peers``
are the others, so its lidar sees their bodies and its contact model blocks (and counts)
a step into one of them (``Simulator.robot_collisions``).  The first robot owns the
world's moving obstacles and yields them to every robot; the others follow its obstacle
clocks.  Physics steps every robot together, in a fixed order, in sub-steps of at most
``physics_dt``: the run is deterministic for a seed, as for one robot.

Each robot draws noise from its own stream (seed ``100 * seed + index``), so adding a
robot does not change the noise another robot sees at the same index.

The fleet also keeps the smallest body-to-body distance between any two robots seen at a
physics step (``min_separation``, exact polygon distance, 0 on contact) -- the figure
that says how close the robots came to each other.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.sim.collision import footprint_collides, polygons_distance
from navstack.sim.robot import RobotParams
from navstack.sim.simulator import Simulator
from navstack.sim.world import World

SEPARATION_CAP = 5.0
"""Robot-robot distances beyond this [m] are not computed exactly (reported as the cap)."""


@dataclass(frozen=True)
class FleetMember:
    """One robot of a fleet: its name (its namespace, ``robot1``), profile and spawn pose."""

    name: str
    robot: RobotParams
    spawn: Pose2D


class FleetSimulator:
    """The robots of a fleet in one world; :meth:`advance_to` steps them all together."""

    def __init__(self, world: World, members: Sequence[FleetMember], seed: int = 0,
                 physics_rate_hz: float = 50.0) -> None:
        if not members:
            raise ConfigError("a fleet needs at least one robot", key_path="fleet.robots")
        names = [m.name for m in members]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(f"robot names must be unique, {dup} repeat",
                              key_path="fleet.robots", suggestion="name them robot1, robot2, ...")
        if not physics_rate_hz > 0.0:
            raise ConfigError(f"physics rate must be positive, got {physics_rate_hz}",
                              key_path="sim.physics_rate_hz")
        self.world = world
        self.names = tuple(names)
        self.physics_dt = 1.0 / physics_rate_hz
        self.sims = tuple(Simulator(world, m.robot, 100 * seed + i, m.spawn)
                          for i, m in enumerate(members))
        owner = self.sims[0]
        for i, sim in enumerate(self.sims):
            sim.peers = tuple(s for j, s in enumerate(self.sims) if j != i)
            sim.obstacle_owner = None if i == 0 else owner
        owner.walkers.robot_speed_bound = max(s.walkers.robot_speed_bound for s in self.sims)
        self._check_spawns()
        self.min_separation = SEPARATION_CAP
        self.min_separation_at: tuple[float, str, str] | None = None
        """``(time, robot, robot)`` of :attr:`min_separation` (``None`` while beyond the cap)."""
        self._update_separation()

    def _check_spawns(self) -> None:
        for i, (name, sim) in enumerate(zip(self.names, self.sims, strict=True)):
            body = sim.body()
            p = sim.pose
            where = f"robot '{name}' spawned at ({p.x:.2f}, {p.y:.2f})"
            if footprint_collides(self.world, body, sim.obstacle_clocks):
                raise ConfigError(f"{where} overlaps an obstacle of world "
                                  f"'{self.world.name}'", key_path=f"fleet.robots[{i}].spawn",
                                  suggestion="move the spawn pose into free space")
            for other_name, other in zip(self.names[:i], self.sims[:i], strict=True):
                if polygons_distance(body, other.body()) <= 0.0:
                    raise ConfigError(f"{where} overlaps robot '{other_name}'",
                                      key_path=f"fleet.robots[{i}].spawn",
                                      suggestion="give every robot its own spawn pose")

    @property
    def time(self) -> float:
        return self.sims[0].time

    def sim(self, name: str) -> Simulator:
        """The simulator of the robot called ``name``."""
        try:
            return self.sims[self.names.index(name)]
        except ValueError:
            raise ConfigError(f"no robot '{name}' in the fleet; robots: "
                              f"{', '.join(self.names)}") from None

    def advance_to(self, t: float) -> None:
        """Step every robot up to time ``t`` (sub-steps of at most ``physics_dt``)."""
        sims = self.sims
        while sims[0].time < t - 1e-9:
            dt = min(self.physics_dt, t - sims[0].time)
            for sim in sims:  # the owner first: it advances the shared obstacles
                sim.step(dt)
            self._update_separation()

    def _update_separation(self) -> None:
        sims = self.sims
        for i in range(len(sims)):
            a = sims[i]
            for j in range(i + 1, len(sims)):
                b = sims[j]
                centre = math.hypot(a.state.x - b.state.x, a.state.y - b.state.y)
                gap_bound = centre - a.footprint.circumscribed_radius \
                    - b.footprint.circumscribed_radius
                if gap_bound >= self.min_separation:
                    continue  # cannot be nearer than what we have
                d = polygons_distance(a.body(), b.body(), SEPARATION_CAP)
                if d < self.min_separation:
                    self.min_separation = d
                    self.min_separation_at = (a.time, self.names[i], self.names[j])

    @property
    def collisions(self) -> int:
        """Collisions of all robots (robot-world and robot-robot)."""
        return sum(s.collisions for s in self.sims)

    @property
    def robot_collisions(self) -> int:
        """Collisions whose contact was another robot (each robot involved counts its own)."""
        return sum(s.robot_collisions for s in self.sims)
