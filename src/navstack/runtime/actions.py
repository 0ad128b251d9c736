"""In-process actions: goal -> feedback* -> result, with cancel.

A server's ``on_goal(handle)`` accepts (returns ``True``) or rejects (returns a reason
string or ``False``) a goal; it then drives the goal from its own timers and ends it with
``succeed``, ``fail(code, reason)`` or ``canceled``.  A goal never ends without a status
and, when it fails, a human-readable reason.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any, Generic, TypeVar

from navstack.core.errors import BusError, UnknownNameError
from navstack.runtime.bus import Bus

G = TypeVar("G")


class GoalStatus(Enum):
    ACCEPTED = "ACCEPTED"
    EXECUTING = "EXECUTING"
    CANCELING = "CANCELING"
    SUCCEEDED = "SUCCEEDED"
    CANCELED = "CANCELED"
    FAILED = "FAILED"
    REJECTED = "REJECTED"

    @property
    def terminal(self) -> bool:
        return self in (GoalStatus.SUCCEEDED, GoalStatus.CANCELED, GoalStatus.FAILED,
                        GoalStatus.REJECTED)


@dataclass(frozen=True)
class ActionResult:
    """Terminal outcome of a goal: status, error code (0 = none), reason and payload."""

    status: GoalStatus
    error_code: int = 0
    error_msg: str = ""
    result: Any = None


class GoalHandle(Generic[G]):
    """Shared by server and client: the goal, its status, latest feedback and result."""

    def __init__(self, action: str, goal_id: int, goal: G) -> None:
        self.action = action
        self.goal_id = goal_id
        self.goal = goal
        self.status = GoalStatus.ACCEPTED
        self.feedback: Any = None
        self.result: ActionResult | None = None
        self.cancel_requested = False
        self._on_cancel: Callable[[GoalHandle[G]], None] | None = None
        self._feedback_cbs: list[Callable[[Any], None]] = []
        self._done_cbs: list[Callable[[ActionResult], None]] = []

    # --- server side ---------------------------------------------------------------
    def execute(self) -> None:
        if not self.status.terminal:
            self.status = GoalStatus.EXECUTING

    def publish_feedback(self, feedback: Any) -> None:
        self.feedback = feedback
        for cb in list(self._feedback_cbs):
            cb(feedback)

    def succeed(self, result: Any = None) -> None:
        self._finish(ActionResult(GoalStatus.SUCCEEDED, 0, "", result))

    def fail(self, error_code: int, reason: str, result: Any = None) -> None:
        if not reason:
            raise BusError(f"action '{self.action}': a failed goal needs a reason")
        self._finish(ActionResult(GoalStatus.FAILED, error_code, reason, result))

    def canceled(self, result: Any = None, reason: str = "canceled on request") -> None:
        self._finish(ActionResult(GoalStatus.CANCELED, 0, reason, result))

    def finish(self, result: ActionResult) -> None:
        """End the goal with a complete result (a proxy relaying a remote server's)."""
        if result.status is GoalStatus.FAILED and not result.error_msg:
            raise BusError(f"action '{self.action}': a failed goal needs a reason")
        self._finish(result)

    def _finish(self, result: ActionResult) -> None:
        if self.status.terminal:
            return
        self.status = result.status
        self.result = result
        for cb in list(self._done_cbs):
            cb(result)

    # --- client side ---------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.status.terminal

    def cancel(self) -> None:
        """Ask the server to cancel; the server ends the goal CANCELED when it has stopped."""
        if self.status.terminal or self.cancel_requested:
            return
        self.cancel_requested = True
        self.status = GoalStatus.CANCELING
        if self._on_cancel is not None:
            self._on_cancel(self)
        else:
            self.canceled()

    def add_feedback_callback(self, cb: Callable[[Any], None]) -> None:
        self._feedback_cbs.append(cb)

    def add_done_callback(self, cb: Callable[[ActionResult], None]) -> None:
        if self.result is not None:
            cb(self.result)
        else:
            self._done_cbs.append(cb)


class ActionServer(Generic[G]):
    """Accepts goals for one action name on a bus."""

    def __init__(self, bus: Bus, name: str, on_goal: Callable[[GoalHandle[G]], bool | str],
                 on_cancel: Callable[[GoalHandle[G]], None] | None = None) -> None:
        if name in bus.action_servers:
            raise BusError(f"action server '{name}' already exists")
        bus.action_servers[name] = self
        self.bus = bus
        self.name = name
        self.on_goal = on_goal
        self.on_cancel = on_cancel
        self._ids = itertools.count(1)
        self.goals: list[GoalHandle[G]] = []

    def submit(self, goal: G) -> GoalHandle[G]:
        handle: GoalHandle[G] = GoalHandle(self.name, next(self._ids), goal)
        handle._on_cancel = self.on_cancel
        verdict = self.on_goal(handle)
        if verdict is not True:
            reason = verdict if isinstance(verdict, str) and verdict else "goal rejected by server"
            handle._finish(ActionResult(GoalStatus.REJECTED, 1, reason))
        else:
            self.goals.append(handle)
        return handle

    def close(self) -> None:
        self.bus.action_servers.pop(self.name, None)


class ActionClient(Generic[G]):
    """Sends goals to the server of one action name on a bus."""

    def __init__(self, bus: Bus, name: str) -> None:
        self.bus = bus
        self.name = name

    def server_ready(self) -> bool:
        return self.name in self.bus.action_servers

    def send_goal(self, goal: G, feedback_cb: Callable[[Any], None] | None = None,
                  done_cb: Callable[[ActionResult], None] | None = None) -> GoalHandle[G]:
        servers = self.bus.action_servers
        server = servers.get(self.name)
        if server is None:
            raise UnknownNameError("action server", self.name, servers)
        handle = server.submit(goal)
        if feedback_cb is not None:
            handle.add_feedback_callback(feedback_cb)
        if done_cb is not None:
            handle.add_done_callback(done_cb)
        return handle
