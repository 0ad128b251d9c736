"""PluginRegistry: duplicate refusal, Nav2 aliases, unknown-name messages."""

from __future__ import annotations

import pytest

from navstack.core.errors import DuplicatePluginError, PluginError, UnknownNameError
from navstack.core.registry import PluginRegistry


class MPPI:
    pass


class DWB:
    pass


def controllers() -> PluginRegistry[type]:
    reg: PluginRegistry[type] = PluginRegistry("controller")
    reg.register("mppi", MPPI, aliases=["nav2_mppi_controller::MPPIController"])
    reg.register("dwb", DWB, aliases=["dwb_core::DWBLocalPlanner"])
    return reg


def test_lookup_by_name_and_nav2_alias() -> None:
    reg = controllers()
    assert reg.get("mppi") is MPPI
    assert reg.get("nav2_mppi_controller::MPPIController") is MPPI
    assert reg.canonical("dwb_core::DWBLocalPlanner") == "dwb"
    assert reg.names() == ["dwb", "mppi"]
    assert len(reg) == 2
    assert "dwb_core::DWBLocalPlanner" in reg and "teb" not in reg


def test_decorator_registers_and_returns_the_class() -> None:
    reg: PluginRegistry[type] = PluginRegistry("planner")

    @reg.decorator("navfn", aliases=["nav2_navfn_planner/NavfnPlanner"])
    class NavFn:
        pass

    assert NavFn.__name__ == "NavFn"
    assert reg.get("nav2_navfn_planner/NavfnPlanner") is NavFn


def test_duplicate_name_refused() -> None:
    reg = controllers()
    with pytest.raises(DuplicatePluginError) as err:
        reg.register("mppi", DWB)
    assert str(err.value) == "controller plugin 'mppi' is already registered; pick another name"
    assert isinstance(err.value, PluginError)
    assert reg.get("mppi") is MPPI


def test_duplicate_alias_refused_and_nothing_half_registered() -> None:
    reg = controllers()
    with pytest.raises(DuplicatePluginError) as err:
        reg.register("mppi2", MPPI, aliases=["nav2_mppi_controller::MPPIController"])
    assert str(err.value) == ("controller plugin 'nav2_mppi_controller::MPPIController' is "
                              "already registered; pick another name")
    assert "mppi2" not in reg
    with pytest.raises(DuplicatePluginError):  # a name may not shadow an alias either
        reg.register("dwb_core::DWBLocalPlanner", DWB)


def test_unknown_name_lists_known_names_and_suggests() -> None:
    reg = controllers()
    with pytest.raises(UnknownNameError) as err:
        reg.get("mpi")
    assert str(err.value) == ("unknown controller plugin 'mpi' (did you mean 'mppi'?); "
                              "known: dwb, mppi")
    assert isinstance(err.value, KeyError)
    with pytest.raises(UnknownNameError) as err:
        reg.get("teb_local_planner::TebLocalPlannerROS")
    assert str(err.value) == ("unknown controller plugin 'teb_local_planner::TebLocalPlannerROS';"
                              " known: dwb, mppi")
    assert err.value.known == ["dwb", "mppi"]


def test_aliases_from_a_generator_are_registered() -> None:
    reg: PluginRegistry[type] = PluginRegistry("controller")
    reg.register("mppi", MPPI, aliases=(a for a in ["nav2_mppi_controller::MPPIController"]))
    assert reg.get("nav2_mppi_controller::MPPIController") is MPPI
