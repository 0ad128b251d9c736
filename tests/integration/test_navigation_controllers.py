"""The navigation bench with MPPI and Regulated Pure Pursuit as FollowPath.

An office room-to-room trip through the 0.9 m doors (the quick suite's ``doors``
scenario) must succeed without collision with each controller, and the controller
files must merge over the packaged Nav2 parameters exactly as documented.
"""

from __future__ import annotations

from typing import Any

import pytest

from navstack.benchmarks.navigation import (
    CONTROLLERS,
    merge_controller_section,
    nav2_params_for,
    run_scenario,
    scenarios,
)
from navstack.benchmarks.runner import SuiteOptionError, run_suite
from navstack.core.errors import ConfigError, UnknownNameError
from navstack.runtime.config import ros_parameters


@pytest.mark.parametrize("controller", ["mppi", "rpp"])
def test_office_room_to_room_succeeds_without_collision(controller: str) -> None:
    trip = next(s for s in scenarios(quick=True) if s.kind == "doors")
    assert trip.name == "office_Goal_1_to_Goal_2"
    out = run_scenario(trip, seed=0, controller=controller)
    assert (out.status, out.reason) == ("SUCCEEDED", "")
    assert out.collisions == 0
    assert out.final_dist_m <= 0.25  # the goal checker's xy_goal_tolerance
    assert out.passed
    assert out.cycle_ms, "the controller's compute() was timed"


@pytest.mark.parametrize(("name", "cls_name"), [
    ("mppi", "MPPIController"), ("rpp", "RegulatedPurePursuitController"),
    ("dwb", "DWBLocalPlanner"), ("", "DWBLocalPlanner")])
def test_controller_files_build_the_named_plugin(name: str, cls_name: str) -> None:
    from navstack.interfaces.stack import NavStack

    params = nav2_params_for(name)
    if name in ("", "dwb"):
        assert params is None  # the packaged file as is
    else:
        server = ros_parameters(params or {}, "controller_server")
        # the diff-drive default: Nav2's rotation shim around the named controller
        assert server["FollowPath"]["plugin"] == (
            "nav2_rotation_shim_controller::RotationShimController")
        assert server["FollowPath"]["primary_controller"] == CONTROLLERS[name]
        # the rest of the packaged controller_server section is kept
        assert server["general_goal_checker"]["xy_goal_tolerance"] == 0.25
        assert server["controller_frequency"] == 20.0
    stack = NavStack("office", seed=0, nav2_params=params).start()
    shim = stack.controller.controllers["FollowPath"]
    assert type(shim).__name__ == "RotationShimController"
    assert type(getattr(shim, "primary", None)).__name__ == cls_name


def test_mppi_file_uses_the_robot_limits_and_nav2_shifting() -> None:
    from navstack.control.mppi.params import MPPIParams

    section = dict(ros_parameters(nav2_params_for("mppi") or {}, "controller_server")
                   ["FollowPath"])
    section.pop("plugin")
    assert section.pop("primary_controller") == "nav2_mppi_controller::MPPIController"
    for key in ("angular_dist_threshold", "forward_sampling_distance",  # the shim's
                "rotate_to_heading_angular_vel", "max_angular_accel", "simulate_ahead_time"):
        section.pop(key)
    p = MPPIParams.from_mapping(section)
    # diff_drive profile: 0.5 m/s, -0.3 m/s reverse, 1.5 rad/s, 1.0 m/s^2, 2.0 rad/s^2
    assert (p.vx_max, p.vx_min, p.wz_max) == (0.5, -0.3, 1.5)
    assert p.accel_limits[0] == 1.0 and p.accel_limits[1] == -1.0 and p.accel_limits[4] == 2.0
    assert p.shifts_control_sequence  # 1 / 20 Hz == model_dt 0.05 s (Nav2's rule)
    cost = p.critic("CostCritic")
    assert (cost.inflation_radius, cost.cost_scaling_factor) == (0.7, 2.5)


def test_merge_replaces_whole_sections_and_keeps_the_rest() -> None:
    base: dict[str, Any] = {
        "controller_server": {"ros__parameters": {
            "controller_frequency": 20.0,
            "FollowPath": {"plugin": "dwb_core::DWBLocalPlanner", "max_vel_x": 0.5},
            "progress_checker": {"movement_time_allowance": 10.0}}},
        "planner_server": {"ros__parameters": {"expected_planner_frequency": 20.0}}}
    overlay = {"controller_server": {"ros__parameters": {
        "FollowPath": {"plugin": "nav2_mppi_controller::MPPIController", "batch_size": 500},
        "failure_tolerance": 1.0}}}
    merged = merge_controller_section(base, overlay)
    assert merged["controller_server"]["ros__parameters"] == {
        "controller_frequency": 20.0,
        "FollowPath": {"plugin": "nav2_mppi_controller::MPPIController", "batch_size": 500},
        "progress_checker": {"movement_time_allowance": 10.0},
        "failure_tolerance": 1.0}
    assert merged["planner_server"] is base["planner_server"]
    # the base is not modified
    assert base["controller_server"]["ros__parameters"]["FollowPath"]["max_vel_x"] == 0.5


def test_merge_refuses_other_servers_naming_the_key() -> None:
    with pytest.raises(ConfigError) as err:
        merge_controller_section({}, {"local_costmap": {}}, file="c.yaml")
    assert str(err.value) == ("c.yaml: local_costmap: a controller file holds only the "
                              "controller_server section (put other servers' parameters "
                              "in the Nav2 parameter file)")
    with pytest.raises(ConfigError, match="controller_server: must be a mapping with a "
                                          "ros__parameters mapping"):
        merge_controller_section({}, {"controller_server": {"FollowPath": {}}})


def test_unknown_controller_is_refused_listing_the_known() -> None:
    with pytest.raises(UnknownNameError) as err:
        nav2_params_for("mpi")
    assert str(err.value) == ("unknown controller 'mpi' (did you mean 'mppi'?); known: "
                              "dwb, mppi, rpp")


def test_runner_refuses_an_option_the_suite_does_not_take() -> None:
    with pytest.raises(SuiteOptionError) as err:
        run_suite("sim", True, None, {"controller": "mppi"})
    assert str(err.value) == ("controller: benchmark suite 'sim' has no option "
                              "'controller' (suites that take it: navigation)")


def test_cli_bench_controller_errors_name_the_fix() -> None:
    from typer.testing import CliRunner

    from navstack.app import app

    runner = CliRunner()
    res = runner.invoke(app, ["bench", "navigation", "--quick", "--controller", "mpi"])
    assert res.exit_code == 2
    assert ("error: unknown controller 'mpi' (did you mean 'mppi'?); known: dwb, mppi, rpp"
            in res.output)
    res = runner.invoke(app, ["bench", "sim", "--quick", "--controller", "rpp"])
    assert res.exit_code == 2
    assert ("error: controller: benchmark suite 'sim' has no option 'controller' "
            "(suites that take it: navigation)" in res.output)
