"""Which missions ``navstack mission NAME`` runs, and how each is set up on a stack.

A :class:`MissionSpec` names the localization a mission needs (exploration and
map-by-poses build the map with SLAM; the coverage search uses the known map), its
default world, and a builder that makes the :class:`~navstack.missions.mission.Mission`
from a :class:`MissionSetup` (the started stack, the mission context, the options).

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

from navstack.core.config_files import ros_parameters
from navstack.core.errors import ConfigError, UnknownNameError
from navstack.exploration import ExploreParams
from navstack.interfaces.stack import NavStack
from navstack.missions.conditions import CameraGeometry, TargetInView
from navstack.missions.context import MissionContext
from navstack.missions.coverage import CoverageParams, coverage_mission
from navstack.missions.explore import explore_mission
from navstack.missions.map_poses import map_poses_mission
from navstack.missions.mission import Mission
from navstack.navigation.waypoint_follower import load_waypoints

MissionLocalization = Literal["slam", "amcl", "perfect"]

__all__ = ["MISSIONS", "MissionOptions", "MissionSetup", "MissionSpec", "config_path",
           "default_nav2_params", "mission_spec"]


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


MISSIONS: dict[str, MissionSpec] = {spec.name: spec for spec in (
    MissionSpec("explore", "frontier exploration with SLAM, then return home", "slam", "arena",
                _explore, 3600.0),
    MissionSpec("coverage", "coverage search of the known map (0.8 m cells), then return "
                "home", "amcl", "arena", _coverage, 3600.0),
    MissionSpec("map-poses", "map the world by visiting chosen poses (SLAM), save and "
                "reload the map", "slam", "office", _map_poses, 3600.0),
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

