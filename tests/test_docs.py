"""The user guide's generated references cover what the code has.

The generators live in ``docs/hooks/`` (run by ``mkdocs build``, which ``make test``
runs with ``--strict``); these tests check their output against the code by independent
means: the parameter keys against every params model found by scanning each module's
namespace, the CLI options against the ``--help`` of every command.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
from pathlib import Path

import yaml
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "hooks"))

import cli_reference  # noqa: E402
import params_reference  # noqa: E402

import navstack  # noqa: E402
from navstack.core.params import Params  # noqa: E402


def _models_by_module_scan() -> dict[str, type[Params]]:
    """Every Params subclass defined at module level in navstack, found by reading each
    module's namespace (not by ``__subclasses__`` as the generator does)."""
    found: dict[str, type[Params]] = {}
    for info in pkgutil.walk_packages(navstack.__path__, "navstack."):
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if (inspect.isclass(obj) and issubclass(obj, Params) and obj is not Params
                    and obj.__module__ == module.__name__):
                found[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return found


def _documented_keys() -> dict[str, set[str]]:
    """``{model anchor: {key, ...}}`` parsed from the generated parameter pages."""
    documented: dict[str, set[str]] = {}
    for path, text in params_reference.pages().items():
        current = None
        for line in text.splitlines():
            heading = re.match(r"^### .* \{#([\w.]+)\}$", line)
            if heading:
                current = heading.group(1)
                assert current not in documented, f"{current} documented twice ({path})"
                documented[current] = set()
                continue
            row = re.match(r"^\| `([^`]+)` \|", line)
            if row and current is not None:
                documented[current].add(row.group(1))
    return documented


def test_parameter_reference_lists_every_key_of_every_model() -> None:
    models = _models_by_module_scan()
    documented = _documented_keys()
    assert len(models) > 50
    missing_models = sorted(set(models) - set(documented))
    assert not missing_models, f"params models missing from the reference: {missing_models}"
    for anchor, model in models.items():
        keys = {info.alias or name for name, info in model.model_fields.items()}
        assert documented[anchor] == keys, (
            f"{anchor}: missing {sorted(keys - documented[anchor])}, "
            f"stale {sorted(documented[anchor] - keys)}")


def test_parameter_reference_gives_units_ranges_and_plugin_types() -> None:
    models = {m.anchor: m for m in params_reference.collect()}
    inflation = models["navstack.costmap.inflation_layer.InflationLayerParams"]
    assert "nav2_costmap_2d::InflationLayer" in inflation.plugin_types
    radius = next(k for k in inflation.keys if k.name == "inflation_radius")
    assert (radius.default, radius.allowed, radius.ros_name) == ("0.55", ">= 0", True)
    kinematics = models["navstack.sim.kinematics.KinematicsParams"]
    assert {k.name: k.unit for k in kinematics.keys}["max_vel_theta"] == "rad/s"
    slam = {k.name: k for k in models["navstack.mapping.slam_params.SlamParams"].keys}
    assert slam["resolution"].ros_name and not slam["loop_match_maximum_ambiguity"].ros_name


def _help_options(runner: CliRunner, path: tuple[str, ...]) -> set[str]:
    from navstack.app import app

    res = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "250", "NO_COLOR": "1"})
    assert res.exit_code == 0, res.output
    return set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", res.output)) - {"--help"}


def test_cli_reference_has_every_command_and_option() -> None:
    page = cli_reference.render()
    sections = dict(re.findall(r"^#{2,4} (navstack[\w -]*)\n(.*?)(?=^#{2,4} navstack|\Z)",
                               page, re.MULTILINE | re.DOTALL))
    runner = CliRunner()
    commands = dict(cli_reference.walk(cli_reference.command_tree()))
    assert len(commands) > 10
    for path, command in commands.items():
        title = " ".join(("navstack", *path))
        assert title in sections, f"{title} missing from the CLI reference"
        documented = set(re.findall(r"`(--[a-z][a-z0-9-]*)`", sections[title])) - {"--help"}
        options = _help_options(runner, path)
        if not cli_reference.is_group(command):
            assert documented == options, f"{title}: reference {documented}, --help {options}"


def test_guide_builds_offline_and_commits_nothing_generated() -> None:
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    plugins = {next(iter(p)) if isinstance(p, dict) else p for p in config["plugins"]}
    assert plugins <= {"search", "offline", "mkdocstrings"}  # none fetches at build time
    assert config["theme"]["font"] is False and config["strict"] is True
    assert not (ROOT / "docs" / "reference").exists()


def test_every_design_note_is_in_the_navigation() -> None:
    import navstack_docs

    config = {"docs_dir": str(ROOT / "docs")}
    nav = navstack_docs.on_config(config)["nav"]
    notes = next(item["Design notes"] for item in nav if "Design notes" in item)
    assert notes[0] == "decisions.md"
    on_disk = {p.name for p in (ROOT / "docs").glob("*.md")}
    assert on_disk - set(notes) == {"index.md", "getting-started.md", "nav2.md"}
