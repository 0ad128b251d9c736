"""``BtNavigator``: the NavigateToPose / NavigateThroughPoses action servers (Nav2
``bt_navigator``), each goal executed by a py_trees tree from :mod:`.trees`.

Per goal: validate (finite pose, unit quaternion, known ``behavior_tree``), transform the
pose(s) into ``global_frame`` (goal frame unknown to TF -> FAILED ``TF_ERROR`` naming the
frame and the known frames), write them to the navigator's private blackboard namespace
and tick the tree every ``bt_loop_duration`` seconds, publishing ``NavigateFeedback`` on
every tick.  A goal that fails validation leaves a running goal untouched.

Preemption (Nav2 ``onPreempt``): a valid new goal for the running navigator and tree
updates ``goal``/``goals`` in place -- the tree keeps running and ``GlobalUpdatedGoal``
triggers a replan -- while the old goal ends CANCELED with reason "preempted by a new
goal"; navigation time and recovery count restart.  Unlike Nav2, whose tree carries the
old goal's spent retries and round-robin place into the new goal, the new goal gets the
recoveries of a fresh tree: every ``RecoveryNode`` has all its retries and the
``RecoveryActions`` round robin starts again from its first action
(:func:`.rewind_recoveries`).  A goal that arrives while a recovery runs halts the tree
and starts a fresh one, ending the recovery at once (the old goal was its reason).  An
explorer that moves its goal every few seconds while the robot is stuck would otherwise
meet its new goals with the old one's escalation -- a 5 s ``Wait`` where the first
action was backing away (docs/missions.md, "Measured": the ninth session).  A goal for the other
navigator or another tree also halts the running tree and starts a fresh one (Nav2
would reject it).  Cancel halts the tree, which cancels the
running planner/controller/behavior goals, and ends CANCELED.  A failure's reason is a
sentence composed from the failing nodes' records ("could not reach the goal after 6
recoveries: FollowPath failed: ...", "no path to the goal: planner says ...").

Holds (navstack addition): a :class:`~navstack.core.msgs.NavigationHold` on
``/navigation/hold`` (a vehicle driver whose link is lost) pauses navigation without
ending the goal: the running tree is halted -- the planner, controller and behavior
goals are cancelled, so nothing commands motion and no progress checker counts the
pause -- and the feedback carries ``paused_reason``.  Holds are kept per source; when
the last one is released the tree starts again from its root (a fresh plan from where
the robot is) under the same goal.

Continuing from a reached goal (navstack addition, off by default): with the tree
parameter ``continue_from_goal_radius`` > 0, a NavigateToPose goal accepted while the
robot stands within that distance of the goal it has just reached plans its first path
from that goal pose instead of from the robot's pose (``ComputePathToPose``'s ``start``;
Nav2's ``ComputePathThroughPoses`` starts leg k at pose k-1 the same way).  A waypoint
route then plans waypoint to waypoint: where exactly inside the goal tolerance the
robot stopped -- a few centimetres that a search on a grid turns into a different
route (docs/drivers.md, "Route stability") -- no longer decides the next leg.  Replans
(an invalid path, a changed goal, a recovery) start from the robot as usual.

Parameter deviation: ``bt_loop_duration`` defaults to 0.05 s (20 Hz, the controller's
rate) instead of Nav2's 0.01 s; each tick is an event of the simulated clock and 100 Hz
only multiplies the work without changing what the tree decides.
"""

from __future__ import annotations

import math
import uuid
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Access, Status
from pydantic import Field

from navstack.core.errors import ConfigError, TransformError, did_you_mean
from navstack.core.geometry import MAX_COORDINATE
from navstack.core.msgs import NavigationHold, Pose2D, PoseStamped
from navstack.core.params import Params
from navstack.navigation import messages as m
from navstack.navigation.bt_composites import recovery_running, rewind_recoveries
from navstack.navigation.bt_nodes import (
    FAILURES_KEY,
    PLAN_START_KEY,
    RECOVERIES_KEY,
    FailureRecord,
    PathCache,
    TreeContext,
    distance_remaining,
)
from navstack.navigation.trees import (
    DEFAULT_TREES,
    NAVIGATE_THROUGH_POSES_TREE,
    NAVIGATE_TO_POSE_TREE,
    NavigateTreeParams,
    TreeBuilder,
    release_tree,
)
from navstack.runtime.actions import ActionServer, GoalHandle
from navstack.runtime.bus import LATCHED
from navstack.runtime.node import LifecycleState, Node, Runtime

NavigatorName = Literal["navigate_to_pose", "navigate_through_poses"]
SPEED_WINDOW = 1.0
"""Seconds of pose history used to estimate the robot speed for the time estimate."""
_PLANNER_TO_NAV: dict[int, m.NavigatorErrorCode] = {
    m.PlannerErrorCode.GOAL_OCCUPIED: m.NavigatorErrorCode.GOAL_OCCUPIED,
    m.PlannerErrorCode.GOAL_OUTSIDE_MAP: m.NavigatorErrorCode.GOAL_OUTSIDE_MAP,
    m.PlannerErrorCode.TF_ERROR: m.NavigatorErrorCode.TF_ERROR,
}


class BtNavigatorParams(Params):
    """Nav2 ``bt_navigator`` parameters (names as Nav2; see module docstring for the one
    changed default).  ``default_nav_*_bt_xml`` name a tree builder instead of a file."""

    bt_loop_duration: float = Field(0.05, gt=0.0)
    default_server_timeout: float = Field(0.02, gt=0.0)
    navigators: tuple[NavigatorName, ...] = ("navigate_to_pose", "navigate_through_poses")
    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    goal_blackboard_id: str = "goal"
    goals_blackboard_id: str = "goals"
    path_blackboard_id: str = "path"
    default_nav_to_pose_bt_xml: str = NAVIGATE_TO_POSE_TREE
    default_nav_through_poses_bt_xml: str = NAVIGATE_THROUGH_POSES_TREE
    hold_topic: str = "/navigation/hold"


@dataclass(frozen=True)
class NavigateResult:
    """Payload of every NavigateToPose / NavigateThroughPoses result (navstack addition)."""

    number_of_recoveries: int
    navigation_time: float


class _GoalError(Exception):
    """A goal pose cannot be expressed in the global frame (carries the reason)."""


@dataclass
class _Run:
    kind: NavigatorName
    tree_name: str
    root: Behaviour
    handle: GoalHandle[Any]
    start: float


def pose_problem(poses: tuple[PoseStamped, ...]) -> str | None:
    """Why these goal poses cannot be used (NaN/inf, non-unit quaternion), or ``None``."""
    for i, ps in enumerate(poses):
        p, q = ps.pose.position, ps.pose.orientation
        what = "goal pose" if len(poses) == 1 else f"goal pose {i}"
        values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
        if not all(math.isfinite(v) for v in values):
            return (f"{what} contains NaN or inf (position ({p.x}, {p.y}, {p.z}), orientation "
                    f"({q.x}, {q.y}, {q.z}, {q.w})); send finite numbers")
        if any(abs(v) > MAX_COORDINATE for v in (p.x, p.y, p.z)):
            return (f"{what} position ({p.x:g}, {p.y:g}, {p.z:g}) is outside ±"
                    f"{MAX_COORDINATE:g} m; goals are in metres in the goal's frame")
        norm = math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w)
        if abs(norm - 1.0) > 1e-3:
            return (f"{what} orientation quaternion has length {norm:.4f}, not 1; normalise "
                    f"it (yaw θ is (0, 0, sin(θ/2), cos(θ/2)))")
    return None


class BtNavigator(Node):
    """NavigateToPose / NavigateThroughPoses action servers driving behavior trees.

    ``trees`` maps tree names (a goal's ``behavior_tree`` field) to builders; the
    defaults are Nav2's two ``*_w_replanning_and_recovery`` trees, parameterised by
    ``tree_params``.
    """

    def __init__(self, runtime: Runtime, params: BtNavigatorParams | None = None,
                 tree_params: NavigateTreeParams | None = None,
                 trees: Mapping[str, TreeBuilder] | None = None,
                 name: str = "bt_navigator") -> None:
        super().__init__(name, runtime)
        self.params = p = params or BtNavigatorParams()
        self.tree_params = tree_params or NavigateTreeParams()
        self.trees = dict(DEFAULT_TREES if trees is None else trees)
        for key, tree in (("default_nav_to_pose_bt_xml", p.default_nav_to_pose_bt_xml),
                          ("default_nav_through_poses_bt_xml",
                           p.default_nav_through_poses_bt_xml)):
            if tree not in self.trees:
                raise ConfigError(f"unknown tree '{tree}'; known: {', '.join(sorted(self.trees))}",
                                  key_path=f"{name}.{key}",
                                  suggestion=did_you_mean(tree, self.trees).strip(" ()"))
        self.namespace = f"/{name}_{uuid.uuid4().hex[:8]}"
        self.ctx = TreeContext(runtime.bus, lambda: self.now, self.robot_pose, self.namespace,
                               p.default_server_timeout, p.goal_blackboard_id,
                               p.goals_blackboard_id, p.path_blackboard_id)
        self._board = py_trees.blackboard.Client(name=name, namespace=self.namespace)
        for key in (self.ctx.goal_key, self.ctx.goals_key, self.ctx.path_key, FAILURES_KEY,
                    RECOVERIES_KEY, PLAN_START_KEY):
            self._board.register_key(key, Access.WRITE)
        self._board_released = False
        self._servers: list[ActionServer[Any]] = []
        self._run: _Run | None = None
        self._path_cache = PathCache()
        self._history: deque[tuple[float, float, float]] = deque()
        self.holds: dict[str, str] = {}
        """Active holds: source -> reason (see module docstring)."""
        self.paused_at: float | None = None
        self._reached: PoseStamped | None = None
        """The goal the last run succeeded at (cleared when the next goal is accepted)."""

    # --- lifecycle -------------------------------------------------------------------
    def on_configure(self) -> None:
        if "navigate_to_pose" in self.params.navigators:
            self._servers.append(ActionServer(self.bus, m.NAVIGATE_TO_POSE, self._on_pose_goal,
                                              self._on_cancel))
        if "navigate_through_poses" in self.params.navigators:
            self._servers.append(ActionServer(self.bus, m.NAVIGATE_THROUGH_POSES,
                                              self._on_poses_goal, self._on_cancel))
        self.create_timer(self.params.bt_loop_duration, self._tick)
        self.create_subscription(self.params.hold_topic, NavigationHold, self._on_hold, LATCHED)

    def on_deactivate(self) -> None:
        run = self._run
        if run is not None:
            result = self._result(run)
            self._finish()
            run.handle.canceled(result, reason=f"{self.name} was deactivated")

    def on_cleanup(self) -> None:
        for server in self._servers:
            server.close()
        self._servers.clear()

    def on_shutdown(self) -> None:
        self._finish()
        if not self._board_released:
            self._board.unregister(clear=True)
            self._board_released = True

    # --- queries -----------------------------------------------------------------------
    def robot_pose(self) -> Pose2D | None:
        """Robot base pose in ``global_frame`` from TF, ``None`` if unavailable."""
        try:
            return self.tf.lookup_pose2d(self.params.global_frame, self.params.robot_base_frame)
        except TransformError:
            return None

    @property
    def active_goal(self) -> GoalHandle[Any] | None:
        return self._run.handle if self._run is not None else None

    @property
    def tree(self) -> Behaviour | None:
        """The running tree (for introspection, e.g. ``py_trees.display``)."""
        return self._run.root if self._run is not None else None

    # --- goals -------------------------------------------------------------------------
    def _on_pose_goal(self, handle: GoalHandle[m.NavigateToPoseGoal]) -> bool | str:
        goal = handle.goal
        return self._accept(handle, "navigate_to_pose", goal.behavior_tree, (goal.pose,))

    def _on_poses_goal(self, handle: GoalHandle[m.NavigateThroughPosesGoal]) -> bool | str:
        goal = handle.goal
        if not goal.poses:
            return "NavigateThroughPoses needs at least one pose; got none"
        return self._accept(handle, "navigate_through_poses", goal.behavior_tree,
                            tuple(goal.poses))

    def _accept(self, handle: GoalHandle[Any], kind: NavigatorName, tree_name: str,
                poses: tuple[PoseStamped, ...]) -> bool | str:
        if self.state is not LifecycleState.ACTIVE:
            return f"{self.name} is not active (state {self.state.value}); activate it first"
        problem = pose_problem(poses)
        if problem is not None:
            return problem
        default = (self.params.default_nav_to_pose_bt_xml if kind == "navigate_to_pose"
                   else self.params.default_nav_through_poses_bt_xml)
        tree_name = tree_name or default
        if tree_name not in self.trees:
            return (f"unknown behavior_tree '{tree_name}'{did_you_mean(tree_name, self.trees)}; "
                    f"known: {', '.join(sorted(self.trees))}")
        try:
            goal_poses = tuple(self._to_global(ps) for ps in poses)
        except _GoalError as exc:
            handle.execute()
            handle.fail(int(m.NavigatorErrorCode.TF_ERROR), str(exc),
                        NavigateResult(0, 0.0))
            return True
        run = self._run
        if run is not None:
            old, old_result = run.handle, self._result(run)
            if (run.kind == kind and run.tree_name == tree_name
                    and not recovery_running(run.root)):
                rewind_recoveries(run.root)
                run.handle, run.start = handle, self.now
                self._write_goal(kind, goal_poses)
                handle.execute()
                old.canceled(old_result, reason="preempted by a new goal")
                return True
            self._finish()
            old.canceled(old_result, reason="preempted by a new goal")
        self._write_goal(kind, goal_poses)
        start = self._continue_from() if kind == "navigate_to_pose" else None
        if start is not None:
            self._board.set(PLAN_START_KEY, start)
        root = self.trees[tree_name](self.ctx, self.tree_params)
        self._run = _Run(kind, tree_name, root, handle, self.now)
        self._history.clear()
        handle.execute()
        return True

    def _continue_from(self) -> PoseStamped | None:
        """The goal just reached, if the robot is still within ``continue_from_goal_radius``
        of it (module docstring); consumed: only the goal right after it continues."""
        reached, self._reached = self._reached, None
        radius = self.tree_params.continue_from_goal_radius
        if reached is None or radius <= 0.0:
            return None
        pose = self.robot_pose()
        if pose is None:
            return None
        p = reached.pose.position
        return reached if math.hypot(p.x - pose.x, p.y - pose.y) <= radius else None

    def _to_global(self, ps: PoseStamped) -> PoseStamped:
        frame, target = ps.header.frame_id, self.params.global_frame
        if not frame:
            raise _GoalError(f"goal pose has an empty header.frame_id; set it (e.g. to "
                             f"'{target}', the global_frame)")
        if frame not in self.tf:
            known = ", ".join(self.tf.frames()) or "none (no transforms received yet)"
            raise _GoalError(f"goal frame '{frame}' is not known to TF"
                             f"{did_you_mean(frame, self.tf.frames())}; known frames: {known}")
        if frame == target:
            return ps
        try:
            frame_in_target = self.tf.lookup_pose2d(target, frame)
        except TransformError as exc:
            raise _GoalError(f"cannot transform the goal from '{frame}' into the global frame "
                             f"'{target}': {exc}") from None
        return PoseStamped.from_pose2d(frame_in_target.compose(ps.to_pose2d()), target,
                                       ps.header.stamp)

    def _write_goal(self, kind: NavigatorName, poses: tuple[PoseStamped, ...]) -> None:
        board, ctx = self._board, self.ctx
        if kind == "navigate_to_pose":
            board.set(ctx.goal_key, poses[0])
            board.unset(ctx.goals_key)
        else:
            board.set(ctx.goals_key, poses)
            board.unset(ctx.goal_key)
        board.unset(ctx.path_key)
        board.unset(PLAN_START_KEY)
        board.set(FAILURES_KEY, ())
        board.set(RECOVERIES_KEY, 0)

    def _on_cancel(self, handle: GoalHandle[Any]) -> None:
        run = self._run
        if run is not None and run.handle is handle:
            result = self._result(run)
            self._finish()
            handle.canceled(result)
        else:
            handle.canceled()

    def _finish(self) -> None:
        if self._run is not None:
            release_tree(self._run.root)
            self._run = None

    # --- holds -------------------------------------------------------------------------
    def _on_hold(self, msg: NavigationHold) -> None:
        if msg.hold:
            self.holds[msg.source] = msg.reason
        else:
            self.holds.pop(msg.source, None)

    @property
    def paused_reason(self) -> str:
        """Why navigation is on hold ("" when it is not)."""
        return "; ".join(self.holds.values())

    # --- ticking -----------------------------------------------------------------------
    def _get(self, key: str, default: Any = None) -> Any:
        try:
            return self._board.get(key)
        except KeyError:
            return default

    def _result(self, run: _Run) -> NavigateResult:
        return NavigateResult(int(self._get(RECOVERIES_KEY, 0)), self.now - run.start)

    def _tick(self) -> None:
        run = self._run
        if run is None:
            self.paused_at = None
            return
        if self.holds:
            if self.paused_at is None:
                self.paused_at = self.now
                if run.root.status != Status.INVALID:
                    run.root.stop(Status.INVALID)  # cancels the running actions
            self._publish_feedback(run)
            return
        self.paused_at = None
        run.root.tick_once()
        if run is not self._run:
            return
        status = run.root.status
        if status == Status.SUCCESS:
            result = self._result(run)
            goals = self._get(self.ctx.goals_key) or (self._get(self.ctx.goal_key),)
            self._reached = goals[-1] if isinstance(goals[-1], PoseStamped) else None
            self._finish()
            run.handle.succeed(result)
        elif status == Status.FAILURE:
            result = self._result(run)
            code, reason = self.failure_reason()
            self._finish()
            run.handle.fail(code, reason, result)
        else:
            self._publish_feedback(run)

    def _publish_feedback(self, run: _Run) -> None:
        pose = self.robot_pose()
        if pose is None:
            return
        now, hist = self.now, self._history
        hist.append((now, pose.x, pose.y))
        while len(hist) > 2 and now - hist[1][0] >= SPEED_WINDOW:
            hist.popleft()
        t0, x0, y0 = hist[0]
        speed = math.hypot(pose.x - x0, pose.y - y0) / (now - t0) if now > t0 else 0.0
        path = self._get(self.ctx.path_key)
        dist = (distance_remaining(self._path_cache.xy(path), pose.x, pose.y)
                if path is not None else 0.0)
        eta = dist / speed if speed > 0.01 and dist > 0.1 else 0.0  # Nav2 thresholds
        remaining = len(self._get(self.ctx.goals_key, ())) if run.kind != "navigate_to_pose" else 0
        run.handle.publish_feedback(m.NavigateFeedback(
            pose, now - run.start, eta, int(self._get(RECOVERIES_KEY, 0)), dist, remaining,
            self.paused_reason))

    def activity(self) -> str:
        """What the running goal is doing, in a few words ("" with no goal; navstack
        addition, for whoever must stop a goal that has not ended, e.g. a benchmark's
        time limit): "recovering (BackUp), 6 of 6 recoveries used; last failure:
        FollowPath failed: ...", "navigating (FollowPath), 0 of 6 recoveries used",
        or "paused: <hold reason>"."""
        run = self._run
        if run is None:
            return ""
        if self.holds:
            return f"paused: {self.paused_reason}"
        tip = run.root.tip()
        chain: list[str] = []
        node = tip
        while node is not None:
            chain.append(node.name)
            node = node.parent
        doing = "recovering" if "RecoveryBranch" in chain else "navigating"
        text = f"{doing} ({tip.name if tip is not None else 'starting'}), " \
               f"{int(self._get(RECOVERIES_KEY, 0))} of " \
               f"{self.tree_params.number_of_retries} recoveries used"
        failures: tuple[FailureRecord, ...] = self._get(FAILURES_KEY, ())
        if failures:
            text += f"; last failure: {failures[-1].describe()}"
        return text

    def failure_reason(self) -> tuple[int, str]:
        """Navigator error code and a sentence for the current goal's failure records.

        The primary cause is the last planner (codes 2xx) or controller (1xx) failure; if
        a recovery failed after it, that is appended.
        """
        failures: tuple[FailureRecord, ...] = self._get(FAILURES_KEY, ())
        n = int(self._get(RECOVERIES_KEY, 0))
        after = f"{n} recover{'y' if n == 1 else 'ies'}"
        primary = next((f for f in reversed(failures) if 100 <= f.error_code < 300), None)
        last = failures[-1] if failures else None
        if primary is None:
            detail = last.describe() if last is not None else "no node reported an error"
            return int(m.NavigatorErrorCode.UNKNOWN), f"navigation failed after {after}: {detail}"
        if primary.error_code >= 200:
            code = _PLANNER_TO_NAV.get(primary.error_code, m.NavigatorErrorCode.NO_VALID_PATH)
            reason = (f"no path to the goal: planner says {primary.reason} "
                      f"({primary.code_name}); gave up after {after}")
        else:
            stalled = primary.error_code == m.ControllerErrorCode.FAILED_TO_MAKE_PROGRESS
            code = m.NavigatorErrorCode.NO_PROGRESS if stalled \
                else m.NavigatorErrorCode.RECOVERIES_EXHAUSTED
            reason = f"could not reach the goal after {after}: {primary.describe()}"
        if last is not None and last is not primary:
            reason += f"; then the recovery failed: {last.describe()}"
        return int(code), reason
