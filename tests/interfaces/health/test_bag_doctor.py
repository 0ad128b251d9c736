"""The doctor on recorded runs: a fault recorded with BagRecorder is diagnosed from the
bag alone (no lifecycle states, no parameters: what a bag of a real robot holds)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from navstack.app import app
from navstack.core.msgs import PoseStamped
from navstack.interfaces.api import Navigator
from navstack.interfaces.health import (
    FAULTS,
    HEALTH_TOPICS,
    diagnose_bag,
    inject_fault,
    observations_from_bag,
    pick_goal,
)
from navstack.interfaces.stack import NavStack
from navstack.runtime.recording import DEFAULT_TOPICS, BagRecorder


def _record(path: Path, fault: str, seconds: float,
            topics: tuple[str, ...] = HEALTH_TOPICS) -> None:
    stack = NavStack("office", seed=0).start()
    recorder = BagRecorder(stack.runtime, path, topics)
    goal = pick_goal(stack)
    inject_fault(stack, fault, goal)
    assert Navigator(stack).goToPose(PoseStamped.from_pose2d(goal, "map"))
    stack.run_for(seconds)
    recorder.close()


@pytest.mark.parametrize(("fault", "seconds"), [
    ("cmd_vel_ignored", 4.0), ("controller_inactive", 4.0), ("costmap_lethal", 3.0),
    ("progress_blocked", 12.0)])
def test_recorded_fault_is_named_from_the_bag(tmp_path: Path, fault: str,
                                              seconds: float) -> None:
    bag = tmp_path / "bag"
    _record(bag, fault, seconds)
    report = diagnose_bag(bag)
    assert report.diagnosis.contract == FAULTS[fault], "\n".join(report.lines())
    assert report.source == f"bag {bag}"
    if fault == "controller_inactive":  # a bag has no lifecycle state: inferred
        assert report.diagnosis.evidence.startswith(
            "inferred from the recording: a plan was published at t=0.05 s but only ")
    if fault == "costmap_lethal":
        assert "global_costmap: 100.0% of 120000 known cells" in report.diagnosis.evidence


def test_healthy_bag_and_cli(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    _record(bag, "healthy", 10.0, DEFAULT_TOPICS)  # a plain `demo --record` topic set
    obs = observations_from_bag(bag)
    assert [g.status for g in obs.goals] == ["SUCCEEDED"]
    assert obs.notes == ["not recorded: /global_costmap/costmap, /local_costmap/costmap "
                         f"(record {', '.join(HEALTH_TOPICS)})"]
    res = CliRunner().invoke(app, ["doctor", "--bag", str(bag)])
    assert res.exit_code == 0, res.output
    assert "  8. Is the costmap all lethal? n/a -- not judged: no costmap observed" in \
        res.output.splitlines()
    assert res.output.splitlines()[-1].startswith("diagnosis: no broken contract")
