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
    transport:                    # optional: robot / base split over Zenoh (issue 21)
      robot: {kind: zenoh, listen: ["tcp/127.0.0.1:7447"], peers: [base]}
      base: {kind: zenoh, connect: ["tcp/127.0.0.1:7447"], peers: [robot]}

Navigation parameters are read in Nav2's own layout (``controller_server:
ros__parameters: ...``), so existing Nav2 parameter files load unchanged.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field

from navstack.core.config_files import ROS_PARAMETERS, load_yaml, ros_parameters
from navstack.core.errors import ConfigError
from navstack.core.params import Params
from navstack.runtime.transports.config import TransportSection

__all__ = ["ROS_PARAMETERS", "StackConfig", "load_stack", "load_yaml", "ros_parameters"]


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
    #: per process name (``robot``, ``base``, ``robot1``...): how it joins the others
    #: (:mod:`navstack.runtime.transports.config`); empty = one process, in-process bus
    transport: dict[str, TransportSection] = Field(default_factory=dict)
    source_file: str = ""

    def navigation_file(self) -> Path | None:
        """The Nav2 parameter file ``navigation`` names (relative to the stack file), or
        ``None`` when the parameters are inline."""
        if not isinstance(self.navigation, str):
            return None
        if not self.navigation.strip():
            raise ConfigError("is an empty file name", file=self.source_file,
                              key_path="navigation", suggestion=(
                                  "name a Nav2 parameter file, give the Nav2 layout inline, "
                                  "or leave navigation out for the packaged defaults"))
        base = Path(self.source_file).parent if self.source_file else Path.cwd()
        path = Path(self.navigation)
        return path if path.is_absolute() else base / path

    def navigation_params(self) -> dict[str, Any]:
        """The Nav2-layout navigation parameters (loading the referenced file if a path)."""
        if isinstance(self.navigation, str):
            return load_yaml(self.navigation_file() or self.navigation)
        return dict(self.navigation)


STACK_KEYS = ("name", "seed", "robot", "world", "sim", "navigation", "transport")


def load_stack(path: str | Path) -> StackConfig:
    """Load and validate a stack file; raises ConfigError naming file and key path.

    An empty file is an error (it describes nothing; ``navstack run`` without ``--stack``
    runs the defaults)."""
    data = load_yaml(path)
    if not data:
        raise ConfigError("empty stack file", file=str(path), suggestion=(
            f"give at least one of {', '.join(STACK_KEYS)}, e.g. 'world: {{name: office}}'"))
    data.setdefault("source_file", str(path))
    return StackConfig.from_mapping(data, file=str(path))
