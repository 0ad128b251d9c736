"""Compile the navigation kernels before a live session serves its first command.

The planners, controllers, costmap layers and SLAM scan matcher are
``numba.njit(cache=True)`` kernels: the first call in a fresh install compiles them
(58-74 s measured on a busy 2-core machine) and writes the cache that every later process loads in
well under a second.  In plain simulated time that only delays a run; in a live session
(``navstack run --web``, ``navstack telegram``) the compilation happens in the simulation
thread on the operator's first goal, so the robot starts half a minute late and every
other command queued behind that step -- a second goal, a cancel -- waits past
``LiveRunner.call``'s timeout.

:func:`warm_up_navigation` pays that cost before the session opens: it builds a twin of
the stack (same world, robot profile, Nav2 parameters, localization and map), drives it
half a metre in plain simulated time, and throws it away.  The live stack itself is not
touched.  With a warm cache the twin costs about as much as starting the stack once.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import INSCRIBED_INFLATED_OBSTACLE
from navstack.interfaces.stack import NavStack
from navstack.interfaces.stack_description import ExternalLocalization, PerfectLocalization

__all__ = ["WarmUp", "warm_up_navigation"]

STEP_M = 0.5
"""How far the twin drives [m]: enough for a plan, a few controller cycles and the
goal checker."""
MAP_WAIT_S = 5.0
"""Simulated seconds the twin waits for a free cell to appear (SLAM's first map)."""
_HEADINGS = (0.0, math.pi / 2, -math.pi / 2, math.pi)
"""Directions tried, relative to the spawn heading; on equal cost ahead wins (a
car-like robot can always go straight), then sideways, then behind."""


@dataclass(frozen=True)
class WarmUp:
    """What the twin did: ``reached`` its goal, and the wall seconds it took."""

    reached: bool
    seconds: float
    reason: str
    """Why the twin did not reach its goal ("" when it did)."""


def warm_up_navigation(stack: NavStack, timeout: float = 120.0) -> WarmUp:
    """Drive a twin of ``stack`` (not started, or started: it is not used) half a metre
    so that every kernel its navigation calls is compiled or loaded from the cache.

    A stack whose localization is external (something outside publishes ``map -> odom``)
    gets the simulator's perfect localization in the twin: the same navigation kernels,
    nobody else needed.  ``timeout``: simulated seconds the twin may take.
    """
    from navstack.missions import (
        Mission,
        MissionContext,
        MissionRunner,
        MissionStatus,
        NavigateToPose,
    )

    wall0 = time.monotonic()
    d = stack.description
    localization = (PerfectLocalization() if isinstance(d.localization, ExternalLocalization)
                    else d.localization)
    twin = NavStack(d.world, d.robot, d.nav2_params, d.seed, d.spawn,
                    localization=localization, physics_rate_hz=d.physics_rate_hz,
                    map_grid=d.map_grid).start()
    goal = None
    while goal is None and twin.now < MAP_WAIT_S:
        twin.run_for(0.25)  # the first scans in the costmaps (and SLAM's first map)
        goal = _free_goal_near(twin, d.spawn)
    if goal is None:
        return WarmUp(False, time.monotonic() - wall0,
                      f"no free cell {STEP_M} m around the spawn pose "
                      f"({d.spawn.x:.2f}, {d.spawn.y:.2f}) after {MAP_WAIT_S:.0f} s")
    ctx = MissionContext(twin.runtime)
    mission = Mission("warm-up", NavigateToPose(ctx, goal, name="warm-up"), ctx)
    result = MissionRunner(twin.runtime, mission).run(timeout=timeout)
    reached = result.status is MissionStatus.SUCCEEDED
    return WarmUp(reached, time.monotonic() - wall0, "" if reached else result.reason)


def _free_goal_near(stack: NavStack, spawn: Pose2D) -> Pose2D | None:
    """The pose ``STEP_M`` from the spawn pose (ahead, left, right or behind) on the
    cheapest global costmap cell the robot's centre may occupy, facing the way there.
    ``None`` while every candidate is unknown or inside the inscribed radius."""
    costmap = stack.global_costmap.costmap
    best: tuple[int, Pose2D] | None = None
    for turn in _HEADINGS:
        a = spawn.theta + turn
        x, y = spawn.x + STEP_M * math.cos(a), spawn.y + STEP_M * math.sin(a)
        cost = costmap.cost_at_world(x, y)  # unknown and off the map: 255
        if cost < INSCRIBED_INFLATED_OBSTACLE and (best is None or cost < best[0]):
            best = (cost, Pose2D(x, y, a))
    return None if best is None else best[1]
