"""Configuration loading: YAML files, Nav2's ``ros__parameters`` layout, stack files.

Every problem is a :class:`~navstack.core.errors.ConfigError` whose one-line text names
the file, the key path and, for unknown keys, the closest known key — never a traceback.

A *stack file* describes one running system::

    name: office_demo
    seed: 1
    robot: turtlebot              # built-in profile name, a YAML path, or an inline mapping
    world: {name: office, perfect_localization: true}
    sim: {duration: 60.0, rate: null}
    navigation: nav2_params.yaml  # Nav2 parameter file (or inline Nav2 layout)

Navigation parameters are read in Nav2's own layout (``controller_server:
ros__parameters: ...``), so existing Nav2 parameter files load unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml
from pydantic import Field

from navstack.core.errors import ConfigError, did_you_mean
from navstack.core.params import Params

ROS_PARAMETERS = "ros__parameters"


def load_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML mapping; missing files, syntax errors and non-mappings are ConfigErrors."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError("file not found", file=str(p),
                          suggestion="check the path" if not p.exists() else "it is a directory")
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        raise ConfigError(f"invalid YAML: {where}{exc.problem}", file=str(p)) from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise ConfigError(f"invalid YAML: {exc}", file=str(p)) from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"top level must be a mapping of keys, got {type(data).__name__}",
                          file=str(p))
    return data


def ros_parameters(data: Mapping[str, Any], server: str, *, file: str = "",
                   required: bool = False) -> dict[str, Any]:
    """Parameters of one Nav2 server from a parameter file's data.

    Accepts ``server: {ros__parameters: {...}}``, the nested costmap form
    ``global_costmap: {global_costmap: {ros__parameters: {...}}}``, and merges the wildcard
    ``/**: {ros__parameters: {...}}`` underneath the server's own values.
    """
    merged: dict[str, Any] = {}
    wildcard = data.get("/**")
    if isinstance(wildcard, Mapping) and isinstance(wildcard.get(ROS_PARAMETERS), Mapping):
        merged.update(wildcard[ROS_PARAMETERS])
    node = data.get(server)
    if node is None:
        if required:
            raise ConfigError(f"no parameters for '{server}'", file=file, key_path=server,
                              suggestion=did_you_mean(server, data).strip(" ()")
                              or f"add '{server}: {ROS_PARAMETERS}: ...'")
        return merged
    if not isinstance(node, Mapping):
        raise ConfigError("must be a mapping", file=file, key_path=server)
    if ROS_PARAMETERS not in node and isinstance(node.get(server), Mapping):
        node = node[server]  # nested costmap layout
        server = f"{server}.{server}"
    params = node.get(ROS_PARAMETERS)
    if params is None:
        unknown = [k for k in node if k != ROS_PARAMETERS]
        hint = did_you_mean(unknown[0], [ROS_PARAMETERS]).strip(" ()") if unknown else ""
        raise ConfigError(f"missing '{ROS_PARAMETERS}'", file=file, key_path=server,
                          suggestion=hint or f"nest the values under '{ROS_PARAMETERS}:'")
    if not isinstance(params, Mapping):
        raise ConfigError("must be a mapping", file=file, key_path=f"{server}.{ROS_PARAMETERS}")
    merged.update(params)
    return merged


class WorldSection(Params):
    """Which world to run in and how the simulator treats it."""

    name: str = "office"
    perfect_localization: bool = True
    spawn: tuple[float, float, float] | None = None


class SimSection(Params):
    """Simulation clock: ``rate`` x real time (``None`` = as fast as possible)."""

    duration: float = Field(60.0, gt=0.0)
    rate: float | None = Field(None, gt=0.0)
    physics_rate_hz: float = Field(50.0, gt=0.0, le=2000.0)


class StackConfig(Params):
    """A whole stack: robot, world, simulation clock and navigation parameters."""

    name: str = "stack"
    seed: int = 0
    robot: str | dict[str, Any] = "diff_drive"
    world: WorldSection = WorldSection()
    sim: SimSection = SimSection()
    navigation: str | dict[str, Any] = Field(default_factory=dict)
    source_file: str = ""

    def navigation_params(self) -> dict[str, Any]:
        """The Nav2-layout navigation parameters (loading the referenced file if a path)."""
        if isinstance(self.navigation, str):
            base = Path(self.source_file).parent if self.source_file else Path.cwd()
            path = Path(self.navigation)
            return load_yaml(path if path.is_absolute() else base / path)
        return dict(self.navigation)


def load_stack(path: str | Path) -> StackConfig:
    """Load and validate a stack file; raises ConfigError naming file and key path."""
    data = load_yaml(path)
    data.setdefault("source_file", str(path))
    return StackConfig.from_mapping(data, file=str(path))
