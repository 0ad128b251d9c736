"""The server plugin registries: the built-in tables agree with the decorators, every
built-in implements its interface, and loading stays lazy."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

from navstack.control.dwb.critic_base import CRITICS as DWB_CRITICS
from navstack.control.mppi.critics import CRITICS as MPPI_CRITICS
from navstack.core.interfaces import Controller, GlobalPlanner
from navstack.core.plugins import CONTROLLERS, PLANNERS, REGISTRIES
from navstack.core.registry import ClassRegistry
from navstack.costmap.layer import COSTMAP_LAYERS

TABLED: tuple[ClassRegistry[object], ...] = (*REGISTRIES, COSTMAP_LAYERS)


def _spellings(key: str) -> set[str]:
    return {key, key.replace("::", "/")} if key.count("::") == 1 else {key}


@pytest.mark.parametrize("registry", TABLED, ids=lambda r: r.kind)
def test_builtin_table_and_decorators_name_the_same_plugins(registry: ClassRegistry[object]
                                                           ) -> None:
    table = registry._builtins
    for module in set(table.values()):
        importlib.import_module(module)
    registered = {*registry._entries, *registry._aliases}
    expected = {s for key in table for s in _spellings(key)}
    assert registered >= expected, f"table names no module registers: {expected - registered}"
    builtin = {k for k in registered
               if getattr(registry._entries[registry.canonical(k)], "__module__", "")
               in set(table.values())}
    assert builtin == expected, f"registered but missing from the table: {builtin - expected}"
    for name in registry.names():
        cls = registry.get(name)
        assert issubclass(cls, registry.interface)
        assert isinstance(getattr(cls, "params_model", None), type), name


def test_server_registries_hold_the_nav2_types() -> None:
    planner = PLANNERS.get("nav2_navfn_planner/NavfnPlanner")
    assert issubclass(planner, GlobalPlanner) and planner.__name__ == "NavfnPlanner"
    assert PLANNERS.get("Navfn") is planner
    assert PLANNERS.get("nav2_smac_planner::SmacPlannerHybrid").__name__ == "HybridAStar"
    mppi = CONTROLLERS.get("nav2_mppi_controller/MPPIController")
    assert issubclass(mppi, Controller) and mppi.params_model.__name__ == "MPPIParams"
    assert DWB_CRITICS.canonical("dwb_critics/PathAlignCritic") == "PathAlign"
    assert MPPI_CRITICS.get("mppi::critics::GoalCritic").name == "GoalCritic"


def test_every_builtin_controller_is_complete_and_takes_a_speed_limit() -> None:
    for name in CONTROLLERS.names():
        cls = CONTROLLERS.get(name)
        assert not cls.__abstractmethods__, f"{name} leaves {cls.__abstractmethods__} abstract"
        # a wrapper (the rotation shim) needs the controller it wraps, as in Nav2
        wraps = ({"primary_controller": "dwb_core::DWBLocalPlanner"}
                 if "primary_controller" in cls.params_model.model_fields else {})
        controller = cls(cls.params_model.from_mapping(wraps))
        controller.set_speed_limit(50.0, True)
        controller.set_speed_limit(0.2, False)
        controller.set_speed_limit(0.0, True)
        controller.reset()


def _modules_after(code: str) -> set[str]:
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys\n"
                          "print('\\n'.join(m for m in sys.modules if m.startswith('navstack')))"],
                         capture_output=True, text=True, check=True, timeout=120)
    return set(out.stdout.split())


PLUGIN_MODULES = {m for r in REGISTRIES for m in r._builtins.values()}


def test_importing_the_servers_imports_no_plugin() -> None:
    loaded = _modules_after("import navstack.navigation.planner_server, "
                            "navstack.navigation.controller_server, "
                            "navstack.navigation.behavior_server")
    assert "navstack.core.plugins" in loaded
    assert not loaded & PLUGIN_MODULES, sorted(loaded & PLUGIN_MODULES)
    assert not any(m.startswith(("navstack.planning", "navstack.control")) for m in loaded)


def test_cli_help_imports_no_plugin() -> None:
    loaded = _modules_after("import sys\nsys.argv = ['navstack', '--help']\n"
                            "from navstack.app import main\n"
                            "try:\n    main()\nexcept SystemExit:\n    pass")
    assert "navstack.app" in loaded
    assert not loaded & PLUGIN_MODULES, sorted(loaded & PLUGIN_MODULES)


def test_server_plugin_errors_name_the_file_and_key() -> None:
    from navstack.core.errors import ConfigError
    from navstack.navigation.plugins import load_plugin

    with pytest.raises(ConfigError) as err:
        load_plugin(PLANNERS, "nav2_navfn_planner/NavfnPlaner", file="nav2.yaml",
                    key_path="planner_server.GridBased")
    assert str(err.value) == ("nav2.yaml: planner_server.GridBased.plugin: unknown planner "
                              "plugin 'nav2_navfn_planner/NavfnPlaner' (did you mean "
                              "'nav2_navfn_planner/NavfnPlanner'?)")
    with pytest.raises(ConfigError) as err:
        load_plugin(CONTROLLERS, "teb_local_planner::TebLocalPlannerROS", file="nav2.yaml",
                    key_path="controller_server.FollowPath")
    assert str(err.value) == (
        "nav2.yaml: controller_server.FollowPath.plugin: unknown controller plugin "
        "'teb_local_planner::TebLocalPlannerROS' (known: dwb_core::DWBLocalPlanner, "
        "nav2_mppi_controller::MPPIController, nav2_regulated_pure_pursuit_controller::"
        "RegulatedPurePursuitController, nav2_rotation_shim_controller::"
        "RotationShimController; a plugin of your own: import its module first or "
        "write 'package.module:ClassName')")
    with pytest.raises(ConfigError) as err:
        load_plugin(PLANNERS, "navstack.core.msgs:Path", file="nav2.yaml",
                    key_path="planner_server.GridBased")
    assert str(err.value) == ("nav2.yaml: planner_server.GridBased.plugin: planner plugin "
                              "'navstack.core.msgs:Path' is not a GlobalPlanner: subclass "
                              "navstack.core.interfaces.GlobalPlanner")
    # an undecorated planner by module path works (NavfnPlanner is also registered)
    assert load_plugin(PLANNERS, "navstack.planning.navfn:NavfnPlanner").__name__ == (
        "NavfnPlanner")
