"""What a :class:`~navstack.interfaces.stack.NavStack` runs, as data: nodes and parameters.

``NavStack(...)`` resolves its arguments into a :class:`StackDescription` -- the world,
the robot, how the robot is localized, and every node with the parameters it will be
configured with -- validating them on the way (a bad value is a ``ConfigError`` naming
the file and key before anything runs).  ``NavStack.start()`` brings the description
up.  A user inspects it with ``stack.description.nodes`` or prints
``stack.description.summary()``, the counterpart of reading a Nav2 launch file.

Localization is a typed option (:data:`Localization`), or its name:

* ``"perfect"`` / :class:`PerfectLocalization` -- the simulator publishes the true
  ``map -> odom`` (the default);
* ``"external"`` / :class:`ExternalLocalization` -- nothing in the stack publishes
  ``map -> odom``; something outside it must (a stack file's
  ``world.perfect_localization: false``);
* ``"amcl"`` / :class:`AmclLocalization` -- Nav2 AMCL on the known map;
* ``"slam"`` / :class:`SlamLocalization` -- slam_toolbox-style mapping while navigating.

The costmap, planner and controller sections are kept as the Nav2 file gives them; their
plugins validate them when ``start()`` builds the servers.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal, get_args

from navstack.control.collision_monitor import CollisionMonitorParams
from navstack.control.twist_mux import TwistMuxParams
from navstack.control.velocity_smoother import VelocitySmootherParams
from navstack.core.config_files import ros_parameters
from navstack.core.errors import ConfigError, UnknownNameError, did_you_mean
from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.core.params import Params
from navstack.core.polygon import Footprint
from navstack.interfaces.command_chain import command_chain
from navstack.localization.amcl.params import AmclParams
from navstack.mapping.slam_params import SlamParams
from navstack.navigation.behavior_server import BehaviorServerParams
from navstack.navigation.bt_navigator import BtNavigatorParams
from navstack.navigation.trees import NavigateTreeParams
from navstack.navigation.waypoint_follower import WaypointFollowerParams
from navstack.sim.robot import RobotParams
from navstack.sim.world import World

__all__ = ["AmclLocalization", "ExternalLocalization", "Localization", "LocalizationName",
           "NodeSpec", "PerfectLocalization", "SlamLocalization", "StackDescription",
           "describe_stack", "localization_option"]

LocalizationName = Literal["perfect", "external", "amcl", "slam"]


@dataclass(frozen=True)
class PerfectLocalization:
    """The simulator publishes the true ``map -> odom`` (10 Hz, future-dated like AMCL)."""

    name: ClassVar[str] = "perfect"


@dataclass(frozen=True)
class ExternalLocalization:
    """No node of the stack publishes ``map -> odom``: an outside publisher must."""

    name: ClassVar[str] = "external"


@dataclass(frozen=True)
class AmclLocalization:
    """AMCL on the known map instead of the simulator's perfect ``map -> odom``.

    ``params`` (Nav2 ``amcl`` keys) override the Nav2 file's ``amcl:`` section; the initial
    pose is the spawn pose (``set_initial_pose``) unless they give one."""

    params: Mapping[str, Any] = field(default_factory=dict)
    name: ClassVar[str] = "amcl"


@dataclass(frozen=True)
class SlamLocalization:
    """Map while navigating: a SLAM node builds ``/map`` and publishes ``map -> odom``.

    ``params``: :class:`SlamParams` or slam_toolbox keys.  The map frame starts at the
    spawn pose (``map_start_pose``, so goals keep the world's coordinates) and the map
    covers the world's bounds (``map_minimum_extent``); there is no map server."""

    params: SlamParams | Mapping[str, Any] = field(default_factory=dict)
    name: ClassVar[str] = "slam"


Localization = PerfectLocalization | ExternalLocalization | AmclLocalization | SlamLocalization
_BY_NAME: dict[str, type[Localization]] = {
    cls.name: cls for cls in (PerfectLocalization, ExternalLocalization, AmclLocalization,
                              SlamLocalization)}
assert set(_BY_NAME) == set(get_args(LocalizationName))


def localization_option(value: LocalizationName | Localization) -> Localization:
    """The option object for ``value`` (a name gets the option's defaults)."""
    if isinstance(value, PerfectLocalization | ExternalLocalization | AmclLocalization
                  | SlamLocalization):
        return value
    if isinstance(value, str):
        cls = _BY_NAME.get(value)
        if cls is None:
            raise ConfigError(f"unknown localization {value!r}; choose one of "
                              f"{', '.join(map(repr, _BY_NAME))}", key_path="localization",
                              suggestion=did_you_mean(value, _BY_NAME).strip(" ()"))
        return cls()
    raise ConfigError(f"expected a name ({', '.join(map(repr, _BY_NAME))}) or a "
                      f"PerfectLocalization / ExternalLocalization / AmclLocalization / "
                      f"SlamLocalization option, got {type(value).__name__} {value!r}",
                      key_path="localization")


@dataclass(frozen=True)
class NodeSpec:
    """One node of the stack: its name in the runtime, the class that runs it, the
    parameters it is configured with and its other construction inputs."""

    name: str
    kind: str
    params: Params | Mapping[str, Any]
    inputs: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class StackDescription:
    """Everything ``NavStack.start()`` brings up, resolved and validated."""

    world: World
    robot: RobotParams
    seed: int
    spawn: Pose2D
    """Where the robot starts (the given spawn pose, else the world's)."""
    physics_rate_hz: float
    localization: Localization
    nav2_file: str
    """The Nav2 parameter file the sections come from (``<nav2 params>`` for a mapping)."""
    nav2_params: Mapping[str, Any]
    map_grid: OccupancyGrid | None
    """The map given to navigation; ``None``: the world's true static map (unused with
    SLAM, which builds its own)."""
    footprint: Footprint
    """What navigation plans with: the body padded by the costmaps' footprint_padding."""
    body_footprint: Footprint
    """The robot body itself (recoveries and the collision monitor check it)."""
    amcl: AmclParams | None
    slam: SlamParams | None
    global_costmap: Mapping[str, Any]
    local_costmap: Mapping[str, Any]
    planner_server: Mapping[str, Any]
    controller_server: Mapping[str, Any]
    behavior_server: BehaviorServerParams
    velocity_smoother: VelocitySmootherParams
    collision_monitor: CollisionMonitorParams
    twist_mux: TwistMuxParams
    """The command chain (``docs/command_path.md``)."""
    bt_navigator: BtNavigatorParams
    navigate_tree: NavigateTreeParams
    waypoint_follower: WaypointFollowerParams

    @property
    def has_map_server(self) -> bool:
        return self.slam is None

    @property
    def nodes(self) -> tuple[NodeSpec, ...]:
        """The nodes in bring-up order, each with its parameters."""
        loc = self.localization
        specs = [NodeSpec("simulator", "navstack.sim.node.SimulatorNode", {
            "world": self.world.name, "robot": self.robot.name, "seed": self.seed,
            "spawn": (self.spawn.x, self.spawn.y, self.spawn.theta),
            "physics_rate_hz": self.physics_rate_hz,
            "perfect_localization": isinstance(loc, PerfectLocalization)})]
        if self.has_map_server:
            source = "map_grid" if self.map_grid is not None else f"world '{self.world.name}'"
            specs.append(NodeSpec("map_server", "navstack.navigation.map_server.MapServer",
                                  {"topic": "/map", "frame_id": "map"}, {"map": source}))
        if self.amcl is not None:
            specs.append(NodeSpec("amcl", "navstack.nodes.amcl.AmclNode", self.amcl))
        if self.slam is not None:
            specs.append(NodeSpec("slam_toolbox", "navstack.nodes.slam.SlamNode", self.slam))
        padded = {"footprint": self.footprint}
        specs += [
            NodeSpec("global_costmap", "navstack.navigation.costmap_node.CostmapNode",
                     self.global_costmap, padded),
            NodeSpec("local_costmap", "navstack.navigation.costmap_node.CostmapNode",
                     self.local_costmap, padded),
            NodeSpec("planner_server", "navstack.navigation.planner_server.PlannerServer",
                     self.planner_server, {"costmap": "global_costmap", **padded}),
            NodeSpec("controller_server",
                     "navstack.navigation.controller_server.ControllerServer",
                     self.controller_server, {"costmap": "local_costmap", **padded}),
            NodeSpec("behavior_server", "navstack.navigation.behavior_server.BehaviorServer",
                     self.behavior_server, {"collision_check": "local_costmap, body"}),
            NodeSpec("velocity_smoother",
                     "navstack.navigation.velocity_smoother_node.VelocitySmootherNode",
                     self.velocity_smoother),
            NodeSpec("collision_monitor",
                     "navstack.navigation.collision_monitor_node.CollisionMonitorNode",
                     self.collision_monitor, {"footprint": self.body_footprint}),
            NodeSpec("twist_mux", "navstack.nodes.twist_mux.TwistMuxNode", self.twist_mux),
            NodeSpec("bt_navigator", "navstack.navigation.bt_navigator.BtNavigator",
                     self.bt_navigator, {"tree": self.navigate_tree}),
            NodeSpec("waypoint_follower",
                     "navstack.navigation.waypoint_follower.WaypointFollower",
                     self.waypoint_follower)]
        return tuple(specs)

    def node(self, name: str) -> NodeSpec:
        """The node called ``name``; :class:`UnknownNameError` lists the others."""
        specs = {spec.name: spec for spec in self.nodes}
        if name not in specs:
            raise UnknownNameError("node", name, specs)
        return specs[name]

    def summary(self) -> str:
        """One line per node: name, class, parameter type (or keys) and inputs."""
        lines = [f"world {self.world.name!r}, robot {self.robot.name!r}, seed {self.seed}, "
                 f"localization {self.localization.name!r}, Nav2 parameters {self.nav2_file}"]
        for spec in self.nodes:
            params = (type(spec.params).__name__ if isinstance(spec.params, Params)
                      else "{" + ", ".join(map(str, spec.params)) + "}")
            inputs = ", ".join(f"{k}={_short(v)}" for k, v in spec.inputs.items())
            lines.append(f"  {spec.name:18s} {spec.kind.rsplit('.', 1)[1]:22s} {params}"
                         + (f"  [{inputs}]" if inputs else ""))
        return "\n".join(lines)


def _short(value: Any) -> str:
    return type(value).__name__ if isinstance(value, Footprint | Params) else str(value)


def describe_stack(world: World, robot: RobotParams, nav: Mapping[str, Any], file: str,
                   seed: int, spawn: Pose2D | None, localization: LocalizationName | Localization,
                   physics_rate_hz: float, map_grid: OccupancyGrid | None) -> StackDescription:
    """Resolve and validate a stack: ``nav`` is the Nav2 parameter file's content (read
    from ``file``).  Raises ``ConfigError`` naming the file and the key path."""
    loc = localization_option(localization)
    start = spawn if spawn is not None else world.spawn
    # navigation plans with the body padded by the costmaps' footprint_padding (Nav2)
    padding = ros_parameters(nav, "global_costmap", file=file).get("footprint_padding", 0.01)
    footprint = robot.updated(footprint_padding=float(padding)).footprint_model()
    amcl = slam = None
    if isinstance(loc, AmclLocalization):
        section = ros_parameters(nav, "amcl", file=file)  # the Nav2 file's amcl:
        amcl = AmclParams.from_mapping(
            {"set_initial_pose": True, "base_frame_id": "base_link",
             "initial_pose": {"x": start.x, "y": start.y, "yaw": start.theta},
             **section, **loc.params}, file=file, key_path="amcl")
    elif isinstance(loc, SlamLocalization):
        xmin, ymin, xmax, ymax = world.bounds
        overrides = {"map_start_pose": [start.x, start.y, start.theta],
                     "map_minimum_extent": [xmin, ymin, xmax, ymax]}
        # navigation plans on /map: a map every second (slam_toolbox's 5 s default
        # leaves the planner routing through what the robot already saw blocked)
        live = {"map_update_interval": 1.0}
        if isinstance(loc.params, SlamParams):
            slam = loc.params.updated(**overrides, **{
                k: v for k, v in live.items() if k not in loc.params.model_fields_set})
        else:
            slam = SlamParams.from_mapping({**live, **overrides, **loc.params},
                                           key_path="slam_toolbox")
    bt = ros_parameters(nav, "bt_navigator", file=file)
    tree = bt.pop("tree", None) or {}
    chain = command_chain(nav, file, robot)
    return StackDescription(
        world=world, robot=robot, seed=seed, spawn=start, physics_rate_hz=physics_rate_hz,
        localization=loc, nav2_file=file, nav2_params=nav, map_grid=map_grid,
        footprint=footprint, body_footprint=robot.footprint_model(), amcl=amcl, slam=slam,
        global_costmap=ros_parameters(nav, "global_costmap", file=file),
        local_costmap=ros_parameters(nav, "local_costmap", file=file),
        planner_server=ros_parameters(nav, "planner_server", file=file),
        controller_server=chain.controller_server,
        behavior_server=BehaviorServerParams.from_mapping(
            chain.behavior_server, file=file, key_path="behavior_server"),
        velocity_smoother=chain.velocity_smoother,
        collision_monitor=chain.collision_monitor,
        twist_mux=chain.twist_mux,
        bt_navigator=BtNavigatorParams.from_mapping(bt, file=file, key_path="bt_navigator"),
        navigate_tree=NavigateTreeParams.from_mapping(tree, file=file,
                                                      key_path="bt_navigator.tree"),
        waypoint_follower=WaypointFollowerParams.from_mapping(
            ros_parameters(nav, "waypoint_follower", file=file), file=file,
            key_path="waypoint_follower"))
