"""Nav2 control-node semantics on py_trees: PipelineSequence, RecoveryNode, RoundRobin,
RateController, tick by tick with scripted leaves."""

from __future__ import annotations

import numpy as np
import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from navstack.navigation.bt_composites import (
    PipelineSequence,
    RateController,
    RecoveryNode,
    RoundRobin,
)
from navstack.navigation.bt_nodes import concatenate_paths, distance_remaining

S, F, R = Status.SUCCESS, Status.FAILURE, Status.RUNNING


class Scripted(Behaviour):
    """Returns the scripted statuses in turn (then the last forever); logs its life."""

    def __init__(self, name: str, script: list[Status], log: list[str]) -> None:
        super().__init__(name)
        self.script, self.log, self.ticks, self.halts = list(script), log, 0, 0

    def update(self) -> Status:
        status = self.script[min(self.ticks, len(self.script) - 1)]
        self.ticks += 1
        self.log.append(f"{self.name}:{status.name[0]}")
        return status

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self.status == Status.RUNNING:
            self.halts += 1


def tick(root: Behaviour) -> Status:
    root.tick_once()
    return root.status


def test_pipeline_sequence_reticks_earlier_children_and_keeps_later_running() -> None:
    log: list[str] = []
    a = Scripted("a", [S, R, R], log)
    b = Scripted("b", [R, R, S], log)
    root = PipelineSequence("p", [a, b])
    assert [tick(root) for _ in range(3)] == [R, R, S]
    # tick 2: a RUNNING again but b (already reached) is still ticked
    assert log == ["a:S", "b:R", "a:R", "b:R", "a:R", "b:S"]
    assert a.halts == 1 and a.status == Status.INVALID  # halted when the pipeline succeeded


def test_pipeline_sequence_stops_at_a_first_time_running_child_and_halts_on_failure() -> None:
    log: list[str] = []
    a = Scripted("a", [R, S, S, F], log)
    b = Scripted("b", [R], log)
    root = PipelineSequence("p", [a, b])
    assert [tick(root) for _ in range(3)] == [R, R, R]
    assert log == ["a:R", "a:S", "b:R", "a:S", "b:R"]
    assert tick(root) == F
    assert b.halts == 1 and b.status == Status.INVALID


def test_recovery_node_retries_in_one_tick_until_exhausted() -> None:
    log: list[str] = []
    main, rec = Scripted("main", [F], log), Scripted("rec", [S], log)
    root = RecoveryNode("r", [main, rec], number_of_retries=2)
    assert tick(root) == F
    assert log == ["main:F", "rec:S", "main:F", "rec:S", "main:F"]
    assert root.retry_count == 2


def test_recovery_node_running_recovery_then_success_and_failing_recovery() -> None:
    log: list[str] = []
    main, rec = Scripted("main", [F, S], log), Scripted("rec", [R, S], log)
    root = RecoveryNode("r", [main, rec], number_of_retries=1)
    assert [tick(root), tick(root)] == [R, S]
    assert log == ["main:F", "rec:R", "rec:S", "main:S"]
    log.clear()
    main2, rec2 = Scripted("main", [F], log), Scripted("rec", [F], log)
    assert tick(RecoveryNode("r2", [main2, rec2], number_of_retries=5)) == F
    assert log == ["main:F", "rec:F"]
    with pytest.raises(ValueError, match="exactly 2 children"):
        RecoveryNode("bad", [Scripted("x", [S], log)])


def test_round_robin_escalates_across_entries_skips_failures_and_resets_on_halt() -> None:
    log: list[str] = []
    kids = [Scripted("c0", [S], log), Scripted("c1", [F], log), Scripted("c2", [S], log)]
    rr = RoundRobin("rr", kids)
    assert [tick(rr) for _ in range(3)] == [S, S, S]
    assert log == ["c0:S", "c1:F", "c2:S", "c0:S"]  # c1 fails -> c2 in the same tick
    log.clear()
    spin = Scripted("spin", [R], log)
    rr2 = RoundRobin("rr2", [Scripted("clear", [S], log), spin])
    assert [tick(rr2), tick(rr2)] == [S, R]
    rr2.stop(Status.INVALID)  # halted while 'spin' runs -> back to the first child
    assert spin.halts == 1 and rr2.next_index == 0
    rr2.stop(Status.INVALID)
    all_fail = RoundRobin("rr3", [Scripted("x", [F], log), Scripted("y", [F], log)])
    assert tick(all_fail) == F and all_fail.next_index == 0


def test_rate_controller_uses_the_given_clock() -> None:
    now = [0.0]
    log: list[str] = []
    child = Scripted("plan", [S], log)
    rc = RateController("rc", child, hz=1.0, clock=lambda: now[0])
    statuses = []
    for k in range(31):
        now[0] = k * 0.1 + 1e-9 * k  # 0.0 .. 3.0 s in 0.1 s steps (monotone)
        statuses.append(tick(rc))
    assert child.ticks == 4  # t = 0, 1.0, 2.0, 3.0
    assert statuses[0] == S and statuses[1] == R and statuses[10] == S
    # a RUNNING child is ticked every tick regardless of the period
    slow = Scripted("slow", [R, R, R, S], log)
    rc2 = RateController("rc2", slow, hz=0.1, clock=lambda: 0.0)
    assert [tick(rc2) for _ in range(5)] == [R, R, R, S, R]
    assert slow.ticks == 4


def test_distance_remaining_projects_onto_segments() -> None:
    xy = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 3.0]])
    assert distance_remaining(xy, 0.5, 0.4) == pytest.approx(1.5 + 3.0, abs=1e-12)
    assert distance_remaining(xy, 2.5, 1.0) == pytest.approx(2.0, abs=1e-12)
    assert distance_remaining(xy, -1.0, 0.0) == pytest.approx(5.0, abs=1e-12)
    assert distance_remaining(xy, 9.0, 9.0) == pytest.approx(0.0, abs=1e-12)
    assert distance_remaining(xy[:1], 1.0, 1.0) == 0.0


def test_concatenate_paths_drops_repeated_junction_poses() -> None:
    from navstack.core.msgs import Path

    a = Path.from_array(np.array([[0.0, 0, 0], [1.0, 0, 0]]))
    b = Path.from_array(np.array([[1.0, 0, 0], [1.0, 1, 0]]))
    joined = concatenate_paths([a, b])
    assert joined.as_array()[:, :2].tolist() == [[0, 0], [1, 0], [1, 1]]
    assert joined.length() == pytest.approx(2.0)
