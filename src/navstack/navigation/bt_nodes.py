"""Leaf nodes of the navigation trees (Nav2 ``nav2_behavior_tree/plugins``) on py_trees.

* Action nodes (Nav2 ``BtActionNode``): send their goal through an
  :class:`~navstack.runtime.actions.ActionClient` on the first tick, stay RUNNING until
  the server ends it, then SUCCESS / FAILURE by its status; a halt
  (``stop(Status.INVALID)``) cancels the goal.  Failures write ``<x>_error_code`` /
  ``<x>_error_msg`` (Nav2 ``error_code_id`` / ``error_msg_id`` ports) and append a
  :class:`FailureRecord` to the ``failures`` key, from which the navigator composes a
  sentence for the user.
* Service and condition nodes live in :mod:`navstack.navigation.bt_conditions`.  (The
  progress trigger around FollowPath is a decorator: ``bt_composites.ProgressGuard``.)

Every node reads and writes the blackboard through a py_trees client in the namespace
of the navigator that owns the tree (:class:`TreeContext`), so two navigators never
share state.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray
from py_trees.behaviour import Behaviour
from py_trees.common import Access, Status

from navstack.core.errors import NavstackError
from navstack.core.msgs import Header, Path, Pose2D, PoseStamped
from navstack.navigation import messages as m
from navstack.runtime.actions import ActionClient, ActionResult, GoalHandle, GoalStatus
from navstack.runtime.bus import Bus

log = logging.getLogger("navstack.bt")

FAILURES_KEY = "failures"
"""Blackboard key: tuple of :class:`FailureRecord`, oldest first (last 32 kept)."""
RECOVERIES_KEY = "number_recoveries"
"""Blackboard key (Nav2 name): recovery-branch entries since the goal was (re)set."""
PLAN_START_KEY = "plan_start"
"""Blackboard key (navstack): a :class:`PoseStamped` the next ``ComputePathToPose`` plans
from instead of the robot's pose, once (the navigator sets it when a goal continues from
the goal just reached: ``NavigateTreeParams.continue_from_goal_radius``)."""
_MAX_FAILURES = 32


@dataclass(frozen=True)
class ClearEntireCostmapRequest:
    """Request of the clear-costmap services (nav2_msgs/srv/ClearEntireCostmap: empty)."""


@dataclass(frozen=True)
class TreeContext:
    """What the nodes of one tree share.

    ``clock`` returns the runtime's (simulated) time [s]; ``robot_pose`` the robot base
    pose in the global frame or ``None`` when TF cannot provide it; ``namespace`` is the
    owning navigator's private blackboard namespace; ``server_timeout`` [s] is how long an
    action node waits for its server to exist (Nav2 ``default_server_timeout``); the keys
    are Nav2's ``goal_blackboard_id`` / ``goals_blackboard_id`` / ``path_blackboard_id``.
    """

    bus: Bus
    clock: Callable[[], float]
    robot_pose: Callable[[], Pose2D | None]
    namespace: str
    server_timeout: float = 0.02
    goal_key: str = "goal"
    goals_key: str = "goals"
    path_key: str = "path"


@dataclass(frozen=True)
class FailureRecord:
    """One node failure: which node, its error code (and enum name), why, and when."""

    node: str
    error_code: int
    code_name: str
    reason: str
    stamp: float

    def describe(self) -> str:
        code = f" ({self.code_name})" if self.code_name else ""
        return f"{self.node} failed: {self.reason}{code}"


class NodeInputError(NavstackError):
    """A node's blackboard input is missing or malformed (carries the error code)."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


def code_name(codes: type[IntEnum], code: int) -> str:
    """Enum name of ``code`` in ``codes`` (``"208"`` if it has none)."""
    try:
        return codes(code).name
    except ValueError:
        return str(code)


# --- path geometry ------------------------------------------------------------------------
def path_xy(path: Path) -> NDArray[np.float64]:
    """``(N, 2)`` positions of a path's poses."""
    return np.ascontiguousarray(path.as_array()[:, :2], dtype=np.float64)


def distance_remaining(xy: NDArray[np.float64], x: float, y: float) -> float:
    """Length [m] of the path ``xy`` (``(N, 2)``) from the point closest to ``(x, y)``.

    The closest point is the orthogonal projection onto the nearest segment, so the
    value decreases smoothly as the robot advances (Nav2 ``distance_remaining`` uses the
    closest vertex).  One compiled pass over the segments; 0 for an empty path.
    """
    n = len(xy)
    if n < 2:
        return 0.0
    seg2 = np.empty(n - 1)
    k, tk = _closest_segment(np.ascontiguousarray(xy, dtype=np.float64), float(x), float(y),
                             seg2)
    seg_len = np.sqrt(seg2)
    return float((1.0 - tk) * seg_len[k] + seg_len[k + 1:].sum())


@numba.njit(cache=True)
def _closest_segment(xy: NDArray[np.float64], x: float, y: float,
                     seg2: NDArray[np.float64]) -> tuple[int, float]:
    """Index of the segment nearest to ``(x, y)`` (the first of equals) and the
    projection parameter on it; fills ``seg2`` with the squared segment lengths."""
    best, best_k, best_t = np.inf, 0, 0.0
    for i in range(xy.shape[0] - 1):
        dx = xy[i + 1, 0] - xy[i, 0]
        dy = xy[i + 1, 1] - xy[i, 1]
        s2 = dx * dx + dy * dy
        seg2[i] = s2
        rx = x - xy[i, 0]
        ry = y - xy[i, 1]
        t = (rx * dx + ry * dy) / (s2 if s2 > 0.0 else 1.0)
        t = min(max(t, 0.0), 1.0)
        gx = rx - t * dx
        gy = ry - t * dy
        g2 = gx * gx + gy * gy
        if g2 < best:
            best, best_k, best_t = g2, i, t
    return best_k, best_t


class PathCache:
    """Positions of the last path seen, recomputed only when the path object changes."""

    def __init__(self) -> None:
        self._path: Path | None = None
        self._xy: NDArray[np.float64] = np.zeros((0, 2))

    def xy(self, path: Path) -> NDArray[np.float64]:
        if path is not self._path:
            self._path, self._xy = path, path_xy(path)
        return self._xy


def concatenate_paths(paths: Iterable[Path]) -> Path:
    """Join leg paths, dropping each leg's first pose when it repeats the previous end."""
    legs = list(paths)
    poses: list[PoseStamped] = []
    for leg in legs:
        start = 0
        if poses and leg.poses:
            p, q = poses[-1].pose.position, leg.poses[0].pose.position
            start = 1 if math.hypot(p.x - q.x, p.y - q.y) < 1e-9 else 0
        poses.extend(leg.poses[start:])
    header = legs[0].header if legs else Header()
    return Path(header, tuple(poses))


# --- blackboard access --------------------------------------------------------------------
class Board:
    """A behaviour's client on its navigator's blackboard namespace."""

    def __init__(self, node: Behaviour, ctx: TreeContext, reads: Iterable[str] = (),
                 writes: Iterable[str] = ()) -> None:
        self.client = node.attach_blackboard_client(name=node.name, namespace=ctx.namespace)
        self._clock = ctx.clock
        for key in reads:
            self.client.register_key(key, Access.READ)
        for key in writes:
            self.client.register_key(key, Access.WRITE)

    def get(self, key: str, default: Any = None) -> Any:
        try:
            return self.client.get(key)
        except KeyError:
            return default

    def set(self, key: str, value: Any) -> None:
        self.client.set(key, value)

    def unset(self, key: str) -> None:
        self.client.unset(key)

    def record_failure(self, node: str, code: int, name: str, reason: str,
                       code_key: str = "", msg_key: str = "") -> FailureRecord:
        """Append a :class:`FailureRecord`; also write the node's error-code ports."""
        record = FailureRecord(node, code, name, reason, self._clock())
        self.set(FAILURES_KEY, (*self.get(FAILURES_KEY, ())[-_MAX_FAILURES + 1:], record))
        if code_key:
            self.set(code_key, code)
        if msg_key:
            self.set(msg_key, reason)
        return record


# --- action nodes ---------------------------------------------------------------------------
class ActionNode(Behaviour):
    """Nav2 ``BtActionNode``: one action goal per activation, cancelled when halted.

    Subclasses give ``make_goal()`` (raise :class:`NodeInputError` for a missing input)
    and may override ``on_succeeded`` (return SUCCESS, FAILURE or RUNNING after sending
    a follow-up goal) and ``on_running`` (called on each tick while the goal runs).
    ``codes`` is the error-code enum used to name codes in reasons.
    """

    codes: type[IntEnum] = m.NavigatorErrorCode
    unknown_code: int = 0

    def __init__(self, name: str, ctx: TreeContext, action_name: str, error_prefix: str,
                 reads: Iterable[str] = (), writes: Iterable[str] = ()) -> None:
        super().__init__(name)
        self.ctx = ctx
        self.action_name = action_name
        self.code_key, self.msg_key = f"{error_prefix}_error_code", f"{error_prefix}_error_msg"
        self.board = Board(self, ctx, reads,
                           (self.code_key, self.msg_key, FAILURES_KEY, *writes))
        self._client: ActionClient[Any] = ActionClient(ctx.bus, action_name)
        self._handle: GoalHandle[Any] | None = None
        self._wait_start: float | None = None
        self.goals_sent = 0

    def make_goal(self) -> Any:
        raise NodeInputError(self.unknown_code, f"{type(self).__name__} defines no goal")

    def on_succeeded(self, result: ActionResult) -> Status:
        return Status.SUCCESS

    def on_running(self) -> None:
        """Hook called on each tick while the goal runs (e.g. to send an updated goal)."""

    def send(self, goal: Any) -> None:
        self._handle = self._client.send_goal(goal)
        self.goals_sent += 1

    def fail(self, code: int, reason: str) -> Status:
        self.board.record_failure(self.name, code, code_name(self.codes, code), reason,
                                  self.code_key, self.msg_key)
        return Status.FAILURE

    def initialise(self) -> None:
        self._handle = None
        self._wait_start = None

    def update(self) -> Status:
        if self._handle is None:
            if not self._client.server_ready():
                now = self.ctx.clock()
                self._wait_start = now if self._wait_start is None else self._wait_start
                if now - self._wait_start < self.ctx.server_timeout:
                    return Status.RUNNING
                known = ", ".join(sorted(self.ctx.bus.action_servers)) or "none"
                return self.fail(self.unknown_code,
                                 f"action server '{self.action_name}' is not available after "
                                 f"{self.ctx.server_timeout:g} s (known: {known}); start and "
                                 f"activate the node that provides it")
            try:
                goal = self.make_goal()
            except NodeInputError as exc:
                return self.fail(exc.code, str(exc))
            self.send(goal)
        else:
            self.on_running()
        handle = self._handle
        if handle is None or not handle.done or handle.result is None:
            return Status.RUNNING
        result = handle.result
        if result.status is GoalStatus.SUCCEEDED:
            self.board.set(self.code_key, 0)
            self.board.set(self.msg_key, "")
            return self.on_succeeded(result)
        text = result.error_msg or "no reason given"
        if result.status is GoalStatus.CANCELED:
            text = f"the server canceled the goal: {text}"
        elif result.status is GoalStatus.REJECTED:
            text = f"the server rejected the goal: {text}"
        return self.fail(result.error_code or self.unknown_code, text)

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self._handle is not None and not self._handle.done:
            self._handle.cancel()
        if new_status == Status.INVALID:
            self._handle = None


def _result_path(payload: Any) -> Path | None:
    """The Path of a planner result: the payload itself or its ``path`` attribute."""
    if isinstance(payload, Path):
        return payload
    path = getattr(payload, "path", None)
    return path if isinstance(path, Path) else None


class ComputePathToPose(ActionNode):
    """Nav2 ``ComputePathToPose``: plan from the robot to ``{goal}``, write ``{path}``.

    On failure the path key is removed (Nav2 clears its ``path`` output), so a stale
    path to an old goal is never followed or judged valid.
    """

    codes = m.PlannerErrorCode
    unknown_code = int(m.PlannerErrorCode.UNKNOWN)

    def __init__(self, ctx: TreeContext, planner_id: str = "GridBased",
                 name: str = "ComputePathToPose", error_prefix: str = "compute_path",
                 reads: Iterable[str] = ()) -> None:
        super().__init__(name, ctx, m.COMPUTE_PATH_TO_POSE, error_prefix,
                         reads=(ctx.goal_key, *reads), writes=(ctx.path_key, PLAN_START_KEY))
        self.planner_id = planner_id

    def make_goal(self) -> Any:
        goal = self.board.get(self.ctx.goal_key)
        if not isinstance(goal, PoseStamped):
            raise NodeInputError(self.unknown_code,
                                 f"no goal pose on the blackboard key '{self.ctx.goal_key}'")
        # Nav2's ``start`` input port: the goal just reached, for the first plan of a
        # goal that continues from it (``PLAN_START_KEY``); the robot's pose otherwise
        start = self.board.get(PLAN_START_KEY)
        return m.ComputePathToPoseGoal(goal=goal, planner_id=self.planner_id,
                                       start=start if isinstance(start, PoseStamped) else None)

    def leg_path(self, result: ActionResult) -> Path | None:
        path = _result_path(result.result)
        return path if path is not None and path.num_poses else None

    def on_succeeded(self, result: ActionResult) -> Status:
        path = self.leg_path(result)
        if path is None:
            return self.fail(int(m.PlannerErrorCode.NO_VALID_PATH),
                             f"the planner succeeded but returned no poses "
                             f"(result {type(result.result).__name__})")
        self.board.set(self.ctx.path_key, path)
        self.board.unset(PLAN_START_KEY)  # replans start from the robot, as in Nav2
        return Status.SUCCESS

    def fail(self, code: int, reason: str) -> Status:
        self.board.unset(self.ctx.path_key)
        self.board.unset(PLAN_START_KEY)
        return super().fail(code, reason)


class ComputePathThroughPoses(ComputePathToPose):
    """Path through ``{goals}``: one ComputePathToPose leg per pose, concatenated.

    Leg 1 starts at the robot, leg k at pose k-1 (Nav2 ``ComputePathThroughPoses`` does
    this inside the planner server; here it is done leg by leg from the tree).
    """

    def __init__(self, ctx: TreeContext, planner_id: str = "GridBased",
                 name: str = "ComputePathThroughPoses") -> None:
        super().__init__(ctx, planner_id, name, reads=(ctx.goals_key,))
        self._goals: tuple[PoseStamped, ...] = ()
        self._legs: list[Path] = []

    def initialise(self) -> None:
        super().initialise()
        self._goals, self._legs = (), []

    def make_goal(self) -> Any:
        goals = tuple(self.board.get(self.ctx.goals_key, ()))
        if not goals:
            raise NodeInputError(self.unknown_code,
                                 f"no poses on the blackboard key '{self.ctx.goals_key}'")
        self._goals, self._legs = goals, []
        return m.ComputePathToPoseGoal(goal=goals[0], planner_id=self.planner_id)

    def on_succeeded(self, result: ActionResult) -> Status:
        path = self.leg_path(result)
        k, n = len(self._legs), len(self._goals)
        if path is None:
            return self.fail(int(m.PlannerErrorCode.NO_VALID_PATH),
                             f"leg {k + 1} of {n}: the planner returned no poses")
        self._legs.append(path)
        if k + 1 < n:
            self.send(m.ComputePathToPoseGoal(goal=self._goals[k + 1], start=self._goals[k],
                                              planner_id=self.planner_id))
            return Status.RUNNING
        self.board.set(self.ctx.path_key, concatenate_paths(self._legs))
        return Status.SUCCESS

    def fail(self, code: int, reason: str) -> Status:
        if self._goals and not reason.startswith("leg "):
            reason = f"leg {len(self._legs) + 1} of {len(self._goals)}: {reason}"
        return super().fail(code, reason)


class FollowPath(ActionNode):
    """Nav2 ``FollowPath``: follow ``{path}``; a new path on the blackboard is sent as a
    new goal while running (the controller server preempts the old one; the old handle
    is cancelled if the server left it running)."""

    codes = m.ControllerErrorCode
    unknown_code = int(m.ControllerErrorCode.UNKNOWN)

    def __init__(self, ctx: TreeContext, controller_id: str = "FollowPath",
                 goal_checker_id: str = "", name: str = "FollowPath") -> None:
        super().__init__(name, ctx, m.FOLLOW_PATH, "follow_path", reads=(ctx.path_key,))
        self.controller_id, self.goal_checker_id = controller_id, goal_checker_id
        self._sent_path: Path | None = None

    def _goal(self, path: Path) -> m.FollowPathGoal:
        self._sent_path = path
        return m.FollowPathGoal(path, self.controller_id, self.goal_checker_id)

    def make_goal(self) -> Any:
        path = self.board.get(self.ctx.path_key)
        if not isinstance(path, Path) or not path.num_poses:
            raise NodeInputError(int(m.ControllerErrorCode.INVALID_PATH),
                                 f"no path to follow on the blackboard key '{self.ctx.path_key}'")
        return self._goal(path)

    def on_running(self) -> None:
        path = self.board.get(self.ctx.path_key)
        if isinstance(path, Path) and path.num_poses and path is not self._sent_path:
            old = self._handle
            self.send(self._goal(path))
            if old is not None and not old.done:
                old.cancel()


class _BehaviorAction(ActionNode):
    """A recovery behavior action with a fixed goal (Nav2 Spin/BackUp/Wait/DriveOnHeading)."""

    codes = m.BehaviorErrorCode
    unknown_code = int(m.BehaviorErrorCode.UNKNOWN)

    def __init__(self, name: str, ctx: TreeContext, action_name: str, error_prefix: str,
                 goal: Any) -> None:
        super().__init__(name, ctx, action_name, error_prefix)
        self.goal = goal

    def make_goal(self) -> Any:
        return self.goal


class Spin(_BehaviorAction):
    """Nav2 ``Spin`` (``spin_dist`` [rad], ``time_allowance`` [s], Nav2 defaults 1.57/10)."""

    def __init__(self, ctx: TreeContext, spin_dist: float = 1.57, time_allowance: float = 10.0,
                 name: str = "Spin") -> None:
        super().__init__(name, ctx, m.SPIN, "spin", m.SpinGoal(spin_dist, time_allowance))


class BackUp(_BehaviorAction):
    """Nav2 ``BackUp`` (``backup_dist`` [m], ``backup_speed`` [m/s], ``time_allowance``)."""

    def __init__(self, ctx: TreeContext, backup_dist: float = 0.30, backup_speed: float = 0.15,
                 time_allowance: float = 10.0, name: str = "BackUp") -> None:
        super().__init__(name, ctx, m.BACKUP, "backup",
                         m.BackUpGoal(backup_dist, backup_speed, time_allowance))


class DriveOnHeading(_BehaviorAction):
    """Nav2 ``DriveOnHeading`` (``dist_to_travel`` [m], ``speed`` [m/s], ``time_allowance``)."""

    def __init__(self, ctx: TreeContext, dist_to_travel: float = 0.15, speed: float = 0.025,
                 time_allowance: float = 10.0, name: str = "DriveOnHeading") -> None:
        super().__init__(name, ctx, m.DRIVE_ON_HEADING, "drive_on_heading",
                         m.DriveOnHeadingGoal(dist_to_travel, speed, time_allowance))


class Wait(_BehaviorAction):
    """Nav2 ``Wait`` (``wait_duration`` [s], Nav2 default 1.0; the default tree uses 5)."""

    def __init__(self, ctx: TreeContext, wait_duration: float = 1.0, name: str = "Wait") -> None:
        super().__init__(name, ctx, m.WAIT, "wait", m.WaitGoal(wait_duration))


# --- service and condition nodes -----------------------------------------------------------
