"""The world's moving obstacles as people and forklifts that make way for robots.

Moving obstacles yield: each has its own clock, held still during a step in which its
motion would bring it closer to a robot than ``yield_margin`` (0.6 m) beyond their
bounding circles -- people and forklifts stop for a robot rather than walk through it --
and an obstacle held for ``turn_back_after`` (4 s) turns back along its path, so a
face-off in a corridor always resolves.  When turning back would close in on a robot as
well (a robot beside the end of a pingpong path, where both ways lead back past it, or
robots on both sides) the obstacle instead steps aside (up to ``sidestep_max``, 0.6 m)
and walks on past it, yielding only within ``pass_margin`` (0 m: its bounding circle
stays 0.05 m off the robot's circumscribed circle); where the robot stands too close to
pass it backs away from the robot, off its path (up to ``step_away_max``, 2.5 m), so the
robot can move.  Once clear of every robot's yield radius it walks back onto its path.
A person squeezes past or makes room for a robot that stands in the way rather than wait
for it for good.  The traffic stays deterministic (clocks, offsets, directions and hold
times depend only on the simulated history).

:class:`WalkerTraffic` holds that state for one world; the
:class:`~navstack.sim.simulator.Simulator` of the robot that owns the obstacles (the
only one, or one per fleet) advances it every physics step.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.sim.world import MovingObstacle, ObstacleClock, ObstacleState, World

__all__ = ["WalkerTraffic"]

Offset = tuple[float, float] | None
"""A walker's offset [m] from its path, ``None`` while on it."""


def _shrink(off: tuple[float, float], by: float) -> Offset:
    """An offset ``by`` metres shorter (``None`` once it reaches the path)."""
    n = math.hypot(*off)
    if n <= by:
        return None
    return off[0] * (1.0 - by / n), off[1] * (1.0 - by / n)


def _at(obstacle: MovingObstacle, clock: float, off: Offset) -> tuple[float, float]:
    """The obstacle's centre at ``clock``, ``off`` its path."""
    x, y, _ = obstacle.pose_in(ObstacleState(clock, *off) if off else clock)
    return x, y


def _closes_in(obstacle: MovingObstacle, clock: float, off: Offset,
               robots: list[tuple[float, float]], d_now: list[float], keep: float) -> bool:
    """Whether the obstacle at ``clock`` (+ ``off``) is nearer than ``keep`` to a robot it
    was farther from (``d_now``: its distances to ``robots`` before the step)."""
    nx, ny = _at(obstacle, clock, off)
    return any(d_next < keep and d_next < d
               for d_next, d in zip([math.hypot(nx - rx, ny - ry) for rx, ry in robots],
                                    d_now, strict=True))


class WalkerTraffic:
    """The clocks, offsets and moods of a world's moving obstacles (module docstring).

    ``robot_radius`` is the robots' circumscribed radius (each obstacle's yield radius
    is measured from their bounding circles), ``robot_speed_bound`` the fastest a robot
    moves [m/s] (for the far-obstacle shortcut of :meth:`advance`)."""

    yield_margin: float = 0.6
    turn_back_after: float = 4.0
    pass_margin: float = 0.0
    sidestep_max: float = 0.6
    step_away_max: float = 2.5

    def __init__(self, world: World, robot_radius: float, robot_speed_bound: float,
                 distance_field: NDArray[np.float64]) -> None:
        self.world = world
        self.robot_speed_bound = robot_speed_bound
        self._dist = distance_field
        n = len(world.moving_obstacles)
        self.bounds = [
            (o, robot_radius + (o.radius if o.shape == "circle" else 0.5 * math.hypot(*o.size))
             + 0.05)
            for o in world.moving_obstacles]
        """Each obstacle with the centre distance at which its bounding circle touches a
        robot's circumscribed one (plus 0.05 m)."""
        self.clocks = [0.0] * n
        self.offsets: list[Offset] = [None] * n
        self.near = [True] * n
        """Whether each obstacle was within its yield radius of a robot at the last step
        (farther ones cannot touch a robot within one step)."""
        self._direction = [1.0] * n
        self._held = [0.0] * n
        self._passing = [False] * n
        self._backing = [False] * n
        self._far_slack = [0.0] * n

    @property
    def states(self) -> tuple[ObstacleClock, ...]:
        """Each obstacle's clock, or its :class:`ObstacleState` while off its path."""
        return tuple(c if not o else ObstacleState(c, o[0], o[1])
                     for c, o in zip(self.clocks, self.offsets, strict=True))

    def forget_distances(self) -> None:
        """A robot jumped (teleport): evaluate every obstacle exactly at the next step."""
        self._far_slack = [0.0] * len(self._far_slack)

    def advance(self, dt: float, robots: list[tuple[float, float]]) -> None:
        """Advance each obstacle's clock unless that step would close in on a robot.

        An obstacle far from the robots is not even evaluated: ``_far_slack`` is a lower
        bound on its distance, shrunk by the most both can have moved since the last
        exact evaluation, and only when it drops below the yield radius is the pose
        computed again (physics runs at 50 Hz; most obstacles are far most of the time).
        An obstacle that stepped aside to pass a robot walks back onto its path once it
        is clear of every robot (:meth:`_pass_step`).
        """
        clocks, offsets = self.clocks, self.offsets
        reach = self.robot_speed_bound * dt
        for i, (obstacle, bound) in enumerate(self.bounds):
            step = self._direction[i] * dt
            radius = bound + self.yield_margin + obstacle.speed * dt
            back = obstacle.speed * dt  # how far it may walk back toward its path per step
            off = offsets[i]
            self._far_slack[i] -= obstacle.speed * dt + reach + (back if off else 0.0)
            if self._far_slack[i] > radius:  # certainly far: just walk
                self._walk_free(i, step, back)
                continue
            cx, cy = _at(obstacle, clocks[i], off)
            d_now = [math.hypot(cx - rx, cy - ry) for rx, ry in robots]
            d_cur = min(d_now)
            self._far_slack[i] = d_cur
            if d_cur > radius:
                self._walk_free(i, step, back)
                continue
            self.near[i] = True
            if self._passing[i]:
                if self._pass_step(i, step, robots, d_now, (cx, cy)):
                    continue
            # hold while the step would close in on any robot within the yield margin
            elif not _closes_in(obstacle, clocks[i] + step, off, robots, d_now,
                                bound + self.yield_margin):
                self._held[i] = 0.0
                clocks[i] += step
                continue
            self._held[i] += dt  # hold: wait for the robot ...
            if self._held[i] >= self.turn_back_after:
                self._held[i] = 0.0
                keep = bound + (self.pass_margin if self._passing[i] else self.yield_margin)
                if not _closes_in(obstacle, clocks[i] - step, off, robots, d_now, keep):
                    self._direction[i] = -self._direction[i]  # ... then turn back
                else:  # both ways lead past a robot: step aside and walk past it
                    self._passing[i] = True

    def _walk_free(self, i: int, step: float, back: float) -> None:
        """Obstacle ``i`` is clear of every robot: it walks on, back toward its path."""
        self._held[i] = 0.0
        self.near[i] = False
        self._passing[i] = self._backing[i] = False
        self.clocks[i] += step
        off = self.offsets[i]
        if off:
            self.offsets[i] = _shrink(off, back)

    def _pass_step(self, i: int, step: float, robots: list[tuple[float, float]],
                   d_now: list[float], at: tuple[float, float]) -> bool:
        """One step of obstacle ``i`` walking past a robot it could not wait out; whether
        it moved.

        It walks on along its path while edging sideways, away from the nearest robot, by
        up to its speed per step (at most ``sidestep_max`` off its path, and only onto
        cells its body clears), while that step keeps it beyond ``pass_margin`` of every
        robot's bounding circle.  Where no such step exists (the robot stands in its way
        too close to pass) it backs away from the robot, off its path (up to
        ``step_away_max``; along a wall when the straight way is blocked), and holds once
        it can do neither: it makes room as a person does, and the robot can then pass.
        """
        obstacle, bound = self.bounds[i]
        clock, off, keep = self.clocks[i], self.offsets[i], bound + self.pass_margin
        ax, ay, heading = obstacle.pose_at(clock)
        bx, by, _ = obstacle.pose_at(clock + step)
        if bx != ax or by != ay:  # the path's own direction (a box may keep a fixed yaw)
            heading = math.atan2(by - ay, bx - ax)
        nx, ny = -math.sin(heading), math.cos(heading)
        rx, ry = robots[min(range(len(robots)), key=d_now.__getitem__)]
        side = 1.0 if (at[0] - rx) * nx + (at[1] - ry) * ny >= 0.0 else -1.0
        edge = obstacle.speed * abs(step)
        ox, oy = off if off else (0.0, 0.0)
        lateral = max(-self.sidestep_max, min(self.sidestep_max,
                                              ox * nx + oy * ny + side * edge))
        aside = (ox + (lateral - (ox * nx + oy * ny)) * nx,
                 oy + (lateral - (ox * nx + oy * ny)) * ny)
        passing: list[tuple[float, Offset]] = [
            (clock + step, aside), (clock + step, off), (clock, aside)]
        backing: list[tuple[float, Offset]] = []
        gap = min(d_now)
        if gap > 0.0:  # back away from the nearest robot (straight, else along a wall)
            ux, uy = (at[0] - rx) / gap * edge, (at[1] - ry) / gap * edge
            for dx, dy in ((ux, uy), (ux, 0.0), (0.0, uy)):
                away = (ox + dx, oy + dy)
                if math.hypot(*away) <= self.step_away_max:
                    backing.append((clock, away))
        # once it has started to back away it keeps doing so until clear of the robot
        # (walking on again at once would close in, back away, close in ... in place)
        candidates = backing if self._backing[i] else passing + backing
        for k, (clock_next, off_next) in enumerate(candidates):
            if clock_next == clock and off_next == off:
                continue
            if not self._clear_of_walls(obstacle, clock_next, off_next):
                continue
            if _closes_in(obstacle, clock_next, off_next, robots, d_now, keep):
                continue
            if candidates is not backing and k >= len(passing):
                self._backing[i] = True
            self._held[i] = 0.0 if clock_next != clock else self._held[i]
            self.clocks[i] = clock_next
            self.offsets[i] = off_next if off_next != (0.0, 0.0) else None
            return True
        return False

    def _clear_of_walls(self, obstacle: MovingObstacle, clock: float, off: Offset) -> bool:
        """Whether the obstacle's body at ``clock`` + ``off`` clears the static grid (on
        its path it always may be: paths are the world author's)."""
        if not off:
            return True
        x, y = _at(obstacle, clock, off)
        w = self.world
        col = math.floor((x - w.origin_x) / w.resolution)
        row = math.floor((y - w.origin_y) / w.resolution)
        if not (0 <= row < self._dist.shape[0] and 0 <= col < self._dist.shape[1]):
            return True  # outside the grid is free space
        extent = obstacle.radius if obstacle.shape == "circle" else 0.5 * math.hypot(*obstacle.size)
        return bool(self._dist[row, col] >= extent + w.resolution)
