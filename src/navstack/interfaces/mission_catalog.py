"""Which missions ``navstack mission NAME`` runs, and how each is set up on a stack.

A :class:`MissionSpec` names the localization a mission needs (exploration and
map-by-poses build the map with SLAM; the coverage search uses the known map), its
default world, and a builder that makes the :class:`~navstack.missions.mission.Mission`
from a :class:`MissionSetup` (the started stack, the mission context, the options).

The perception missions (issue 17): ``marker-frame`` (the Nav2 lab: AMCL on the known
map, the world's first marker -- the office's tagged cabinet -- seen from its
``Marker_View`` waypoint) and ``package-retrieval`` (the TurtleBot course: the known map,
the course's two packages placed at random free spots by the seed unless the world has
packages, the costmaps fed the package cloud).  Their specs ``prepare`` the world and the
Nav2 parameters before the stack is built, then attach the camera, the ArUco detector,
the marker map and the simulated gripper.

A user mission is one Python file (docs/missions.md): it defines
``build(ctx: MissionContext) -> Mission`` (or ``build(setup: MissionSetup)`` when it
wants the options), and may set ``LOCALIZATION = "slam" | "amcl" | "perfect"``
and ``WORLD``.  ``navstack mission path/to/file.py`` runs it.
"""

from __future__ import annotations

import importlib.util
import inspect
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np

from navstack.core.config_files import ros_parameters
from navstack.core.errors import ConfigError, UnknownNameError
from navstack.exploration import ExploreParams
from navstack.interfaces.perception import (
    Perception,
    PerceptionOptions,
    attach_perception,
    with_package_cloud,
)
from navstack.interfaces.stack import NavStack
from navstack.missions.conditions import CameraGeometry, TargetInView
from navstack.missions.context import MissionContext
from navstack.missions.coverage import CoverageParams, coverage_mission
from navstack.missions.explore import explore_mission
from navstack.missions.map_poses import map_poses_mission
from navstack.missions.marker_behaviours import MarkerContext
from navstack.missions.marker_missions import marker_frame_mission, package_retrieval_mission
from navstack.missions.mission import Mission
from navstack.missions.search_viewpoints import search_viewpoints
from navstack.navigation.waypoint_follower import load_waypoints
from navstack.sim.packages import place_packages
from navstack.sim.world import World

MissionLocalization = Literal["slam", "amcl", "perfect"]

__all__ = ["GRIP_DISTANCE", "MISSIONS", "MissionOptions", "MissionSetup", "MissionSpec",
           "build_package_retrieval", "config_path", "default_nav2_params", "mission_spec",
           "prepare_retrieval"]


def config_path(name: str) -> Path:
    return Path(str(resources.files("navstack") / "config" / name))


def default_nav2_params(robot: str) -> Path | None:
    """``config/<robot>_nav2_params.yaml`` when the robot has its own, else None (the
    packaged default)."""
    path = config_path(f"{robot}_nav2_params.yaml")
    return path if path.is_file() else None


@dataclass(frozen=True)
class MissionOptions:
    """What the command line can set (``None``: the mission's default)."""

    strategy: str | None = None
    poses: Path | None = None
    localization: MissionLocalization | None = None
    max_duration: float | None = None
    explore: Mapping[str, Any] = field(default_factory=dict)
    coverage: Mapping[str, Any] = field(default_factory=dict)
    targets: tuple[tuple[float, float], ...] = ()
    nav2_params: Path | None = None


@dataclass
class MissionSetup:
    """Everything a builder gets."""

    stack: NavStack
    ctx: MissionContext
    out: Path
    options: MissionOptions
    nav2: Mapping[str, Any]
    nav2_file: str

    @property
    def circumscribed_radius(self) -> float:
        """The padded planning footprint's turning radius [m]."""
        return float(self.stack.footprint.circumscribed_radius)

    def section(self, name: str) -> dict[str, Any]:
        """A ``name: ros__parameters:`` section of the Nav2 file ({} when absent)."""
        if name not in self.nav2:
            return {}
        return dict(ros_parameters(self.nav2, name, file=self.nav2_file))

    def camera(self) -> CameraGeometry:
        cam = self.stack.robot.sensors.camera
        return CameraGeometry(cam.horizontal_fov, cam.max_range, cam.mount.x, cam.mount.y,
                              cam.mount.yaw)


@dataclass(frozen=True)
class MissionSpec:
    name: str
    description: str
    localization: MissionLocalization
    world: str
    build: Callable[[MissionSetup], Mission]
    max_duration: float = 3600.0
    prepare: Callable[[World, dict[str, Any], int], tuple[World, dict[str, Any]]] | None = None
    """Change the world and the Nav2 parameters (given the seed) before the stack is
    built (``None``: the world by name and the Nav2 file as they are)."""


def _explore(setup: MissionSetup) -> Mission:
    o = setup.options
    values = {**setup.section("explore_node"), **o.explore}
    if o.strategy is not None:
        values["strategy"] = o.strategy
    lidar = setup.stack.robot.sensors.lidar
    if math.isfinite(lidar.range_max):
        values.setdefault("sensor_range", lidar.range_max)
    params = ExploreParams.from_mapping(values, file=setup.nav2_file,
                                       key_path="explore_node")
    return explore_mission(setup.ctx, params, setup.circumscribed_radius)


def _coverage(setup: MissionSetup) -> Mission:
    o = setup.options
    # 0.1 m beyond the padded footprint: lidar noise puts obstacle cells a few cm nearer
    values = {"turning_radius": setup.circumscribed_radius + 0.1, **setup.section("coverage"),
              **o.coverage}
    params = CoverageParams.from_mapping(values, file=setup.nav2_file, key_path="coverage")
    stop = (TargetInView(setup.ctx, o.targets, setup.camera()) if o.targets else None)
    return coverage_mission(setup.ctx, params, stop)


def _map_poses(setup: MissionSetup) -> Mission:
    path = setup.options.poses or config_path("office_map_poses.yaml")
    poses = [(name, ps.to_pose2d()) for name, ps in load_waypoints(path)]
    setup.ctx.results["poses_file"] = str(path)
    return map_poses_mission(setup.ctx, poses, str(setup.out / "map"))


def _marker_frame(setup: MissionSetup) -> Mission:
    world = setup.stack.world
    if not world.markers or "Marker_View" not in world.waypoints:
        raise ConfigError(f"world '{world.name}' needs a marker (markers:) and a "
                          "'Marker_View' waypoint to look at it from", key_path="markers",
                          suggestion="use --world office (its tagged cabinet, marker 12)")
    marker = world.markers[0]
    attach_perception(setup.stack, PerceptionOptions(camera_rate_hz=10.0, detector={
        "marker_size": marker.size, "dictionary": marker.dictionary}))
    ctx = MarkerContext(setup.stack.runtime)
    return marker_frame_mission(ctx, marker.id, world.waypoints["Marker_View"])


RETRIEVAL_TARGET, RETRIEVAL_OTHER = 3, 4
"""The course's package ids: the one to bring home and the one to avoid."""
GRIP_DISTANCE = 0.166
"""Package centre ahead of base_link when gripping (TurtleBot3 Waffle Pi): front edge
0.076 m + 9 cm (the reach zone is 0 .. 12 cm; a 5 cm end face then leaves 4 cm for the
stop and the estimate)."""


def prepare_retrieval(world: World, nav2: dict[str, Any], seed: int
                      ) -> tuple[World, dict[str, Any]]:
    """The course's two packages at random free spots (by ``seed``) unless ``world`` has
    packages; the costmaps fed the package cloud."""
    if not world.packages:
        world.packages = place_packages(world, np.random.default_rng(1000 + seed),
                                        (RETRIEVAL_TARGET, RETRIEVAL_OTHER))
    return world, with_package_cloud(nav2)


def build_package_retrieval(stack: NavStack) -> tuple[Mission, Perception]:
    """Attach perception (camera at 10 Hz, the packages' marker size, the world's package
    ids) to a started stack and build the retrieval of package ``RETRIEVAL_TARGET``."""
    ids = sorted({p.marker_id for p in stack.world.packages})
    if RETRIEVAL_TARGET not in ids:
        raise ConfigError(f"world '{stack.world.name}' has no package with marker "
                          f"{RETRIEVAL_TARGET} (the target)", key_path="packages")
    if not stack.robot.gripper.enabled:
        raise ConfigError(f"robot '{stack.robot.name}' has no gripper",
                          key_path="robot.gripper.enabled",
                          suggestion="use --robot turtlebot3_waffle_pi")
    per = attach_perception(stack, PerceptionOptions(
        camera_rate_hz=10.0, detector={"marker_size": stack.world.packages[0].marker_size},
        marker_map={"package_ids": ids}))
    ctx = MarkerContext(stack.runtime)
    grid = stack.world.to_occupancy_grid()
    viewpoints = search_viewpoints(grid, stack.world.spawn, clearance=0.3)
    mission = package_retrieval_mission(ctx, RETRIEVAL_TARGET, viewpoints, grid,
                                        GRIP_DISTANCE, standoff=0.7)
    return mission, per


def _package_retrieval(setup: MissionSetup) -> Mission:
    return build_package_retrieval(setup.stack)[0]


MISSIONS: dict[str, MissionSpec] = {spec.name: spec for spec in (
    MissionSpec("explore", "frontier exploration with SLAM, then return home", "slam", "arena",
                _explore, 3600.0),
    MissionSpec("coverage", "coverage search of the known map (0.8 m cells), then return "
                "home", "amcl", "arena", _coverage, 3600.0),
    MissionSpec("map-poses", "map the world by visiting chosen poses (SLAM), save and "
                "reload the map", "slam", "office", _map_poses, 3600.0),
    MissionSpec("marker-frame", "go near the tagged obstacle, publish its ArUco marker's "
                "static frame, return to the start", "amcl", "office", _marker_frame, 600.0),
    MissionSpec("package-retrieval", "find the target package by its marker, avoid the "
                "others, grip it and bring it home", "perfect", "arena", _package_retrieval,
                600.0, prepare_retrieval),
)}


def _load_user(path: Path) -> MissionSpec:
    if not path.is_file():
        raise ConfigError("mission file not found; give a built-in mission name "
                          f"({', '.join(MISSIONS)}) or an existing .py file", file=str(path))
    module_spec = importlib.util.spec_from_file_location(f"navstack_user_mission_{path.stem}",
                                                         path)
    if module_spec is None or module_spec.loader is None:
        raise ConfigError("cannot import the mission file", file=str(path))
    module = importlib.util.module_from_spec(module_spec)
    try:
        module_spec.loader.exec_module(module)
    except Exception as exc:
        raise ConfigError(f"the mission file raised {type(exc).__name__}: {exc}",
                          file=str(path)) from None
    build = getattr(module, "build", None)
    if not callable(build):
        raise ConfigError("a mission file must define build(ctx) -> Mission", file=str(path),
                          key_path="build")
    takes_setup = next(iter(inspect.signature(build).parameters), "") == "setup"

    def builder(setup: MissionSetup) -> Mission:
        made = build(setup) if takes_setup else build(setup.ctx)
        if not isinstance(made, Mission):
            raise ConfigError(f"build() returned {type(made).__name__}, not a Mission",
                              file=str(path), key_path="build")
        return made

    loc_name = getattr(module, "LOCALIZATION", "perfect")
    locs: dict[str, MissionLocalization] = {"slam": "slam", "amcl": "amcl",
                                            "perfect": "perfect"}
    if loc_name not in locs:
        raise ConfigError(f"LOCALIZATION must be 'slam', 'amcl' or 'perfect', got "
                          f"{loc_name!r}", file=str(path), key_path="LOCALIZATION")
    loc = locs[loc_name]
    doc = (module.__doc__ or "").strip().splitlines()
    return MissionSpec(path.stem, doc[0] if doc else "user mission", loc,
                       str(getattr(module, "WORLD", "office")), builder,
                       float(getattr(module, "MAX_DURATION", 3600.0)))


def mission_spec(name: str) -> MissionSpec:
    """A built-in mission by name, or a user mission file (``*.py``)."""
    if name.endswith(".py") or "/" in name:
        return _load_user(Path(name))
    if name not in MISSIONS:
        raise UnknownNameError("mission", name, list(MISSIONS))
    return MISSIONS[name]

