"""``NavStack``: the default navigation stack in one process, on the built-in simulator.

Wires the data flow of ARCHITECTURE.md §2: simulator (``/scan``, ``/odom``, ``/tf``) ->
map server (``/map``) -> global costmap (map) + planner server -> local costmap (odom) +
controller server and behavior server (``/cmd_vel_nav``) -> collision monitor
(``/cmd_vel``) -> base; BT navigator and waypoint follower orchestrate.
Navigation parameters are a Nav2 parameter file (the packaged default is
``navstack/config/nav2_params.yaml``).  The robot's footprint comes from its profile and
overrides ``robot_radius``/``footprint`` in the costmap sections.
"""

from __future__ import annotations

from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from navstack.core.msgs import OccupancyGrid, Pose2D
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE
from navstack.costmap.footprint import footprint_cost
from navstack.mapping.slam_node import SlamNode
from navstack.mapping.slam_params import SlamParams
from navstack.navigation.behavior_server import BehaviorServer, BehaviorServerParams
from navstack.navigation.bt_navigator import BtNavigator, BtNavigatorParams
from navstack.navigation.collision_monitor_node import CollisionMonitorNode
from navstack.navigation.controller_server import ControllerServer
from navstack.navigation.costmap_node import CostmapNode
from navstack.navigation.map_server import MapServer
from navstack.navigation.planner_server import PlannerServer
from navstack.navigation.trees import NavigateTreeParams
from navstack.navigation.waypoint_follower import WaypointFollower, WaypointFollowerParams
from navstack.runtime.config import load_stack, load_yaml, ros_parameters
from navstack.runtime.node import Runtime
from navstack.sim.node import SimulatorNode
from navstack.sim.robot import RobotParams, load_robot, robot_from_mapping
from navstack.sim.simulator import Simulator
from navstack.sim.world import World
from navstack.sim.worlds import load_world

if TYPE_CHECKING:
    from navstack.localization.amcl.node import AmclNode


def default_nav2_params_path() -> Path:
    return Path(str(resources.files("navstack") / "config" / "nav2_params.yaml"))


class NavStack:
    """Simulator + Nav2-equivalent servers, configured and active, in one ``Runtime``."""

    def __init__(self, world: str | World = "office", robot: str | RobotParams = "diff_drive",
                 nav2_params: str | Path | Mapping[str, Any] | None = None, seed: int = 0,
                 spawn: Pose2D | None = None, perfect_localization: bool = True,
                 physics_rate_hz: float = 50.0, map_grid: OccupancyGrid | None = None,
                 slam: bool | SlamParams | Mapping[str, Any] = False,
                 amcl: bool | Mapping[str, Any] = False) -> None:
        """``world``: a built-in name, a world/map file, or a :class:`World`; ``map_grid``:
        the map given to navigation (default: the world's true static map).

        ``slam``: map while navigating instead -- a :class:`SlamNode` (slam_toolbox
        parameters, ``True`` for the defaults) builds ``/map`` and publishes
        ``map -> odom``; there is no map server and no perfect localization.  The SLAM map
        frame starts at the spawn pose (slam_toolbox ``map_start_pose``), so goals keep
        the world's coordinates.

        ``amcl``: localize with AMCL on the known map instead of the simulator's perfect
        ``map -> odom`` (Nav2 ``amcl`` parameters, ``True`` for the defaults); the
        initial pose is the spawn pose (``set_initial_pose``) unless given."""
        if nav2_params is None or isinstance(nav2_params, str | Path):
            path = Path(nav2_params) if nav2_params is not None else default_nav2_params_path()
            nav, file = load_yaml(path), str(path)
        else:
            nav, file = dict(nav2_params), "<nav2 params>"
        self.nav2_params = nav
        self.runtime = rt = Runtime()
        self.world = load_world(world) if isinstance(world, str) else world
        self.robot = load_robot(robot) if isinstance(robot, str) else robot
        # navigation plans with the body padded by the costmaps' footprint_padding (Nav2)
        padding = ros_parameters(nav, "global_costmap", file=file).get("footprint_padding", 0.01)
        self.footprint = self.robot.updated(footprint_padding=float(padding)).footprint_model()
        # recoveries check the body itself: they exist to get out of tight spots
        self.body_footprint = self.robot.footprint_model()
        simulator = Simulator(self.world, self.robot, seed, spawn)
        self.slam: SlamNode | None = None
        self.map_server: MapServer | None = None
        self.amcl: AmclNode | None = None
        if slam is False and amcl is not False:
            from navstack.localization.amcl.node import AmclNode
            from navstack.localization.amcl.params import AmclParams

            self.sim = SimulatorNode(rt, simulator, physics_rate_hz, False)
            self.map_server = MapServer(rt, grid=map_grid or self.world.to_occupancy_grid())
            start = simulator.pose
            given = {} if amcl is True else dict(amcl)
            section = ros_parameters(nav, "amcl", file=file)  # the Nav2 file's amcl:
            amcl_params = AmclParams.from_mapping(
                {"set_initial_pose": True, "base_frame_id": "base_link",
                 "initial_pose": {"x": start.x, "y": start.y, "yaw": start.theta},
                 **section, **given}, file=file, key_path="amcl")
            self.amcl = AmclNode(rt, amcl_params)
        elif slam is False:
            self.sim = SimulatorNode(rt, simulator, physics_rate_hz, perfect_localization)
            self.map_server = MapServer(rt, grid=map_grid or self.world.to_occupancy_grid())
        else:
            self.sim = SimulatorNode(rt, simulator, physics_rate_hz, False)
            start = simulator.pose
            xmin, ymin, xmax, ymax = self.world.bounds
            overrides = {"map_start_pose": [start.x, start.y, start.theta],
                         "map_minimum_extent": [xmin, ymin, xmax, ymax]}
            # navigation plans on /map: a map every second (slam_toolbox's 5 s default
            # leaves the planner routing through what the robot already saw blocked)
            live = {"map_update_interval": 1.0}
            if isinstance(slam, SlamParams):
                slam_params = slam.updated(**overrides, **{
                    k: v for k, v in live.items() if k not in slam.model_fields_set})
            else:
                given = {} if slam is True else dict(slam)
                slam_params = SlamParams.from_mapping({**live, **overrides, **given},
                                                      key_path="slam_toolbox")
            self.slam = SlamNode(rt, slam_params)
        self.global_costmap = CostmapNode(rt, "global_costmap",
                                          ros_parameters(nav, "global_costmap", file=file),
                                          self.footprint, file)
        self.local_costmap = CostmapNode(rt, "local_costmap",
                                         ros_parameters(nav, "local_costmap", file=file),
                                         self.footprint, file)
        self.planner = PlannerServer(rt, ros_parameters(nav, "planner_server", file=file),
                                     self.global_costmap, file, footprint=self.footprint)
        self.controller = ControllerServer(
            rt, ros_parameters(nav, "controller_server", file=file), self.local_costmap,
            self.footprint, file)
        self.behaviors = BehaviorServer(
            rt, BehaviorServerParams.from_mapping(
                ros_parameters(nav, "behavior_server", file=file), file=file,
                key_path="behavior_server"),
            collision_checker=self.local_collision)
        self.collision_monitor = CollisionMonitorNode(rt, self.body_footprint)
        bt = ros_parameters(nav, "bt_navigator", file=file)
        tree = bt.pop("tree", None) or {}
        self.navigator = BtNavigator(
            rt, BtNavigatorParams.from_mapping(bt, file=file, key_path="bt_navigator"),
            tree_params=NavigateTreeParams.from_mapping(tree, file=file,
                                                        key_path="bt_navigator.tree"))
        self.waypoint_follower = WaypointFollower(rt, WaypointFollowerParams.from_mapping(
            ros_parameters(nav, "waypoint_follower", file=file), file=file,
            key_path="waypoint_follower"))
        rt.bring_up()
        # a first costmap cycle so planners never see an empty map at t=0
        rt.scheduler.run_until(0.0)
        if self.amcl is not None:
            # AMCL publishes map -> odom after its first scan: wait for it (as a Nav2
            # launch waits for localization before sending goals), at most 2 s
            rt.scheduler.run_until(2.0, until=lambda: rt.tf.can_transform("map", "odom"))
            self.sim.advance()
        self.global_costmap.update()
        self.local_costmap.update()

    @classmethod
    def from_stack_file(cls, path: str | Path) -> NavStack:
        """Build the running graph a stack YAML describes (robot, world, seed, Nav2 params).

        ``robot`` may name a profile or be an inline profile mapping; ``navigation`` is a
        Nav2 parameter file (relative to the stack file) or inline Nav2 layout, and the
        packaged defaults are used when it is empty.  Errors name the file and key path.
        """
        cfg = load_stack(path)
        robot = (load_robot(cfg.robot) if isinstance(cfg.robot, str)
                 else robot_from_mapping(cfg.robot, file=str(path)))
        nav = cfg.navigation_params() or None
        spawn = Pose2D(*cfg.world.spawn) if cfg.world.spawn is not None else None
        return cls(cfg.world.name, robot, nav, cfg.seed, spawn,
                   cfg.world.perfect_localization, cfg.sim.physics_rate_hz)

    def local_collision(self, pose_odom: Pose2D) -> bool:
        """True if the robot body at ``pose_odom`` touches a lethal cell of the local
        costmap (the behaviors' collision check; the planning padding is not applied)."""
        cost = footprint_cost(self.local_costmap.costmap,
                              (pose_odom.x, pose_odom.y, pose_odom.theta), self.body_footprint)
        return cost == LETHAL_OBSTACLE

    @property
    def now(self) -> float:
        return self.runtime.now

    def run_for(self, seconds: float) -> None:
        """Advance simulated time."""
        self.runtime.scheduler.run_for(seconds)
        self.sim.advance()
