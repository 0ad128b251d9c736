"""Service and condition leaves of the navigation trees (Nav2 ``nav2_behavior_tree``).

``ClearEntireCostmap`` calls a clear service; ``IsPathValid``, ``GoalUpdated`` and
``GlobalUpdatedGoal`` are conditions; ``RemovePassedGoals`` trims the goal list of
NavigateThroughPoses; ``CountRecovery`` counts entries into the recovery branch.  They
share the blackboard conventions of :mod:`navstack.navigation.bt_nodes`.
"""

from __future__ import annotations

import logging
import math
from typing import Any

from py_trees.behaviour import Behaviour
from py_trees.common import Status

from navstack.core.errors import NavstackError
from navstack.core.msgs import Path
from navstack.navigation import messages as m
from navstack.navigation.bt_nodes import (
    FAILURES_KEY,
    RECOVERIES_KEY,
    Board,
    ClearEntireCostmapRequest,
    TreeContext,
)

log = logging.getLogger("navstack.bt")


class ClearEntireCostmap(Behaviour):
    """Nav2 ``ClearEntireCostmap``: call a clear service; FAILURE (recorded) if it fails."""

    def __init__(self, name: str, ctx: TreeContext, service_name: str) -> None:
        super().__init__(name)
        self.ctx, self.service_name = ctx, service_name
        self.board = Board(self, ctx, writes=(FAILURES_KEY,))

    def update(self) -> Status:
        try:
            self.ctx.bus.call(self.service_name, ClearEntireCostmapRequest())
        except NavstackError as exc:
            self.board.record_failure(self.name, 0, "", f"service '{self.service_name}': {exc}")
            return Status.FAILURE
        return Status.SUCCESS


class IsPathValid(Behaviour):
    """Nav2 ``IsPathValid``: SUCCESS when the ``is_path_valid`` service accepts ``{path}``.

    The service takes the :class:`Path` and answers a bool (or an object with
    ``is_valid``).  No path, or no service, is FAILURE: the tree then replans.
    """

    def __init__(self, ctx: TreeContext, service_name: str = m.IS_PATH_VALID,
                 name: str = "IsPathValid") -> None:
        super().__init__(name)
        self.ctx, self.service_name = ctx, service_name
        self.board = Board(self, ctx, reads=(ctx.path_key,))
        self._warned = False

    def update(self) -> Status:
        path = self.board.get(self.ctx.path_key)
        if not isinstance(path, Path) or not path.num_poses:
            return Status.FAILURE
        if self.service_name not in self.ctx.bus.services:
            if not self._warned:
                log.warning("no '%s' service: every replanning check will replan",
                            self.service_name)
                self._warned = True
            return Status.FAILURE
        answer = self.ctx.bus.call(self.service_name, path)
        return Status.SUCCESS if bool(getattr(answer, "is_valid", answer)) else Status.FAILURE


class GoalUpdated(Behaviour):
    """Nav2 ``GoalUpdated``: SUCCESS when ``{goal}``/``{goals}`` changed since this node was
    (re)started; its first tick after a reset only takes the snapshot (FAILURE)."""

    def __init__(self, ctx: TreeContext, name: str = "GoalUpdated") -> None:
        super().__init__(name)
        self.ctx = ctx
        self.board = Board(self, ctx, reads=(ctx.goal_key, ctx.goals_key))
        self._seen: tuple[Any, Any] | None = None

    def _snapshot(self) -> tuple[Any, Any]:
        return self.board.get(self.ctx.goal_key), self.board.get(self.ctx.goals_key)

    def changed(self, fresh: bool) -> bool:
        current = self._snapshot()
        if fresh or self._seen is None:
            self._seen = current
            return False
        if current != self._seen:
            self._seen = current
            return True
        return False

    def update(self) -> Status:
        return Status.SUCCESS if self.changed(self.status == Status.INVALID) else Status.FAILURE


class GlobalUpdatedGoal(GoalUpdated):
    """Nav2 ``GlobalUpdatedGoal``: like GoalUpdated but the snapshot survives resets, so
    any change since the tree's previous check counts."""

    def __init__(self, ctx: TreeContext, name: str = "GlobalUpdatedGoal") -> None:
        super().__init__(ctx, name)

    def update(self) -> Status:
        return Status.SUCCESS if self.changed(False) else Status.FAILURE


class RemovePassedGoals(Behaviour):
    """Nav2 ``RemovePassedGoals(radius)``: drop leading ``{goals}`` within ``radius`` [m]
    of the robot, always keeping the last one (Nav2 default radius 0.5 m)."""

    def __init__(self, ctx: TreeContext, radius: float = 0.5,
                 name: str = "RemovePassedGoals") -> None:
        super().__init__(name)
        self.ctx, self.radius = ctx, radius
        self.board = Board(self, ctx, writes=(ctx.goals_key,))

    def update(self) -> Status:
        goals = tuple(self.board.get(self.ctx.goals_key, ()))
        pose = self.ctx.robot_pose()
        if pose is None:
            return Status.FAILURE
        k = 0
        while len(goals) - k > 1:
            p = goals[k].pose.position
            if math.hypot(p.x - pose.x, p.y - pose.y) > self.radius:
                break
            k += 1
        if k:
            self.board.set(self.ctx.goals_key, goals[k:])
        return Status.SUCCESS


class CountRecovery(Behaviour):
    """Increment ``number_recoveries`` (the navigator's ``number_of_recoveries``)."""

    def __init__(self, ctx: TreeContext, name: str = "CountRecovery") -> None:
        super().__init__(name)
        self.board = Board(self, ctx, writes=(RECOVERIES_KEY,))

    def update(self) -> Status:
        self.board.set(RECOVERIES_KEY, int(self.board.get(RECOVERIES_KEY, 0)) + 1)
        return Status.SUCCESS
