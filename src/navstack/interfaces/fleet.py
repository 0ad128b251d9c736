"""A fleet: several robots in one simulated world, one namespace and one stack each.

The layout Nav2's multi-robot bringup uses (``nav2_bringup``'s
``unique_multi_tb3_simulation_launch``): every robot runs its own full stack in its own
namespace -- ``/robot1/scan``, ``/robot1/cmd_vel``, ``/robot1/navigate_to_pose`` -- and its
own per-namespace ``tf`` / ``tf_static`` (Nav2 remaps ``/tf`` to ``tf`` inside the
namespace), so frame names stay ``map``, ``odom``, ``base_link`` inside each namespace and
two robots' transforms never meet.  In process a namespace is one
:class:`~navstack.runtime.node.Runtime` (bus + TF buffer) per robot, all on one shared
:class:`~navstack.runtime.scheduler.Scheduler`: one deterministic clock, one event loop,
no message can reach another robot's bus.  :meth:`Fleet.add_tap` observes every
namespace with fully qualified names (``/robot2/plan``), as a recorder or a base station
subscribing to ``/robot*/...`` would see them.

The world is shared (:class:`~navstack.sim.fleet.FleetSimulator`): every robot's lidar
sees the other robots' bodies, so they enter each other's local costmap (and, through
the obstacle layer, the global one) and the planners and controllers avoid them as any
obstacle; a step into another robot's body is a collision, counted robot-robot.

A fleet file names the world, the robot profile (one for every robot) and per robot its
namespace, spawn pose and route (goals visited in order)::

    name: warehouse_fleet
    world: warehouse
    robot: diff_drive
    seed: 1
    robots:
      - name: robot1
        spawn: [2.0, 2.0, 0.0]
        route:
          - {name: Dock, pose: [25.0, 3.0, -1.5708]}
"""

from __future__ import annotations

import copy
import re
from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path as FsPath
from typing import Any

import yaml
from pydantic import Field, field_validator

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.core.params import Params
from navstack.interfaces.stack import NavStack, default_nav2_params_path
from navstack.navigation.nav2_params import Nav2Params, load_nav2_params
from navstack.runtime.node import Runtime
from navstack.runtime.scheduler import Scheduler
from navstack.runtime.transports.keys import namespaced
from navstack.sim.fleet import FleetMember, FleetSimulator
from navstack.sim.node import FleetSimulatorNode, SimulatorNode
from navstack.sim.robot import load_robot
from navstack.sim.worlds import load_world

_NAMESPACE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

Tap = Callable[[str, Any, float], None]


class FleetGoal(Params):
    """One goal of a route: a name and a pose ``[x, y, yaw]`` in ``map``."""

    name: str
    pose: tuple[float, float, float]


class FleetRobotParams(Params):
    """One robot: its namespace (``robot1``), spawn pose ``[x, y, yaw]`` and route."""

    name: str
    spawn: tuple[float, float, float]
    route: tuple[FleetGoal, ...] = Field(min_length=1)

    @field_validator("name")
    @classmethod
    def _namespace(cls, value: str) -> str:
        if not _NAMESPACE.match(value):
            raise ValueError(f"'{value}' is not a ROS namespace segment (a letter, then "
                             f"letters, digits or '_', e.g. robot1)")
        return value


class FleetParams(Params):
    """A fleet file (module docstring)."""

    name: str = "fleet"
    world: str = "warehouse"
    robot: str = "diff_drive"
    seed: int = 1
    goal_timeout: float = Field(default=240.0, gt=0.0)
    navigation: dict[str, Any] = Field(default_factory=dict)
    """Nav2 parameters (Nav2 layout) deep-merged over the packaged defaults for every
    robot: only the keys that differ need be given."""
    robots: tuple[FleetRobotParams, ...] = Field(min_length=1)

    def nav2_params(self) -> dict[str, Any]:
        """The packaged Nav2 parameters with :attr:`navigation` merged in."""
        base = yaml.safe_load(default_nav2_params_path().read_text())
        return _deep_merge(base, self.navigation)


def _deep_merge(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(base.get(key), dict):
            _deep_merge(base[key], value)
        else:
            base[key] = copy.deepcopy(value)
    return base


def default_fleet_path() -> FsPath:
    from importlib import resources

    return FsPath(str(resources.files("navstack") / "config" / "warehouse_fleet.yaml"))


def load_fleet(path: str | FsPath | None = None) -> FleetParams:
    """Read and validate a fleet file (default: the packaged three-robot warehouse)."""
    file = FsPath(path) if path is not None else default_fleet_path()
    try:
        data = yaml.safe_load(file.read_text())
    except OSError as exc:
        raise ConfigError(f"cannot read the fleet file: {exc.strerror or exc}",
                          file=str(file)) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"invalid YAML: {exc}", file=str(file)) from None
    if not isinstance(data, Mapping):
        raise ConfigError("must be a mapping with 'robots'", file=str(file))
    return FleetParams.from_mapping(data, file=str(file))


class Fleet:
    """The robots of a fleet file, each a :class:`NavStack` in its namespace, in one world.

    ``robots``: use only the first N robots of the file; ``nav2_params``: the Nav2 file
    every robot's stack uses instead of the file's (default: the packaged Nav2 file with
    the fleet file's ``navigation`` merged in)."""

    def __init__(self, params: FleetParams, *, robots: int | None = None,
                 nav2_params: str | FsPath | Mapping[str, Any] | Nav2Params | None = None,
                 physics_rate_hz: float = 50.0) -> None:
        if robots is not None and not 1 <= robots <= len(params.robots):
            raise ConfigError(f"--robots {robots}: the fleet '{params.name}' defines "
                              f"{len(params.robots)} robots", key_path="robots",
                              suggestion=f"choose 1..{len(params.robots)} or add robots")
        self.params = params
        self.members = params.robots[:robots] if robots is not None else params.robots
        self.world = load_world(params.world)
        self.robot = load_robot(params.robot)
        self.scheduler = Scheduler()
        self.physics = FleetSimulator(
            self.world, [FleetMember(r.name, self.robot, Pose2D(*r.spawn)) for r in self.members],
            params.seed, physics_rate_hz)
        nav = (load_nav2_params(nav2_params) if nav2_params is not None else
               load_nav2_params(params.nav2_params(), file=f"fleet '{params.name}' navigation"))
        self.stacks: dict[str, NavStack] = {
            r.name: NavStack(self.world, self.robot, nav, params.seed, Pose2D(*r.spawn),
                             physics_rate_hz=physics_rate_hz, scheduler=self.scheduler,
                             simulator_node=partial(_simulator_node, self.physics, r.name))
            for r in self.members}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.stacks)

    def start(self) -> Fleet:
        """Bring every robot's stack up (idempotent)."""
        for stack in self.stacks.values():
            stack.start()
        return self

    def runtime(self, name: str) -> Runtime:
        """The runtime (bus, TF buffer) of namespace ``name``."""
        if name not in self.stacks:
            raise ConfigError(f"no robot '{name}' in the fleet; robots: {', '.join(self.names)}")
        return self.stacks[name].runtime

    @property
    def now(self) -> float:
        return self.scheduler.now

    def run_for(self, seconds: float) -> None:
        """Advance simulated time for every robot."""
        self.start()
        self.scheduler.run_for(seconds)
        self.physics.advance_to(self.scheduler.now)

    def add_tap(self, tap: Tap) -> Callable[[], None]:
        """Observe every message of every namespace as ``tap(full_topic, msg, t)`` with
        the namespaced name (``/robot1/scan``); returns the function that removes it."""
        self.start()
        removers = [stack.runtime.bus.add_tap(partial(_prefixed, tap, name))
                    for name, stack in self.stacks.items()]

        def remove() -> None:
            for r in removers:
                r()
        return remove


def _prefixed(tap: Tap, namespace: str, topic: str, msg: Any, t: float) -> None:
    tap(namespaced(namespace, topic), msg, t)


def _simulator_node(physics: FleetSimulator, name: str, runtime: Runtime,
                    perfect_localization: bool, wired: frozenset[str]) -> SimulatorNode:
    return FleetSimulatorNode(runtime, physics, name, perfect_localization, wired)
