"""HybridAStar end to end: geometry, kinematic and collision guarantees, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.errors import (
    ConfigError,
    GoalOccupied,
    NoValidPath,
    PlannerCancelled,
    PlannerTimeout,
    StartOccupied,
)
from navstack.core.msgs import Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning.hybrid_astar import (
    HybridAStar,
    HybridAStarParams,
    TurningRadiusTooSmall,
    golf_cart_hybrid_params,
    max_curvature,
    path_collision,
    travel_directions,
)
from tests.planning.hybrid_astar.helpers import INFLATION, ROBOT, dead_end, empty, wall

R = 1.0  # minimum turning radius [m] (10 cells)
KAPPA = (1.0 / R) * (1.0 + 1e-6)


def planner(model: str = "DUBIN", **kw: object) -> HybridAStar:
    params = HybridAStarParams.from_mapping({"minimum_turning_radius": R,
                                             "lookup_table_size": 4.0,
                                             "motion_model_for_search": model, **kw})
    return HybridAStar(params, ROBOT, inflation=INFLATION)


@pytest.fixture(scope="module")
def wall_map() -> Costmap2D:
    return wall()


@pytest.fixture(scope="module")
def corridor() -> Costmap2D:
    return dead_end()


def test_empty_map_straight_plan_has_the_straight_length() -> None:
    cm = empty()
    plan = planner().plan_detailed(Pose2D(0.0, 0.0, 0.0), Pose2D(10.0, 0.0, 0.0), cm)
    assert plan.path.length() == pytest.approx(10.0, abs=cm.resolution)
    xyt = plan.path.as_array()
    assert xyt[0].tolist() == [0.0, 0.0, 0.0]
    assert np.allclose(xyt[-1], [10.0, 0.0, 0.0], atol=1e-9)
    assert np.abs(xyt[:, 1]).max() < 1e-9  # never leaves the line
    assert plan.reached_goal and plan.analytic


@pytest.mark.parametrize("model", ["DUBIN", "REEDS_SHEPP"])
def test_plan_around_a_wall_is_collision_free_and_curvature_bounded(
        model: str, wall_map: Costmap2D) -> None:
    start, goal = Pose2D(1.0, 1.0, 0.0), Pose2D(6.0, 1.0, 0.0)
    plan = planner(model).plan_detailed(start, goal, wall_map)
    for xyt in (plan.raw, plan.smoothed):
        assert path_collision(xyt, wall_map, ROBOT.polygon) == -1
        assert max_curvature(xyt, plan.direction) <= KAPPA
        assert np.allclose(xyt[0], [1.0, 1.0, 0.0]) and np.allclose(xyt[-1], [6.0, 1.0, 0.0])
    # it had to climb over the wall's end (y = 2.5 m) with the 0.4 m wide footprint
    assert plan.raw[:, 1].max() > 2.5 + 0.2
    assert plan.path.as_array().tolist() == plan.smoothed.tolist()
    # forward-only search and the Reeds-Shepp search agree there is no need to back up
    assert np.all(plan.direction == 1)
    assert np.all(travel_directions(plan.path.as_array()) == 1)


def test_reverse_motion_only_with_reeds_shepp(corridor: Costmap2D) -> None:
    # facing the dead end of a 1 m corridor: too narrow to turn around with R = 1 m
    start, goal = Pose2D(6.0, 0.0, 0.0), Pose2D(2.0, 0.0, 0.0)
    plan = planner("REEDS_SHEPP").plan_detailed(start, goal, corridor)
    assert np.all(plan.direction[1:] == -1)  # backs straight out
    assert plan.path.length() == pytest.approx(4.0, abs=corridor.resolution)
    assert np.all(travel_directions(plan.path.as_array())[1:] == -1)
    for xyt in (plan.raw, plan.smoothed):
        assert path_collision(xyt, corridor, ROBOT.polygon) == -1
    with pytest.raises(NoValidPath) as err:
        planner("DUBIN").plan(start, goal, corridor)
    assert str(err.value) == (
        "no valid path from start (6.00, 0.00) to goal (2.00, 0.00) at goal heading 0.000 rad "
        "(0.0 deg): every pose reachable with minimum_turning_radius 1.0 m (DUBIN) was searched "
        "(151 expansions); check the costmap for a passage too narrow for the footprint, or use "
        "REEDS_SHEPP")


def test_reeds_shepp_manoeuvre_keeps_its_cusps_through_smoothing(corridor: Costmap2D) -> None:
    # back out of the corridor, then turn into the hall facing north
    plan = planner("REEDS_SHEPP").plan_detailed(Pose2D(6.0, 0.0, 0.0),
                                                Pose2D(-1.5, 2.0, math.pi / 2), corridor)
    cusps = np.nonzero(np.diff(plan.direction[1:]))[0] + 1
    assert len(cusps) >= 1 and np.any(plan.direction < 0) and np.any(plan.direction > 0)
    assert np.array_equal(plan.raw[cusps], plan.smoothed[cusps])
    for xyt in (plan.raw, plan.smoothed):
        assert path_collision(xyt, corridor, ROBOT.polygon) == -1
        assert max_curvature(xyt, plan.direction) <= KAPPA


def test_unreachable_goal_heading_names_the_heading(corridor: Costmap2D) -> None:
    # driving into the dead end forward, the car can never face back out at its end
    with pytest.raises(NoValidPath) as err:
        planner("DUBIN").plan(Pose2D(-2.0, 0.0, 0.0), Pose2D(6.0, 0.0, math.pi), corridor)
    assert str(err.value) == (
        "no valid path from start (-2.00, 0.00) to goal (6.00, 0.00) at goal heading 3.142 rad "
        "(180.0 deg): the goal position is reachable only at headings 0, 10, 20, 30, 40, 340, "
        "350 deg (kinematically, with minimum_turning_radius 1.0 m and DUBIN); choose a "
        "reachable goal heading, raise tolerance or use REEDS_SHEPP")


def test_goal_heading_that_puts_the_footprint_into_a_wall(corridor: Costmap2D) -> None:
    long_robot = Footprint.from_polygon([[0.6, 0.2], [0.6, -0.2], [-0.6, -0.2], [-0.6, 0.2]])
    pl = HybridAStar(planner(tolerance=0.0).params, long_robot, inflation=INFLATION)
    with pytest.raises(GoalOccupied) as err:
        pl.plan(Pose2D(-2.0, 0.0, 0.0), Pose2D(2.0, 0.0, math.pi / 2), corridor)
    assert str(err.value) == (
        "goal (2.00, 0.00) at heading 1.571 rad (90.0 deg): the footprint overlaps the lethal "
        "cell at (1.85, -0.55) (the footprint fits there at headings 330..30, 150..210 deg); "
        "choose a free goal pose or raise tolerance")


def test_turning_radius_smaller_than_a_cell_is_refused(wall_map: Costmap2D) -> None:
    pl = planner(minimum_turning_radius=0.05)
    with pytest.raises(TurningRadiusTooSmall) as err:
        pl.plan(Pose2D(1.0, 1.0, 0.0), Pose2D(6.0, 1.0, 0.0), wall_map)
    assert str(err.value) == (
        "minimum_turning_radius: 0.05 m is smaller than one search-grid cell (0.1 m = costmap "
        "resolution 0.1 m x downsampling factor 1); a turn must leave its cell (set "
        "minimum_turning_radius >= 0.1 or use a finer costmap)")
    assert isinstance(err.value, ConfigError) and err.value.key_path == "minimum_turning_radius"
    pl = planner(minimum_turning_radius=0.15, downsample_costmap=True, downsampling_factor=2)
    with pytest.raises(TurningRadiusTooSmall, match=r"\(0.2 m = costmap resolution 0.1 m x "
                                                    r"downsampling factor 2\)"):
        pl.plan(Pose2D(1.0, 1.0, 0.0), Pose2D(6.0, 1.0, 0.0), wall_map)


def test_start_in_an_obstacle(wall_map: Costmap2D) -> None:
    with pytest.raises(StartOccupied) as err:
        planner().plan(Pose2D(3.05, 1.0, 0.0), Pose2D(6.0, 1.0, 0.0), wall_map)
    assert str(err.value) == ("start (3.05, 1.00) is in an obstacle (cost 254); clear the "
                              "costmap or move the robot into free space")


def test_goal_in_an_obstacle_within_tolerance_ends_nearby(wall_map: Costmap2D) -> None:
    goal = Pose2D(3.1, 1.0, 0.0)  # inside the wall
    with pytest.raises(GoalOccupied, match=r"^goal \(3.10, 1.00\) is in an obstacle \(cost 254\)"):
        planner(tolerance=0.0).plan(Pose2D(1.0, 1.0, 0.0), goal, wall_map)
    # Nav2 compares tolerance with the (cost-weighted) heuristic, not the bare distance
    plan = planner(tolerance=1.0).plan_detailed(Pose2D(1.0, 1.0, 0.0), goal, wall_map)
    assert not plan.reached_goal
    end = plan.path.as_array()[-1]
    assert math.hypot(end[0] - goal.x, end[1] - goal.y) <= 1.0
    assert path_collision(plan.smoothed, wall_map, ROBOT.polygon) == -1


def test_budgets_and_cancel(wall_map: Costmap2D) -> None:
    start, goal = Pose2D(1.0, 1.0, 0.0), Pose2D(6.0, 1.0, 0.0)
    with pytest.raises(PlannerTimeout) as err:
        planner(max_iterations=10, terminal_checking_interval=5).plan(start, goal, wall_map)
    assert str(err.value) == (
        "planning from start (1.00, 1.00) to goal (6.00, 1.00) exceeded max_iterations 10 "
        "without reaching the goal or a pose within tolerance 0.25 m; raise max_iterations "
        "(or set it to -1) or tolerance")
    with pytest.raises(PlannerCancelled) as err2:
        planner().plan(start, goal, wall_map, cancel=lambda: True)
    assert str(err2.value) == ("planning from start (1.00, 1.00) to goal (6.00, 1.00) was "
                               "cancelled after 0 expansions")


def test_same_cell_and_bin_is_a_one_pose_plan(wall_map: Costmap2D) -> None:
    path = planner().plan(Pose2D(1.01, 1.01, 0.01), Pose2D(1.02, 1.03, 0.02), wall_map)
    assert path.as_array().tolist() == [[1.01, 1.01, 0.02]]


def test_downsampled_costmap_plan_is_free_on_the_full_map(wall_map: Costmap2D) -> None:
    pl = planner(downsample_costmap=True, downsampling_factor=2)
    plan = pl.plan_detailed(Pose2D(1.0, 1.0, 0.0), Pose2D(6.0, 1.0, 0.0), wall_map)
    assert path_collision(plan.smoothed, wall_map, ROBOT.polygon) == -1
    assert max_curvature(plan.raw, plan.direction) <= KAPPA


def test_reverse_penalty_below_one_warns_and_means_no_penalty() -> None:
    p = HybridAStarParams(reverse_penalty=0.9, motion_model_for_search="REEDS_SHEPP")
    with pytest.warns(UserWarning) as rec:
        pl = HybridAStar(p)
    assert str(rec[0].message) == (
        "reverse_penalty 0.9 is below 1; treating it as 1.0 (no penalty): a value below 1 "
        "would reward reversing over driving forward. Set reverse_penalty >= 1 to silence "
        "this warning.")
    assert pl.reverse_penalty == 1.0


def test_nav2_parameter_sections() -> None:
    section = golf_cart_hybrid_params()
    assert section.pop("plugin") == "nav2_smac_planner::SmacPlannerHybrid"
    with pytest.warns(UserWarning, match="reverse_penalty 0.9 is below 1"):
        pl = HybridAStar(HybridAStarParams.from_mapping(section))
    assert pl.params.minimum_turning_radius == 4.25
    assert pl.params.smoother.max_iterations == 1000
    assert HybridAStarParams().angle_quantization_bins == 72
    with pytest.raises(ConfigError) as err:
        HybridAStarParams.from_mapping({"travel_distance_scale": 1.0}, key_path="GridBased")
    assert str(err.value) == (
        "GridBased: Value error, travel_distance_scale is not a SmacPlannerHybrid parameter in "
        "any Nav2 release; to weigh travel distance use retrospective_penalty (travel reward = "
        "1 - retrospective_penalty) and remove travel_distance_scale (got "
        "{'travel_distance_scale': 1.0})")


def test_footprint_and_inflation_from_a_layered_costmap() -> None:
    from navstack.costmap.inflation_layer import InflationLayer, InflationLayerParams
    from navstack.costmap.layered_costmap import LayeredCostmap

    layered = LayeredCostmap(50, 40, 0.1, footprint=ROBOT)
    layered.add_plugin(InflationLayer(params=InflationLayerParams(inflation_radius=0.7,
                                                                  cost_scaling_factor=4.0)))
    pl = planner()
    pl.set_costmap_source(layered)
    assert pl.footprint is ROBOT
    assert pl.inflation == (0.7, 4.0)
