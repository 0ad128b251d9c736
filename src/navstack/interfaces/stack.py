"""``NavStack``: the default navigation stack in one process, on the built-in simulator.

Wires the data flow of ARCHITECTURE.md §2: simulator (``/scan``, ``/odom``, ``/tf``) ->
map server (``/map``) -> global costmap (map) + planner server -> local costmap (odom) +
controller server and behavior server (``/cmd_vel_nav``) -> velocity smoother ->
collision monitor -> twist_mux (``/cmd_vel``; e-stop lock ``/emergency_stop``) -> base;
BT navigator and waypoint follower orchestrate (``docs/command_path.md``).
Navigation parameters are a Nav2 parameter file (the packaged default is
``navstack/config/nav2_params.yaml``).  The robot's footprint comes from its profile and
overrides ``robot_radius``/``footprint`` in the costmap sections.

Construction only describes the stack (:attr:`NavStack.description`: which nodes, with
which parameters, all validated); :meth:`NavStack.start` builds the nodes, brings them up
and runs the first instant.  ``start()`` is idempotent, and what drives a stack starts
it: :class:`~navstack.interfaces.api.Navigator`, :meth:`NavStack.run_for`, the live
runner and the health session.  The running parts (``runtime``, ``sim``, the servers)
exist only after ``start()``; reading them before raises :class:`StackNotStarted`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from navstack.core.errors import LifecycleError
from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.costmap.footprint import footprint_cost
from navstack.costmap.footprint_penetration import penetration_depth
from navstack.interfaces.stack_description import (
    Localization,
    LocalizationName,
    PerfectLocalization,
    StackDescription,
    describe_stack,
)
from navstack.navigation.behavior_server import BehaviorServer
from navstack.navigation.bt_navigator import BtNavigator
from navstack.navigation.collision_monitor_node import CollisionMonitorNode
from navstack.navigation.controller_server import ControllerServer
from navstack.navigation.costmap_filter_servers import FilterServers, create_filter_servers
from navstack.navigation.costmap_node import CostmapNode
from navstack.navigation.map_server import MapServer
from navstack.navigation.nav2_params import Nav2Params, load_nav2_params, stack_navigation
from navstack.navigation.planner_server import PlannerServer
from navstack.navigation.velocity_smoother_node import VelocitySmootherNode
from navstack.navigation.waypoint_follower import WaypointFollower
from navstack.nodes.amcl import AmclNode
from navstack.nodes.slam import SlamNode
from navstack.nodes.twist_mux import TwistMuxNode
from navstack.runtime.config import load_stack
from navstack.runtime.node import Runtime
from navstack.runtime.scheduler import Scheduler
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import RobotParams, load_robot, robot_from_mapping
from navstack.sim.simulator import Simulator
from navstack.sim.world import World
from navstack.sim.worlds import load_world

__all__ = ["NavStack", "StackExtension", "StackNotStarted", "default_nav2_params_path"]


def default_nav2_params_path() -> Path:
    return Path(str(resources.files("navstack") / "config" / "nav2_params.yaml"))


class StackExtension(Protocol):
    """Nodes added to a stack at ``start()``, right after the simulator (a vehicle link
    and its simulated vehicle, :mod:`navstack.interfaces.hil`).  ``wired``: the parts of
    the simulated robot the extension serves instead of the simulator node (``"base"``,
    ``"odometry"``, ``"imu"``, ``"gnss"``, ``"magnetometer"``)."""

    wired: frozenset[str]

    def attach(self, runtime: Runtime, sim: SimulatorNode) -> None: ...

    def ready(self, runtime: Runtime) -> bool:
        """Whether the extension is up (``start()`` waits for it, at most 2 s)."""


class SimulatorNodeFactory(Protocol):
    """Builds a stack's simulator node: ``(runtime, perfect_localization, wired)``."""

    def __call__(self, runtime: Runtime, perfect_localization: bool,
                 wired: frozenset[str]) -> SimulatorNode: ...


class StackNotStarted(LifecycleError):
    """A running part of a :class:`NavStack` was read before :meth:`NavStack.start`."""


@dataclass
class _Running:
    """The nodes of a started stack."""

    runtime: Runtime
    sim: SimulatorNode
    map_server: MapServer | None
    amcl: AmclNode | None
    slam: SlamNode | None
    global_costmap: CostmapNode
    local_costmap: CostmapNode
    filter_servers: FilterServers
    planner: PlannerServer
    controller: ControllerServer
    behaviors: BehaviorServer
    velocity_smoother: VelocitySmootherNode
    collision_monitor: CollisionMonitorNode
    twist_mux: TwistMuxNode
    navigator: BtNavigator
    waypoint_follower: WaypointFollower


class NavStack:
    """Simulator + Nav2-equivalent servers in one ``Runtime``: described on construction,
    configured and active after :meth:`start`."""

    def __init__(self, world: str | World = "office", robot: str | RobotParams = "diff_drive",
                 nav2_params: str | Path | Mapping[str, Any] | Nav2Params | None = None,
                 seed: int = 0,
                 spawn: Pose2D | None = None, *,
                 localization: LocalizationName | Localization = "perfect",
                 physics_rate_hz: float = 50.0, map_grid: OccupancyGrid | None = None,
                 extensions: Sequence[StackExtension] = (),
                 scheduler: Scheduler | None = None,
                 simulator_node: SimulatorNodeFactory | None = None) -> None:
        """``world``: a built-in name, a world/map file, or a :class:`World`; ``map_grid``:
        the map given to navigation (default: the world's true static map).

        ``localization``: ``"perfect"`` (the simulator's true ``map -> odom``),
        ``"external"`` (none: something outside the stack publishes it), ``"amcl"`` (AMCL
        on the known map, initial pose = spawn pose) or ``"slam"`` (map while navigating;
        no map server), or an option object with parameters --
        ``AmclLocalization({...Nav2 amcl keys})``, ``SlamLocalization(SlamParams | {...})``
        (:mod:`navstack.interfaces.stack_description`).

        ``scheduler``: run on this scheduler (clock) instead of a new one -- the robots of
        a fleet share one; ``simulator_node``: builds the simulator node instead of a
        simulator of its own (a fleet robot, :class:`~navstack.sim.node.FleetSimulatorNode`),
        called with the runtime, whether localization is perfect and the wired parts.

        Nothing runs yet: the arguments are resolved and validated into
        :attr:`description`; :meth:`start` brings the stack up."""
        checked = load_nav2_params(nav2_params)  # errors name the file; partial files merge
        nav, file = checked.data, checked.file
        self.description: StackDescription = describe_stack(
            load_world(world) if isinstance(world, str) else world,
            load_robot(robot) if isinstance(robot, str) else robot,
            nav, file, seed, spawn, localization, physics_rate_hz, map_grid)
        d = self.description
        self.nav2_params = nav
        self.world = d.world
        self.robot = d.robot
        self.footprint = d.footprint
        self.body_footprint = d.body_footprint
        self.extensions = tuple(extensions)
        self._scheduler = scheduler
        self._simulator_node = simulator_node
        self._running: _Running | None = None

    # --- bring-up --------------------------------------------------------------------------
    @property
    def started(self) -> bool:
        return self._running is not None

    def start(self) -> NavStack:
        """Build the described nodes, configure and activate them, and run the first
        instant (a first costmap cycle; with AMCL, until its first ``map -> odom``, at most
        2 s).  Idempotent; returns the stack."""
        if self._running is not None:
            return self
        rt = Runtime(self._scheduler)
        sim = self._start_simulation(rt)
        for extension in self.extensions:
            extension.attach(rt, sim)
        map_server, amcl, slam = self._start_localization(rt)
        filter_servers = self._start_filter_servers(rt)
        global_costmap, local_costmap = self._start_costmaps(rt)
        planner, controller, behaviors = self._start_servers(rt, global_costmap,
                                                             local_costmap)
        smoother, monitor, mux = self._start_command_chain(rt)
        navigator, follower = self._start_navigators(rt)
        self._running = _Running(rt, sim, map_server, amcl, slam, global_costmap,
                                 local_costmap, filter_servers, planner, controller,
                                 behaviors, smoother, monitor, mux, navigator, follower)
        rt.bring_up()
        # a first costmap cycle so planners never see an empty map at t=0
        rt.scheduler.run_until(0.0)
        if self.extensions:  # e.g. a vehicle link's first odometry and map -> odom
            rt.scheduler.run_until(2.0, until=lambda: all(e.ready(rt) for e in self.extensions))
            sim.advance()
        if amcl is not None:
            # AMCL publishes map -> odom after its first scan: wait for it (as a Nav2
            # launch waits for localization before sending goals), at most 2 s
            rt.scheduler.run_until(2.0, until=lambda: rt.tf.can_transform("map", "odom"))
            sim.advance()
        global_costmap.update()
        local_costmap.update()
        return self

    def _start_simulation(self, rt: Runtime) -> SimulatorNode:
        d = self.description
        perfect = isinstance(d.localization, PerfectLocalization)
        wired = frozenset().union(*(e.wired for e in self.extensions))
        if self._simulator_node is not None:
            return self._simulator_node(rt, perfect, wired)
        return SimulatorNode(rt, Simulator(d.world, d.robot, d.seed, d.spawn),
                             d.physics_rate_hz, perfect, wired=wired)

    def _start_localization(self, rt: Runtime
                            ) -> tuple[MapServer | None, AmclNode | None, SlamNode | None]:
        """Map server (unless SLAM builds the map), then AMCL or SLAM if chosen."""
        d = self.description
        map_server = (MapServer(rt, grid=d.map_grid or d.world.to_occupancy_grid())
                      if d.has_map_server else None)
        amcl = AmclNode(rt, d.amcl) if d.amcl is not None else None
        slam = SlamNode(rt, d.slam) if d.slam is not None else None
        return map_server, amcl, slam

    def _start_filter_servers(self, rt: Runtime) -> FilterServers:
        """Costmap filter info + mask servers (keepout / speed zones) the Nav2 file declares."""
        d = self.description
        return create_filter_servers(rt, d.nav2_params, d.nav2_file)

    def _start_costmaps(self, rt: Runtime) -> tuple[CostmapNode, CostmapNode]:
        d = self.description
        return (CostmapNode(rt, "global_costmap", d.global_costmap, d.footprint, d.nav2_file),
                CostmapNode(rt, "local_costmap", d.local_costmap, d.footprint, d.nav2_file))

    def _start_servers(self, rt: Runtime, global_costmap: CostmapNode,
                       local_costmap: CostmapNode
                       ) -> tuple[PlannerServer, ControllerServer, BehaviorServer]:
        """Planner, controller and behavior servers."""
        d = self.description
        planner = PlannerServer(rt, d.planner_server, global_costmap, d.nav2_file,
                                footprint=d.footprint)
        controller = ControllerServer(rt, d.controller_server, local_costmap, d.footprint,
                                      d.nav2_file)
        behaviors = BehaviorServer(rt, d.behavior_server, collision_checker=self.local_collision,
                                   penetration=self.local_penetration)
        return planner, controller, behaviors

    def _start_command_chain(self, rt: Runtime
                             ) -> tuple[VelocitySmootherNode, CollisionMonitorNode, TwistMuxNode]:
        """Velocity smoother -> collision monitor -> twist_mux (docs/command_path.md)."""
        d = self.description
        return (VelocitySmootherNode(rt, d.velocity_smoother),
                CollisionMonitorNode(rt, d.body_footprint, d.collision_monitor),
                TwistMuxNode(rt, d.twist_mux))

    def _start_navigators(self, rt: Runtime) -> tuple[BtNavigator, WaypointFollower]:
        d = self.description
        return (BtNavigator(rt, d.bt_navigator, tree_params=d.navigate_tree),
                WaypointFollower(rt, d.waypoint_follower))

    def _up(self) -> _Running:
        if self._running is None:
            raise StackNotStarted(
                "the stack is described but not started: call stack.start() (Navigator(stack), "
                "stack.run_for() and the live runner start it for you)")
        return self._running

    # --- the running parts (after start()) ---------------------------------------------------
    @property
    def runtime(self) -> Runtime:
        return self._up().runtime

    @property
    def sim(self) -> SimulatorNode:
        return self._up().sim

    @property
    def map_server(self) -> MapServer | None:
        return self._up().map_server

    @property
    def amcl(self) -> AmclNode | None:
        return self._up().amcl

    @property
    def slam(self) -> SlamNode | None:
        return self._up().slam

    @property
    def global_costmap(self) -> CostmapNode:
        return self._up().global_costmap

    @property
    def local_costmap(self) -> CostmapNode:
        return self._up().local_costmap

    @property
    def filter_servers(self) -> FilterServers:
        return self._up().filter_servers

    @property
    def planner(self) -> PlannerServer:
        return self._up().planner

    @property
    def controller(self) -> ControllerServer:
        return self._up().controller

    @property
    def behaviors(self) -> BehaviorServer:
        return self._up().behaviors

    @property
    def velocity_smoother(self) -> VelocitySmootherNode:
        return self._up().velocity_smoother

    @property
    def collision_monitor(self) -> CollisionMonitorNode:
        return self._up().collision_monitor

    @property
    def twist_mux(self) -> TwistMuxNode:
        return self._up().twist_mux

    @property
    def navigator(self) -> BtNavigator:
        return self._up().navigator

    @property
    def waypoint_follower(self) -> WaypointFollower:
        return self._up().waypoint_follower

    @classmethod
    def from_stack_file(cls, path: str | Path) -> NavStack:
        """The stack a stack YAML describes (robot, world, seed, Nav2 params), not started.

        ``robot`` may name a profile or be an inline profile mapping; ``navigation`` is a
        Nav2 parameter file (relative to the stack file) or inline Nav2 layout, and the
        packaged defaults are used when it is empty.  Errors name the file and key path.
        """
        cfg = load_stack(path)
        robot = (load_robot(cfg.robot) if isinstance(cfg.robot, str)
                 else robot_from_mapping(cfg.robot, file=str(path)))
        nav = stack_navigation(cfg)
        spawn = Pose2D(*cfg.world.spawn) if cfg.world.spawn is not None else None
        return cls(cfg.world.name, robot, nav, cfg.seed, spawn,
                   localization="perfect" if cfg.world.perfect_localization else "external",
                   physics_rate_hz=cfg.sim.physics_rate_hz)

    def local_collision(self, pose_odom: Pose2D) -> bool:
        """True if the robot body at ``pose_odom`` touches a lethal cell of the local
        costmap (the behaviors' collision check; the planning padding is not applied)."""
        cost = footprint_cost(self.local_costmap.costmap,
                              (pose_odom.x, pose_odom.y, pose_odom.theta), self.body_footprint)
        return cost == LETHAL_OBSTACLE

    def local_penetration(self, pose_odom: Pose2D) -> float:
        """How deep [m] lethal cells of the local costmap reach into the robot body at
        ``pose_odom`` (the behaviors' escape rule, costmap/footprint_penetration.py)."""
        return penetration_depth(self.local_costmap.costmap, pose_odom,
                                 np.asarray(self.body_footprint.polygon, dtype=np.float64))

    @property
    def now(self) -> float:
        """Simulated time (after :meth:`start`)."""
        return self.runtime.now

    def run_for(self, seconds: float) -> None:
        """Advance simulated time (starting the stack first if needed)."""
        self.start()
        self.runtime.scheduler.run_for(seconds)
        self.sim.advance()
