"""PluginRegistry: duplicate refusal, Nav2 aliases, unknown-name messages, lazy built-in
tables, ``module:Class`` strings and entry points."""

from __future__ import annotations

import sys
from importlib import metadata
from pathlib import Path

import pytest

from navstack.core import registry as registry_module
from navstack.core.errors import DuplicatePluginError, PluginError, UnknownNameError
from navstack.core.registry import (
    ClassRegistry,
    PluginRegistry,
    builtin_table,
    nav2_spellings,
    scoped,
)


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


# --- lazy built-in tables, Nav2 spellings, module paths, entry points ------------------
def test_nav2_spellings_from_either_form() -> None:
    assert nav2_spellings("nav2_navfn_planner/NavfnPlanner") == (
        "nav2_navfn_planner::NavfnPlanner", "nav2_navfn_planner/NavfnPlanner")
    assert nav2_spellings("pkg::Cls") == ("pkg::Cls", "pkg/Cls")
    assert nav2_spellings("mppi::critics::GoalCritic") == ("mppi::critics::GoalCritic",)
    for bad in ("NavfnPlanner", "pkg/", "::Cls", "a/b/c", "pkg::a/b"):
        with pytest.raises(PluginError, match="must look like 'package::Class'"):
            nav2_spellings(bad)


def test_plugin_decorator_registers_both_spellings() -> None:
    reg: PluginRegistry[type] = PluginRegistry("planner")

    @reg.plugin("Navfn", nav2="nav2_navfn_planner/NavfnPlanner", aliases=["navfn"])
    class NavFn:
        pass

    for key in ("Navfn", "nav2_navfn_planner::NavfnPlanner", "nav2_navfn_planner/NavfnPlanner",
                "navfn"):
        assert reg.get(key) is NavFn
    assert reg.aliases_of("navfn") == ["nav2_navfn_planner/NavfnPlanner",
                                       "nav2_navfn_planner::NavfnPlanner", "navfn"]


def test_builtin_table_imports_the_module_on_first_lookup(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    pkg = tmp_path / "lazy_pkg_a"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "planner.py").write_text(
        "from tests.core.test_registry import LAZY\n"
        "@LAZY.plugin('Lazy', nav2='lazy_pkg::LazyPlanner')\n"
        "class LazyPlanner:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert "lazy_pkg_a.planner" not in sys.modules
    assert LAZY.names() == ["Lazy"]  # known before import
    assert "lazy_pkg::LazyPlanner" in LAZY.all_names()
    assert "lazy_pkg/LazyPlanner" in LAZY.all_names()
    assert "lazy_pkg_a.planner" not in sys.modules
    cls = LAZY.get("lazy_pkg/LazyPlanner")  # either spelling triggers the import
    assert cls.__name__ == "LazyPlanner" and "lazy_pkg_a.planner" in sys.modules
    assert LAZY.get("Lazy") is cls
    # a built-in name is reserved before its module is imported
    with pytest.raises(DuplicatePluginError) as err:
        PluginRegistry("planner", {"p::Taken": "somewhere.else"}).register("x", MPPI,
                                                                           ["p/Taken"])
    assert str(err.value) == ("planner plugin 'p/Taken' is reserved for the built-in plugin "
                              "in somewhere.else; pick another name")


LAZY: PluginRegistry[type] = PluginRegistry(
    "planner", builtin_table({"lazy_pkg_a.planner": ("Lazy", "lazy_pkg::LazyPlanner")}))


def test_builtin_table_module_that_does_not_register_is_an_error(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch
                                                                 ) -> None:
    (tmp_path / "lazy_empty_b.py").write_text("")
    monkeypatch.syspath_prepend(str(tmp_path))
    reg: PluginRegistry[type] = PluginRegistry("planner", {"Ghost": "lazy_empty_b"})
    with pytest.raises(PluginError, match="should be registered by lazy_empty_b, but "
                                          "importing it did not register it"):
        reg.get("Ghost")
    with pytest.raises(PluginError, match="listed for a and b"):
        builtin_table({"a": ("X",), "b": ("X",)})


class Base:
    pass


class Impl(Base):
    pass


def test_class_registry_checks_the_interface_and_resolves_module_paths() -> None:
    reg: ClassRegistry[Base] = ClassRegistry("planner", Base)
    with pytest.raises(PluginError) as err:
        reg.register("mppi", MPPI)
    assert str(err.value).endswith("does not implement tests.core.test_registry.Base; "
                                   "subclass it")
    # an undecorated class by module path is accepted once and then known by that path
    assert reg.get("tests.core.test_registry:Impl") is Impl
    assert "tests.core.test_registry:Impl" in reg.names()
    with pytest.raises(PluginError) as err:
        reg.get("tests.core.test_registry:MPPI")
    assert str(err.value) == ("planner plugin 'tests.core.test_registry:MPPI' is not a Base: "
                              "subclass tests.core.test_registry.Base")
    with pytest.raises(PluginError) as err:
        reg.get("tests.core.test_registry:Nope")
    assert str(err.value) == ("planner plugin 'tests.core.test_registry:Nope': module "
                              "tests.core.test_registry has no attribute 'Nope'")
    with pytest.raises(PluginError) as err:
        reg.get("no_such_pkg_x.mod:Cls")
    assert str(err.value) == ("planner plugin 'no_such_pkg_x.mod:Cls': no module named "
                              "'no_such_pkg_x.mod'; is its package installed or on sys.path?")


def test_decorated_class_by_module_path_keeps_its_name() -> None:
    reg: ClassRegistry[Base] = ClassRegistry("planner", Base)
    reg.register("impl", Impl, aliases=["my_pkg::Impl"])
    assert reg.canonical("tests.core.test_registry:Impl") == "impl"
    assert "tests.core.test_registry:Impl" not in reg.names()


def test_entry_points_are_loaded_once_on_a_miss(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "ep_plugins_c.py").write_text(
        "from tests.core.test_registry import EP_REGISTRY, Base\n"
        "@EP_REGISTRY.plugin('FromEntryPoint', nav2='ep_pkg::FromEntryPoint')\n"
        "class FromEntryPoint(Base):\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    eps = metadata.EntryPoints([metadata.EntryPoint("ep", "ep_plugins_c",
                                                    registry_module.ENTRY_POINT_GROUP)])
    calls: list[str] = []

    def fake(group: str) -> metadata.EntryPoints:
        calls.append(group)
        return eps

    monkeypatch.setattr(registry_module.metadata, "entry_points", fake)
    registry_module.load_entry_points.cache_clear()
    try:
        assert EP_REGISTRY.get("ep_pkg/FromEntryPoint").__name__ == "FromEntryPoint"
        with pytest.raises(UnknownNameError):
            EP_REGISTRY.get("ep_pkg::Other")
        assert calls == [registry_module.ENTRY_POINT_GROUP]  # scanned once
    finally:
        registry_module.load_entry_points.cache_clear()


EP_REGISTRY: ClassRegistry[Base] = ClassRegistry("planner", Base)


def test_broken_entry_point_names_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    eps = metadata.EntryPoints([metadata.EntryPoint("bad", "no_such_module_d",
                                                    registry_module.ENTRY_POINT_GROUP)])
    monkeypatch.setattr(registry_module.metadata, "entry_points", lambda group: eps)
    registry_module.load_entry_points.cache_clear()
    try:
        with pytest.raises(PluginError, match="entry point 'bad = no_such_module_d' of an "
                                              "unknown distribution failed to load: No "
                                              "module named 'no_such_module_d'"):
            ClassRegistry("planner", Base).get("whatever")
    finally:
        registry_module.load_entry_points.cache_clear()


def test_scoped_restores_the_registrations() -> None:
    reg = controllers()
    with scoped(reg):
        reg.register("teb", Base)
        assert "teb" in reg
    assert "teb" not in reg and reg.get("mppi") is MPPI
