"""NavStack: construction describes (nodes, params, validated), start() brings it up."""

from __future__ import annotations

import pytest

from navstack.core.errors import ConfigError, UnknownNameError
from navstack.core.msgs import Pose2D
from navstack.interfaces.api import Navigator
from navstack.interfaces.stack import NavStack, StackNotStarted
from navstack.interfaces.stack_description import (
    AmclLocalization,
    ExternalLocalization,
    PerfectLocalization,
    SlamLocalization,
)
from navstack.localization.amcl.params import AmclParams
from navstack.mapping.slam_params import SlamParams
from navstack.navigation.behavior_server import BehaviorServerParams

SERVERS = ["global_costmap", "local_costmap", "planner_server", "controller_server",
           "behavior_server", "velocity_smoother", "collision_monitor", "twist_mux",
           "bt_navigator", "waypoint_follower"]
SPAWN = Pose2D(2.0, 7.5, 0.3)


def test_construction_describes_without_running() -> None:
    stack = NavStack("office", "diff_drive", seed=4, spawn=SPAWN)
    d = stack.description
    assert not stack.started
    assert [n.name for n in d.nodes] == ["simulator", "map_server", *SERVERS]
    assert isinstance(d.localization, PerfectLocalization)
    assert d.node("simulator").params == {
        "world": "office", "robot": "diff_drive", "seed": 4, "spawn": (2.0, 7.5, 0.3),
        "physics_rate_hz": 50.0, "perfect_localization": True}
    behaviors = d.node("behavior_server")
    assert behaviors.kind == "navstack.navigation.behavior_server.BehaviorServer"
    assert isinstance(behaviors.params, BehaviorServerParams)
    assert d.node("controller_server").params["controller_frequency"] == 20.0
    assert d.node("global_costmap").inputs["footprint"] is stack.footprint
    assert d.nav2_file.endswith("nav2_params.yaml")
    lines = d.summary().splitlines()
    assert lines[0].startswith("world 'office', robot 'diff_drive', seed 4, localization "
                               "'perfect', Nav2 parameters ")
    assert len(lines) == 1 + len(d.nodes)
    assert lines[3].split()[:3] == ["global_costmap", "CostmapNode", "{update_frequency,"]
    with pytest.raises(UnknownNameError, match=r"unknown node 'amcl'; known: behavior_server"):
        d.node("amcl")
    with pytest.raises(StackNotStarted, match=r"^the stack is described but not started: "
                                              r"call stack\.start\(\)"):
        _ = stack.runtime


def test_amcl_and_slam_options_resolve_their_parameters() -> None:
    amcl = NavStack("office", spawn=SPAWN, localization="amcl").description
    assert [n.name for n in amcl.nodes] == ["simulator", "map_server", "amcl", *SERVERS]
    params = amcl.node("amcl").params
    assert isinstance(params, AmclParams) and params is amcl.amcl
    assert params.set_initial_pose and params.initial_pose.x == 2.0
    assert params.initial_pose.yaw == 0.3
    assert params.alpha1 == 0.02  # the packaged Nav2 file's amcl: section
    seeded = NavStack("office", localization=AmclLocalization({"alpha1": 0.1})).description
    assert seeded.amcl is not None and seeded.amcl.alpha1 == 0.1
    assert amcl.node("simulator").params["perfect_localization"] is False

    slam = NavStack("office", spawn=SPAWN, localization="slam").description
    assert [n.name for n in slam.nodes] == ["simulator", "slam_toolbox", *SERVERS]
    assert slam.slam is not None and slam.slam.map_start_pose == [2.0, 7.5, 0.3]
    given = SlamLocalization(SlamParams(resolution=0.1))
    typed = NavStack("office", spawn=SPAWN, localization=given).description
    assert typed.slam is not None and typed.slam.resolution == 0.1
    assert typed.slam.map_minimum_extent == list(typed.world.bounds)

    external = NavStack("office", localization=ExternalLocalization()).description
    assert [n.name for n in external.nodes] == ["simulator", "map_server", *SERVERS]
    assert external.node("simulator").params["perfect_localization"] is False


def test_bad_localization_options_name_the_option() -> None:
    with pytest.raises(ConfigError) as e:
        NavStack("office", localization="amlc")  # type: ignore[arg-type]
    assert str(e.value) == ("localization: unknown localization 'amlc'; choose one of "
                            "'perfect', 'external', 'amcl', 'slam' (did you mean 'amcl'?)")
    with pytest.raises(ConfigError, match=r"^localization: expected a name .* got bool True"):
        NavStack("office", localization=True)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"slam_toolbox\.resolutoin: unknown key"):
        NavStack("office", localization=SlamLocalization({"resolutoin": 0.1}))


def test_start_is_idempotent_and_the_drivers_start_the_stack() -> None:
    stack = NavStack("office", seed=1, spawn=SPAWN)
    assert stack.start() is stack
    runtime = stack.runtime
    assert stack.start().runtime is runtime and stack.now == 0.0
    assert set(runtime.nodes) == {n.name for n in stack.description.nodes}
    assert stack.sim.sim.pose == SPAWN
    assert stack.amcl is None and stack.slam is None and stack.map_server is not None

    driven = NavStack("office", seed=1)
    Navigator(driven)  # the commander starts it
    assert driven.started and driven.runtime.tf.can_transform("map", "odom")
    ran = NavStack("office", seed=1)
    ran.run_for(0.5)
    assert ran.now == pytest.approx(0.5)


def test_external_localization_leaves_map_to_odom_to_others() -> None:
    stack = NavStack("office", seed=1, localization="external").start()
    stack.run_for(0.5)
    assert stack.runtime.tf.can_transform("odom", "base_link")
    assert not stack.runtime.tf.can_transform("map", "odom")
