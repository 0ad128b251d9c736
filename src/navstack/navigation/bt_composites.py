"""Control and decorator nodes of the navigation trees on py_trees.

py_trees ships Sequence/Selector/Parallel; Nav2's navigation trees
(``navigate_to_pose_w_replanning_and_recovery.xml``) need four more control nodes from
``nav2_behavior_tree/plugins/control`` and ``.../decorator``.  Their semantics are
reproduced tick for tick:

* :class:`PipelineSequence` re-ticks every earlier child on each tick, so a RUNNING
  planner branch and a RUNNING controller run side by side (``pipeline_sequence.cpp``).
* :class:`RecoveryNode` ticks child 1; on its failure ticks child 2 (the recovery) and
  then child 1 again, at most ``number_of_retries`` times (``recovery_node.cpp``).
* :class:`RoundRobin` ticks the next child each time it is entered, so successive
  recoveries escalate (clear -> spin -> wait -> backup) (``round_robin_node.cpp``).
* :class:`RateController` ticks its child at most at ``hz`` by the simulated clock it is
  given, never the wall clock (``rate_controller.cpp``).
* :class:`ProgressGuard` (navstack) fails a FollowPath child that stops making progress.

"Halt" in BehaviorTree.CPP is py_trees' ``stop(Status.INVALID)``: it percolates down and
makes running action nodes cancel their goals.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from navstack.core.msgs import Path
from navstack.navigation import messages as m
from navstack.navigation.bt_nodes import (
    FAILURES_KEY,
    Board,
    PathCache,
    TreeContext,
    distance_remaining,
)

_EPS = 1e-9
"""Slack [s] on period comparisons: sums of float timer periods drift by a few ulp."""


def halt_children(node: Behaviour) -> None:
    """Reset every child that is not INVALID (BT.CPP ``haltChildren``)."""
    for child in node.children:
        if child.status != Status.INVALID:
            child.stop(Status.INVALID)


class PipelineSequence(py_trees.composites.Composite):
    """Nav2 ``PipelineSequence``: tick child 1 until it succeeds, then children 1 and 2
    until 2 succeeds, and so on.

    A RUNNING child that was already passed on an earlier tick does not stop the sweep,
    so the replanning branch (child 1) keeps being re-ticked while the controller
    (child 2) runs.  Any FAILURE halts all children and fails the sequence; SUCCESS when
    the last child succeeds.
    """

    def __init__(self, name: str, children: Sequence[Behaviour] | None = None) -> None:
        super().__init__(name, children)
        self._last_child_ticked = 0

    def tick(self) -> Iterator[Behaviour]:
        if self.status != Status.RUNNING:
            self._last_child_ticked = 0
            halt_children(self)
            self.initialise()
        for index, child in enumerate(self.children):
            yield from child.tick()
            if child.status == Status.FAILURE:
                self.current_child = child
                self._last_child_ticked = 0
                halt_children(self)
                self.stop(Status.FAILURE)
                yield self
                return
            if child.status == Status.RUNNING and index >= self._last_child_ticked:
                self._last_child_ticked = index
                self.current_child = child
                self.status = Status.RUNNING
                yield self
                return
        self._last_child_ticked = 0
        halt_children(self)
        self.stop(Status.SUCCESS)
        yield self


class RecoveryNode(py_trees.composites.Composite):
    """Nav2 ``RecoveryNode(number_of_retries)`` with exactly two children.

    Child 1 SUCCESS -> SUCCESS.  Child 1 FAILURE -> tick child 2 (in the same tick);
    child 2 SUCCESS -> count a retry and tick child 1 again; child 2 FAILURE -> FAILURE.
    Once ``number_of_retries`` recoveries have run, the next failure of child 1 is
    final.  ``retry_count`` is the number of recoveries of the current activation.
    """

    def __init__(self, name: str, children: Sequence[Behaviour], number_of_retries: int = 1
                 ) -> None:
        if len(children) != 2:
            raise ValueError(f"RecoveryNode '{name}' needs exactly 2 children (the action "
                             f"and its recovery), got {len(children)}")
        if number_of_retries < 0:
            raise ValueError(f"RecoveryNode '{name}': number_of_retries must be >= 0, "
                             f"got {number_of_retries}")
        super().__init__(name, children)
        self.number_of_retries = number_of_retries
        self.retry_count = 0
        self._index = 0

    @property
    def recovering(self) -> bool:
        """True while the node runs its recovery child (child 2)."""
        return self.status == Status.RUNNING and self._index == 1

    def _finish(self, status: Status) -> None:
        self._index = 0
        halt_children(self)
        self.stop(status)

    def tick(self) -> Iterator[Behaviour]:
        if self.status != Status.RUNNING:
            self.retry_count = 0
            self._index = 0
            halt_children(self)
            self.initialise()
        while True:
            child = self.children[self._index]
            self.current_child = child
            yield from child.tick()
            status = child.status
            if status == Status.RUNNING:
                self.status = Status.RUNNING
                yield self
                return
            if self._index == 0:
                if status == Status.SUCCESS:
                    self._finish(Status.SUCCESS)
                    yield self
                    return
                if self.retry_count >= self.number_of_retries:
                    self._finish(Status.FAILURE)
                    yield self
                    return
                child.stop(Status.INVALID)
                self._index = 1
            else:
                if status == Status.FAILURE:
                    self._finish(Status.FAILURE)
                    yield self
                    return
                child.stop(Status.INVALID)
                self.retry_count += 1
                self._index = 0


class RoundRobin(py_trees.composites.Composite):
    """Nav2 ``RoundRobin``: each entry ticks the child after the one that ran last.

    A child's SUCCESS ends the node with SUCCESS (the index stays on the next child, so
    the next entry escalates); a FAILURE moves on to the next child in the same tick;
    FAILURE when every child failed in turn.  Halting the node while a child runs
    resets it to the first child (BT.CPP ``RoundRobinNode::halt``); being reset after it
    finished does not.
    """

    def __init__(self, name: str, children: Sequence[Behaviour] | None = None) -> None:
        super().__init__(name, children)
        self.next_index = 0
        self._failed = 0

    def tick(self) -> Iterator[Behaviour]:
        if self.status != Status.RUNNING:
            self.initialise()
        n = len(self.children)
        while self._failed < n:
            child = self.children[self.next_index]
            self.current_child = child
            yield from child.tick()
            status = child.status
            if status != Status.RUNNING:
                self.next_index = (self.next_index + 1) % n
            if status == Status.SUCCESS:
                self._failed = 0
                halt_children(self)
                self.stop(Status.SUCCESS)
                yield self
                return
            if status == Status.RUNNING:
                self.status = Status.RUNNING
                yield self
                return
            self._failed += 1
        self.rewind()
        halt_children(self)
        self.stop(Status.FAILURE)
        yield self

    def stop(self, new_status: Status = Status.INVALID) -> None:
        if new_status == Status.INVALID and self.status == Status.RUNNING:
            self.rewind()
        super().stop(new_status)

    def rewind(self) -> None:
        """Start the next entry from the first child."""
        self.next_index = 0
        self._failed = 0


def recovery_running(root: Behaviour) -> bool:
    """True while any :class:`RecoveryNode` of the tree is running its recovery child."""
    return any(isinstance(node, RecoveryNode) and node.recovering for node in root.iterate())


def rewind_recoveries(root: Behaviour) -> None:
    """Give a running tree the recovery state of a fresh one, for a new goal: every
    :class:`RecoveryNode` has all its retries again and every :class:`RoundRobin` starts
    from its first child.  Call it only when no recovery runs (:func:`recovery_running`):
    a running round robin keeps its place."""
    for node in root.iterate():
        if isinstance(node, RecoveryNode):
            node.retry_count = 0
        elif isinstance(node, RoundRobin) and node.status != Status.RUNNING:
            node.rewind()


class RateController(py_trees.decorators.Decorator):
    """Nav2 ``RateController(hz)``: tick the child at most every ``1/hz`` seconds.

    The child is ticked on the first tick after the node is (re)started, on every tick
    while it is RUNNING, and once the period has elapsed since its last SUCCESS; in
    between the node reports RUNNING without ticking it (so a PipelineSequence moves on
    to its later children).  ``clock`` returns the runtime's (simulated) time [s].
    """

    def __init__(self, name: str, child: Behaviour, hz: float, clock: Callable[[], float]
                 ) -> None:
        if not hz > 0.0:
            raise ValueError(f"RateController '{name}': hz must be > 0, got {hz}")
        super().__init__(name=name, child=child)
        self.period = 1.0 / hz
        self._clock = clock
        self._start = 0.0
        self._first = True

    def tick(self) -> Iterator[Behaviour]:
        now = self._clock()
        if self.status == Status.INVALID:
            self._start = now
            self._first = True
        child = self.decorated
        new_status = Status.RUNNING
        if self._first or child.status == Status.RUNNING or now - self._start >= self.period - _EPS:
            self._first = False
            yield from child.tick()
            new_status = child.status
            if new_status == Status.SUCCESS:
                self._start = now
        if new_status != Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def update(self) -> Status:
        return self.status


class ProgressGuard(py_trees.decorators.Decorator):
    """Fail the (FollowPath) child when it stops making progress toward the goal.

    While the child runs, the distance remaining along ``{path}`` from the robot's
    closest point is measured every tick.  If it has not fallen by at least
    ``progress_epsilon`` [m] within ``progress_dwell_time`` [s], the child is halted
    (its controller goal cancelled) and the guard returns FAILURE with
    ``FAILED_TO_MAKE_PROGRESS`` recorded under the child's name, so the tree's recovery
    takes over.  A replanned path keeps the progress already made in the current window
    (the reference is re-based onto the new path), so frequent replans neither reset nor
    trip the timer.  Without a robot pose or a path no measurement is taken but the
    window keeps running.
    """

    def __init__(self, child: Behaviour, ctx: TreeContext, progress_epsilon: float = 0.05,
                 progress_dwell_time: float = 10.0, error_prefix: str = "follow_path",
                 name: str = "ProgressGuard") -> None:
        super().__init__(name=name, child=child)
        self.ctx, self.epsilon, self.dwell = ctx, progress_epsilon, progress_dwell_time
        self.code_key, self.msg_key = f"{error_prefix}_error_code", f"{error_prefix}_error_msg"
        self.board = Board(self, ctx, reads=(ctx.path_key,),
                           writes=(self.code_key, self.msg_key, FAILURES_KEY))
        self._cache = PathCache()
        self._ref: float | None = None
        self._last = 0.0
        self._t_ref = 0.0
        self._path: Path | None = None
        self.fired = 0

    def _stall_reason(self) -> str | None:
        now = self.ctx.clock()
        path, pose = self.board.get(self.ctx.path_key), self.ctx.robot_pose()
        if isinstance(path, Path) and path.num_poses and pose is not None:
            d = distance_remaining(self._cache.xy(path), pose.x, pose.y)
            if self._ref is None:
                self._ref, self._last, self._t_ref, self._path = d, d, now, path
                return None
            if path is not self._path:
                self._ref, self._path = d + (self._ref - self._last), path
            self._last = d
            if self._ref - d >= self.epsilon:
                self._ref, self._t_ref = d, now
                return None
        if self._ref is None or now - self._t_ref < self.dwell - _EPS:
            return None
        return (f"made no progress toward the goal: the distance remaining along the path "
                f"went from {self._ref:.2f} m to {self._last:.2f} m in {now - self._t_ref:.1f} s "
                f"(progress_epsilon {self.epsilon:g} m, progress_dwell_time {self.dwell:g} s)")

    def tick(self) -> Iterator[Behaviour]:
        if self.status != Status.RUNNING:
            self._ref, self._path = None, None
        yield from self.decorated.tick()
        status = self.decorated.status
        if status == Status.RUNNING:
            reason = self._stall_reason()
            if reason is not None:
                self.decorated.stop(Status.INVALID)
                code = int(m.ControllerErrorCode.FAILED_TO_MAKE_PROGRESS)
                self.board.record_failure(self.decorated.name, code,
                                          m.ControllerErrorCode(code).name, reason,
                                          self.code_key, self.msg_key)
                self.fired += 1
                status = Status.FAILURE
        if status != Status.RUNNING:
            self.stop(status)
        self.status = status
        yield self

    def update(self) -> Status:
        return self.status
