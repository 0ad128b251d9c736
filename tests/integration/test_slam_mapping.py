"""Issue 4 acceptance 2: the office mapped while following the waypoints, SLAM on.

Navigation plans on the live SLAM map (no map given).  With loop closure the trajectory
error stays under 5 cm and the map matches the world (IoU >= 0.90); the same run without
loop closure is measurably worse, so the closures are doing the work.
"""

from __future__ import annotations

import pytest

from navstack.benchmarks.sim_mapping import SimMappingResult, run_sim_mapping


@pytest.fixture(scope="module")
def with_loops() -> SimMappingResult:
    return run_sim_mapping({})


@pytest.fixture(scope="module")
def without_loops() -> SimMappingResult:
    return run_sim_mapping({"do_loop_closing": False})


def test_mapping_the_office_is_accurate_with_loop_closure(with_loops: SimMappingResult) -> None:
    run = with_loops
    assert run.ate_m <= 0.05
    assert run.map.iou >= 0.90
    assert run.stats.loop_closures > 0
    assert run.collisions == 0
    # navigation used the live map: the first three rooms were reached on it
    assert [status for _, status, _ in run.goals[:3]] == ["SUCCEEDED"] * 3
    # every failed goal carries a reason
    assert all(reason for _, status, reason in run.goals if status != "SUCCEEDED")


def test_loop_closure_matters(with_loops: SimMappingResult,
                              without_loops: SimMappingResult) -> None:
    assert without_loops.stats.loop_closures == 0
    assert without_loops.ate_m > 1.5 * with_loops.ate_m
    assert without_loops.map.iou < with_loops.map.iou - 0.05
