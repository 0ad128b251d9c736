"""``max_planning_time`` as a wall-clock deadline, or as an expansion budget on simulated
time (planning/budget.py): Hybrid-A* and Smac 2D stop at exactly the budget, the same
run after run, and the planner server tells its planners which clock they run on."""

from __future__ import annotations

import time

import numpy as np
import pytest

from navstack.core.errors import PlannerTimeout
from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning import AStarParams, CostAwareAStar
from navstack.planning.budget import PlanningBudget
from navstack.planning.hybrid_astar import HybridAStar, HybridAStarParams
from tests.planning.hybrid_astar.helpers import INFLATION, ROBOT, wall


def test_budget_counts_expansions_on_simulated_time_and_seconds_on_the_wall() -> None:
    sim = PlanningBudget(2.5, 1000.0, simulated=True)
    assert sim.max_expansions == 2500
    assert not sim.exceeded(2500) and sim.exceeded(2501)
    time.sleep(0.01)
    assert not sim.exceeded(10)  # wall time does not count
    wall_clock = PlanningBudget(0.005, 1000.0, simulated=False)
    assert wall_clock.max_expansions is None
    time.sleep(0.01)
    assert wall_clock.exceeded(0)
    assert not PlanningBudget(None, 1000.0, simulated=True).exceeded(10 ** 12)
    with pytest.raises(ValueError, match="expansion_rate must be a positive number"):
        PlanningBudget(1.0, 0.0)


def _hybrid(**kw: object) -> HybridAStar:
    params = HybridAStarParams.from_mapping({"minimum_turning_radius": 1.0,
                                             "lookup_table_size": 4.0, **kw})
    return HybridAStar(params, ROBOT, inflation=INFLATION)


def test_hybrid_astar_on_simulated_time_stops_at_exactly_the_expansion_budget() -> None:
    cm = wall()
    start, goal = Pose2D(1.0, 1.0, 0.0), Pose2D(6.0, 1.0, 0.0)
    full = _hybrid().plan_detailed(start, goal, cm)
    assert full.iterations > 20
    # 1e-3 s at 10,000 expansions/s = 10 expansions: not enough for this plan
    tight = _hybrid(max_planning_time=1e-3, sim_expansion_rate=10_000.0,
                    terminal_checking_interval=7)
    tight.use_simulated_time(True)
    with pytest.raises(PlannerTimeout) as err:
        tight.plan(start, goal, cm)
    assert str(err.value) == (
        "planning from start (1.00, 1.00) to goal (6.00, 1.00) exceeded max_planning_time "
        "0.001 s (simulated time: 10 expansions at sim_expansion_rate 10000/s; 10 "
        "expansions done) without reaching the goal or a pose within tolerance 0.25 m; "
        "raise max_planning_time or tolerance")
    # a budget of exactly the plan's expansions plans it, identically every time
    enough = _hybrid(max_planning_time=(full.iterations + 0.5) / 10_000.0,
                     sim_expansion_rate=10_000.0)
    enough.use_simulated_time(True)
    a = enough.plan_detailed(start, goal, cm)
    b = enough.plan_detailed(start, goal, cm)
    assert a.iterations == b.iterations == full.iterations
    assert np.array_equal(a.smoothed, full.smoothed) and np.array_equal(b.smoothed, a.smoothed)


def test_smac2d_on_simulated_time_stops_at_exactly_the_expansion_budget() -> None:
    d = np.zeros((60, 60), dtype=np.uint8)
    d[:50, 30] = 254
    cm = Costmap2D.from_array(d, 0.1, 0.0, 0.0)
    start, goal = Pose2D(0.5, 0.5, 0.0), Pose2D(5.5, 0.5, 0.0)
    planner = CostAwareAStar(AStarParams(max_planning_time=1e-4, sim_expansion_rate=1e6,
                                         terminal_checking_interval=1000))
    planner.use_simulated_time(True)
    with pytest.raises(PlannerTimeout) as err:
        planner.plan(start, goal, cm)
    assert str(err.value) == (
        "planning from start (0.50, 0.50) to goal (5.50, 0.50) exceeded max_planning_time "
        "0.000 s (simulated time: 100 expansions at sim_expansion_rate 1000000/s; 100 "
        "expansions done); raise max_planning_time")
    planner = CostAwareAStar(AStarParams(max_planning_time=1.0, sim_expansion_rate=1e6))
    planner.use_simulated_time(True)
    path = planner.plan(start, goal, cm)
    assert np.allclose(path.as_array()[-1, :2], [5.5, 0.5])


@pytest.mark.parametrize("mode", ["sim", "wall"])
def test_planner_server_tells_its_planners_the_clock(mode: str) -> None:
    from navstack.navigation.costmap_node import CostmapNode
    from navstack.navigation.planner_server import PlannerServer
    from navstack.runtime.node import Runtime
    from navstack.runtime.scheduler import Scheduler

    rt = Runtime(Scheduler(mode))  # type: ignore[arg-type]
    costmap = CostmapNode(rt, "global_costmap", {"global_frame": "map", "width": 4,
                                                 "height": 4, "resolution": 0.1,
                                                 "plugins": []})
    server = PlannerServer(rt, {"planner_plugins": ["GridBased", "Hybrid"],
                                "GridBased": {"plugin": "nav2_smac_planner::SmacPlanner2D"},
                                "Hybrid": {"plugin": "nav2_smac_planner::SmacPlannerHybrid"}},
                           costmap)
    assert [p.simulated_time for p in server.planners.values()] == [mode == "sim"] * 2
