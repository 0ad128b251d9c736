"""The layer rules of ARCHITECTURE.md §1, checked on the source (imports only point down).

Every module of a package is parsed with ``ast`` and every import in it is collected --
module level, inside functions and classes, under ``if TYPE_CHECKING:`` and ``try:``,
relative imports resolved, ``importlib.import_module("...")`` / ``__import__("...")``
with a literal name -- and compared with what its layer may import:

* the algorithm packages (costmap, planning, control, localization, mapping, perception,
  geo, exploration) import only ``core`` and each other: no runtime/bus, no node layer,
  nothing above;
* the node layer (``nodes``) adapts algorithms and vehicle links to the bus: core,
  runtime, algorithms and drivers, nothing above it and not ``navigation`` beside it;
* ``drivers`` is pure protocol and transport code: only ``core`` (no bus, no algorithm,
  no simulator, nothing above);
* ``missions`` (behaviour trees over navigator goals) import anything below them --
  navigation, nodes, runtime, algorithms -- but not ``interfaces``/``benchmarks`` above
  them, nor ``sim``/``drivers`` (a mission runs on a real robot as in the simulator);
* ``core`` imports only itself -- except the costmap data types that the plugin
  interfaces of ``core/interfaces.py`` name in annotations (under ``if TYPE_CHECKING:``
  only, so nothing is imported at run time; see :data:`ANNOTATION_ONLY`).

A violation fails naming the module, the line and the import.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

import navstack

SRC = Path(navstack.__file__).resolve().parent
ALGORITHMS = ("costmap", "planning", "control", "localization", "mapping", "perception", "geo",
              "exploration")
ABOVE_ALGORITHMS = ("runtime", "nodes", "navigation", "interfaces", "benchmarks", "sim",
                    "drivers", "missions", "app")
RULES: dict[str, tuple[str, ...]] = {
    **dict.fromkeys(ALGORITHMS, ABOVE_ALGORITHMS),
    "nodes": ("navigation", "interfaces", "benchmarks", "sim", "missions", "app"),
    "drivers": (*ALGORITHMS, "runtime", "nodes", "navigation", "interfaces", "benchmarks", "sim",
                "missions", "app"),
    # missions orchestrate navigator goals on the bus: above navigation and the node layer,
    # below interfaces; they run on a real robot too, so never the simulator or drivers
    "missions": ("interfaces", "benchmarks", "sim", "drivers", "app"),
    "core": (*ALGORITHMS, *ABOVE_ALGORITHMS),
}
# (importing module, imported module) pairs allowed under ``if TYPE_CHECKING:`` only: the
# plugin interfaces take a Costmap2D / LayeredCostmap, which live in the costmap package
ANNOTATION_ONLY = {("navstack.core.interfaces", "navstack.costmap.costmap_2d"),
                   ("navstack.core.interfaces", "navstack.costmap.layered_costmap")}
# names ``navstack/__init__.py`` resolves lazily, and the layer they come from
PACKAGE_ATTRIBUTES = {"NavStack": "interfaces", "Navigator": "interfaces",
                      "TaskResult": "interfaces"}


@dataclass(frozen=True)
class Import:
    module: str  # the importing module, "navstack.localization.ekf.node"
    line: int
    target: str  # the imported module, "navstack.runtime.bus"
    type_checking: bool = False  # inside ``if TYPE_CHECKING:``

    def __str__(self) -> str:
        return f"{self.module} (line {self.line}) imports {self.target}"


def module_name(path: Path, root: Path) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _absolute(module: str, is_package: bool, level: int, name: str | None) -> str:
    """The absolute module a ``from <dots><name> import`` in ``module`` refers to."""
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level > 1:
        base = base[:len(base) - (level - 1)]
    return ".".join([*base, name] if name else base)


def imports_of(path: Path, root: Path) -> list[Import]:
    """Every navstack module ``path`` imports, wherever the import statement is."""
    module = module_name(path, root)
    is_package = path.name == "__init__.py"
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: list[Import] = []
    guarded = {id(n) for guard in ast.walk(tree) if isinstance(guard, ast.If)
               and isinstance(guard.test, ast.Name) and guard.test.id == "TYPE_CHECKING"
               for stmt in guard.body for n in ast.walk(stmt)}
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = (_absolute(module, is_package, node.level, node.module) if node.level
                    else node.module or "")
            if base == root.name:  # from navstack import runtime / NavStack
                targets = [f"{base}.{PACKAGE_ATTRIBUTES.get(a.name, a.name)}"
                           for a in node.names]
            else:
                targets = [base]
        elif (isinstance(node, ast.Call) and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
              and ((isinstance(node.func, ast.Attribute) and node.func.attr == "import_module")
                   or (isinstance(node.func, ast.Name)
                       and node.func.id in ("import_module", "__import__")))):
            targets = [node.args[0].value]
        found += [Import(module, node.lineno, t, id(node) in guarded) for t in targets
                  if t == root.name or t.startswith(root.name + ".")]
    return sorted(found, key=lambda i: i.line)  # ast.walk is breadth first


def violations(root: Path, package: str, forbidden: tuple[str, ...]) -> list[Import]:
    """Imports of ``root/package`` (recursively) into any of the ``forbidden`` packages."""
    bad = tuple(f"{root.name}.{name}" for name in forbidden)
    out: list[Import] = []
    for path in sorted((root / package).rglob("*.py")):
        out += [imp for imp in imports_of(path, root)
                if not (imp.type_checking and (imp.module, imp.target) in ANNOTATION_ONLY)
                and any(imp.target == b or imp.target.startswith(b + ".") for b in bad)]
    return out


@pytest.mark.parametrize("package", sorted(RULES))
def test_package_imports_only_from_below(package: str) -> None:
    found = violations(SRC, package, RULES[package])
    assert not found, (f"{package}/ must not import {', '.join(RULES[package])}:\n  "
                       + "\n  ".join(map(str, found)))


def test_annotation_only_exceptions_are_used_and_guarded() -> None:
    """Each allowed pair exists, and only under ``if TYPE_CHECKING:`` (so a run-time import
    of the costmap from core would still fail the rule above)."""
    seen = {(i.module, i.target): i.type_checking
            for i in imports_of(SRC / "core" / "interfaces.py", SRC)}
    for pair in ANNOTATION_ONLY:
        assert seen.get(pair) is True, pair


def test_every_algorithm_package_exists_and_is_checked() -> None:
    for package in (*ALGORITHMS, "nodes", "drivers", "missions", "core"):
        assert (SRC / package / "__init__.py").is_file(), package
        assert any((SRC / package).rglob("*.py"))


def test_the_checker_finds_every_kind_of_import(tmp_path: Path) -> None:
    """A fake ``navstack`` tree with one upward import of each kind: all are reported."""
    root = tmp_path / "navstack"
    (root / "localization" / "amcl").mkdir(parents=True)
    for pkg in (root, root / "localization", root / "localization" / "amcl"):
        (pkg / "__init__.py").write_text("")
    (root / "localization" / "amcl" / "node.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "import numpy\n"
        "from navstack.core.msgs import Pose2D\n"
        "from navstack.localization.amcl import params\n"
        "import navstack.runtime.bus as bus\n"
        "if TYPE_CHECKING:\n"
        "    from navstack.interfaces.stack import NavStack\n"
        "def f():\n"
        "    from ...benchmarks import common\n"
        "    from .. import navsat\n"
        "    from navstack import nodes, NavStack\n"
        "    import importlib\n"
        "    return importlib.import_module('navstack.sim.world')\n"
        "try:\n"
        "    from navstack.navigation.map_server import MapServer\n"
        "except ImportError:\n"
        "    pass\n")
    found = violations(root, "localization", ABOVE_ALGORITHMS)
    assert [(i.line, i.target) for i in found] == [
        (5, "navstack.runtime.bus"), (7, "navstack.interfaces.stack"),
        (9, "navstack.benchmarks"), (11, "navstack.nodes"), (11, "navstack.interfaces"),
        (13, "navstack.sim.world"), (15, "navstack.navigation.map_server")]
    assert str(found[0]) == "navstack.localization.amcl.node (line 5) imports navstack.runtime.bus"


def test_importing_the_ekf_does_not_import_the_bus() -> None:
    """``import navstack.localization.ekf`` in a fresh interpreter loads no module of the
    runtime (bus, node, scheduler), the node layer or anything above."""
    layers = ("runtime", "nodes", "navigation", "interfaces", "benchmarks", "sim")
    code = ("import sys\n"
            "import navstack.localization.ekf as ekf\n"
            "assert ekf.Ekf and ekf.EkfParams\n"
            f"loaded = sorted(m for m in sys.modules if m.split('.')[1:2] and "
            f"m.split('.')[0] == 'navstack' and m.split('.')[1] in {layers!r})\n"
            "print('\\n'.join(loaded))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "", f"importing the EKF loaded: {out.stdout.split()}"
