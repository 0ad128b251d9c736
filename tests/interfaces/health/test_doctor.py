"""The doctor on the simulated stack: each injected fault is named by its contract, the
healthy run passes every check, and faults revert."""

from __future__ import annotations

import math

import pytest

from navstack.core.msgs import Pose2D
from navstack.interfaces.health import (
    FAULTS,
    DoctorReport,
    HealthError,
    HealthMonitor,
    HealthSession,
    inject_fault,
    pick_goal,
)
from navstack.interfaces.stack import NavStack

SECONDS = 12.0  # the progress checker's 10 s allowance plus the drive to the obstacle


@pytest.fixture(scope="module")
def reports() -> dict[str, DoctorReport]:
    out = {}
    for fault in FAULTS:
        session = HealthSession(NavStack("office", seed=0), fault=fault)
        session.run(SECONDS)
        out[fault] = session.diagnose()
        session.close()
    return out


@pytest.mark.parametrize("fault", list(FAULTS))
def test_doctor_names_the_broken_contract(reports: dict[str, DoctorReport], fault: str) -> None:
    report = reports[fault]
    assert report.diagnosis.contract == FAULTS[fault], "\n".join(report.lines())
    steps = {s.contract: s for s in report.steps}
    assert steps["goal_accepted"].answer == "yes"
    if fault != "healthy":  # the walk stops at the broken contract
        assert report.steps[-1].contract == FAULTS[fault]
        assert report.steps[-1].broken
        assert not any(s.broken and not s.symptom for s in report.steps[:-1])


def test_walk_evidence_is_specific(reports: dict[str, DoctorReport]) -> None:
    inactive = reports["controller_inactive"]
    assert inactive.diagnosis.evidence == "controller_server is INACTIVE"
    walk = {s.contract: s for s in inactive.steps}
    assert walk["motion"].answer == "no" and walk["cmd_vel_published"].answer == "no"
    ignored = reports["cmd_vel_ignored"].diagnosis.evidence
    assert ignored.startswith("/odom twist followed 0 of ")
    assert ignored.endswith("; /cmd_vel has 0 subscriber(s)")
    assert reports["tf_map_odom"].diagnosis.evidence.startswith("map->odom ")
    assert reports["tf_odom_base"].diagnosis.evidence.startswith("odom->base_link ")
    stuck = reports["progress_blocked"]
    assert ("failed to make progress: moved less than 0.50 m in 10.0 s"
            in stuck.diagnosis.evidence)
    assert {s.contract: s for s in stuck.steps}["base_consumes_cmd_vel"].answer == "yes"
    lethal = reports["costmap_lethal"].diagnosis.evidence
    assert "global_costmap: 100.0% of" in lethal and "local_costmap: 100.0% of" in lethal
    zero = reports["velocity_limits_zero"].diagnosis.evidence
    assert zero == "FollowPath.max_vel_x = 0, FollowPath.max_speed_xy = 0, " \
                   "FollowPath.max_vel_theta = 0"
    healthy = reports["healthy"]
    assert healthy.healthy and healthy.diagnosis.fix == "nothing to fix"
    assert {s.contract: s for s in healthy.steps}["motion"].answer == "yes"
    lines = healthy.lines()
    assert lines[-1].startswith("diagnosis: no broken contract (every contract holds; moved up")
    assert lines[1].startswith("  1. Was the goal accepted? yes -- accepted at t=0.00 s, "
                                "ended SUCCEEDED at t=")


def test_healthy_run_passes_every_check_while_driving() -> None:
    session = HealthSession(NavStack("office", seed=0))
    session.run(4.0)  # mid-way along the 3 m goal: everything is judged
    results = session.report()
    session.close()
    assert all(r.ok for r in results), [r for r in results if not r.ok]
    judged = {r.name for r in results if not r.detail.startswith("not judged")}
    assert {"rate:/scan", "rate:/odom", "rate:/tf", "map_latched", "tf", "lifecycle",
            "plan_frame", "costmap_not_lethal:global_costmap",
            "costmap_not_lethal:local_costmap", "cmd_vel_published", "velocity_limits",
            "base_consumes_cmd_vel", "progress"} <= judged
    # only localization is not judged: the simulator localizes perfectly (no /amcl_pose)
    assert {r.name for r in results} - judged == {"localization_covariance"}


def test_fault_reverts_and_the_robot_drives_again() -> None:
    stack = NavStack("office", seed=0)
    monitor = HealthMonitor(stack)
    goal = pick_goal(stack)
    assert goal == Pose2D(4.0, 7.5, 0.0)  # 3 m straight ahead of the office spawn
    faults = [inject_fault(stack, name, goal)
              for name in ("controller_inactive", "cmd_vel_ignored", "costmap_lethal")]
    stack.run_for(1.0)
    failing = {r.name for r in monitor.report() if not r.ok}
    assert {"lifecycle", "costmap_not_lethal:global_costmap",
            "costmap_not_lethal:local_costmap"} <= failing
    for fault in faults:
        fault.revert()
        fault.revert()  # idempotent
    session_goal = HealthSession(stack, goal=goal)
    start = stack.sim.sim.pose
    session_goal.run(3.0)
    moved = math.hypot(stack.sim.sim.pose.x - start.x, stack.sim.sim.pose.y - start.y)
    assert moved > 0.8
    assert all(r.ok for r in session_goal.report()), session_goal.report()
    session_goal.close()
    monitor.close()


def test_unknown_fault_and_no_free_goal_are_typed_errors() -> None:
    stack = NavStack("office", seed=0).start()
    with pytest.raises(KeyError) as e:
        inject_fault(stack, "tf_stopped")
    assert str(e.value) == ("unknown fault 'tf_stopped'; known: cmd_vel_ignored, "
                            "controller_inactive, costmap_lethal, healthy, progress_blocked, "
                            "tf_map_odom, tf_odom_base, velocity_limits_zero")
    with pytest.raises(HealthError, match=r"no free straight stretch of 33\.0-50\.0 m"):
        pick_goal(stack, distance=50.0)
