"""Build :class:`~navstack.sim.world.World` objects from files.

Two formats are read:

* a **primitives YAML** (``name``, ``resolution``, ``size``, ``origin``, ``boundary``,
  ``walls``, ``boxes``, ``circles``, ``polygons``, ``moving_obstacles``, ``spawn``,
  ``waypoints``; for cameras ``wall_height``, ``marker_dictionary``, ``markers``,
  ``packages``) validated by :class:`WorldSpec` and rasterised with numpy;
* a **ROS map_server YAML** (it has an ``image`` key) read by
  :func:`navstack.core.map_files.load_map`; cells of value 100 are obstacles, unknown
  counts as free.  Optional extra keys ``name``, ``spawn`` and ``waypoints`` (ignored by
  map_server) give it named places.

Rasterisation marks a cell occupied when its centre lies inside the primitive, so
shapes whose edges sit on cell boundaries are exact (a 0.9 m door at 0.05 m is 18 free
cells).  Walls are rectangles from ``from`` to ``to`` (no end caps) of ``thickness``;
their centre line is also marked so that a wall thinner than a cell never has holes.
A tiny circle always marks its centre cell.
"""

from __future__ import annotations

import math
import typing
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, Field, ValidationError

from navstack.core.errors import (
    ConfigError,
    ConfigErrors,
    MapFileError,
    SimulationError,
    did_you_mean,
)
from navstack.core.map_files import load_map, load_map_yaml
from navstack.core.msgs import Pose2D
from navstack.core.params import Params
from navstack.core.polygon import points_in_polygon
from navstack.sim.markers import PackageSpec, WorldMarker
from navstack.sim.world import BoolArray, FloatArray, MovingObstacle, World

Vec2 = tuple[float, float]
Size2 = tuple[float, float]
MAX_CELLS = 25_000_000


class WallSpec(Params):
    """A straight wall: rectangle ``thickness`` wide centred on the segment from-to."""

    from_: Vec2 = Field(alias="from")
    to: Vec2
    thickness: float = Field(default=0.1, gt=0.0)


class BoxSpec(Params):
    """A rectangle of ``size`` (along x, along y before rotation) turned by ``yaw``."""

    center: Vec2
    size: Size2
    yaw: float = 0.0


class CircleSpec(Params):
    center: Vec2
    radius: float = Field(gt=0.0)


class PolygonSpec(Params):
    """A simple polygon (either winding), at least three ``[x, y]`` points."""

    points: list[Vec2] = Field(min_length=3)


class MovingObstacleSpec(Params):
    """A moving obstacle; see :class:`navstack.sim.world.MovingObstacle`."""

    name: str = ""
    shape: Literal["circle", "box"] = "circle"
    radius: float = Field(default=0.3, gt=0.0)
    size: Size2 = (0.6, 0.6)
    path: list[Vec2] = Field(min_length=1)
    speed: float = Field(default=0.5, ge=0.0)
    mode: Literal["pingpong", "loop"] = "pingpong"
    yaw: float | None = None
    phase: float = Field(default=0.0, ge=0.0)


class MarkerSpec(Params):
    """An ArUco marker on a wall or obstacle face (:class:`navstack.sim.markers.WorldMarker`):
    ``position`` of its centre [m] on the face, ``height`` of the centre above the floor,
    ``yaw`` the direction it faces (out of the surface), ``size`` the black square's side,
    ``margin`` the white quiet zone around it (default one marker cell)."""

    id: int = Field(ge=0)
    size: float
    position: Vec2
    height: float = Field(default=0.5, gt=0.0)
    yaw: float = 0.0
    dictionary: str | None = None
    margin: float | None = Field(default=None, ge=0.0)


class PackageSpecModel(Params):
    """A marked package on the floor (:class:`navstack.sim.markers.PackageSpec`); the
    TurtleBot course's packages are 10 x 5 x 5 cm with 5 cm markers."""

    id: int = Field(ge=0)
    name: str = ""
    position: Vec2
    yaw: float = 0.0
    size: tuple[float, float, float] = (0.10, 0.05, 0.05)
    marker_size: float = 0.05
    dictionary: str | None = None


class SpawnSpec(Params):
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


class WorldSpec(Params):
    """The primitives world file (all lengths in metres, angles in radians)."""

    name: str = "world"
    description: str = ""
    resolution: float = Field(default=0.05, gt=0.0)
    size: Size2
    origin: Vec2 = (0.0, 0.0)
    boundary: bool = True
    boundary_thickness: float = Field(default=0.1, gt=0.0)
    walls: list[WallSpec] = Field(default_factory=list)
    boxes: list[BoxSpec] = Field(default_factory=list)
    circles: list[CircleSpec] = Field(default_factory=list)
    polygons: list[PolygonSpec] = Field(default_factory=list)
    moving_obstacles: list[MovingObstacleSpec] = Field(default_factory=list)
    spawn: SpawnSpec = Field(default_factory=SpawnSpec)
    waypoints: dict[str, tuple[float, float, float] | tuple[float, float]] = Field(
        default_factory=dict)
    wall_height: float = Field(default=2.0, gt=0.0)
    marker_dictionary: str = "DICT_4X4_50"
    markers: list[MarkerSpec] = Field(default_factory=list)
    packages: list[PackageSpecModel] = Field(default_factory=list)


class MapWorldExtras(Params):
    """navstack's optional keys in a map_server YAML (map_server ignores them)."""

    name: str | None = None
    spawn: SpawnSpec | None = None
    waypoints: dict[str, tuple[float, float, float] | tuple[float, float]] = Field(
        default_factory=dict)


# --- validation errors with did-you-mean inside lists ------------------------------------
def _model_in(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _model_in(arg)
        if found is not None:
            return found
    return None


def _keys_at(model: type[BaseModel], loc: tuple[int | str, ...]) -> list[str]:
    """Spelled keys (aliases) of the model owning ``loc[-1]``, descending lists/dicts."""
    current: type[BaseModel] | None = model
    for item in loc[:-1]:
        if current is None:
            return []
        fields = {(f.alias or n): f for n, f in current.model_fields.items()}
        if isinstance(item, str) and item in fields:
            current = _model_in(fields[item].annotation)
    if current is None:
        return []
    return [f.alias or n for n, f in current.model_fields.items()]


def _config_error(exc: ValidationError, model: type[BaseModel], file: str) -> ConfigError:
    errors: list[ConfigError] = []
    for err in exc.errors():
        loc = tuple(err["loc"])
        path = ".".join(f"[{p}]" if isinstance(p, int) else str(p) for p in loc)
        path = path.replace(".[", "[")
        if err["type"] == "extra_forbidden":
            hint = did_you_mean(str(loc[-1]), _keys_at(model, loc)).strip(" ()")
            errors.append(ConfigError("unknown key", file=file, key_path=path, suggestion=hint))
        elif err["type"] == "missing":
            errors.append(ConfigError("required key is missing", file=file, key_path=path))
        else:
            errors.append(ConfigError(f"{err['msg']} (got {err.get('input')!r})", file=file,
                                      key_path=path))
    return errors[0] if len(errors) == 1 else ConfigErrors(errors)


# --- rasterisation --------------------------------------------------------------------
class _Raster:
    """A boolean grid being painted with primitives (vectorised over the cells of each
    primitive's bounding window)."""

    def __init__(self, width: int, height: int, resolution: float, ox: float, oy: float):
        self.occ: BoolArray = np.zeros((height, width), dtype=np.bool_)
        self.res, self.ox, self.oy = resolution, ox, oy

    def _window(self, xmin: float, ymin: float, xmax: float, ymax: float
                ) -> tuple[slice, slice, FloatArray, FloatArray] | None:
        h, w = self.occ.shape
        c0 = max(0, math.floor((xmin - self.ox) / self.res) - 1)
        c1 = min(w, math.ceil((xmax - self.ox) / self.res) + 1)
        r0 = max(0, math.floor((ymin - self.oy) / self.res) - 1)
        r1 = min(h, math.ceil((ymax - self.oy) / self.res) + 1)
        if c0 >= c1 or r0 >= r1:
            return None
        xs = self.ox + (np.arange(c0, c1) + 0.5) * self.res
        ys = self.oy + (np.arange(r0, r1) + 0.5) * self.res
        return slice(r0, r1), slice(c0, c1), xs, ys

    def polygon(self, poly: FloatArray) -> None:
        win = self._window(*poly.min(axis=0), *poly.max(axis=0))
        if win is None:
            return
        rs, cs, xs, ys = win
        X, Y = np.meshgrid(xs, ys)
        inside = points_in_polygon(np.column_stack((X.ravel(), Y.ravel())), poly)
        self.occ[rs, cs] |= inside.reshape(X.shape)

    def circle(self, cx: float, cy: float, r: float) -> None:
        win = self._window(cx - r, cy - r, cx + r, cy + r)
        if win is not None:
            rs, cs, xs, ys = win
            self.occ[rs, cs] |= (xs[None, :] - cx) ** 2 + (ys[:, None] - cy) ** 2 <= r * r
        self.points(np.array([[cx, cy]]))

    def points(self, pts: FloatArray) -> None:
        h, w = self.occ.shape
        c = np.floor((pts[:, 0] - self.ox) / self.res).astype(np.int64)
        r = np.floor((pts[:, 1] - self.oy) / self.res).astype(np.int64)
        ok = (c >= 0) & (c < w) & (r >= 0) & (r < h)
        self.occ[r[ok], c[ok]] = True

    def wall(self, a: FloatArray, b: FloatArray, thickness: float) -> None:
        d = b - a
        length = float(np.hypot(*d))
        if length > 0.0:
            n = np.array([-d[1], d[0]]) * (0.5 * thickness / length)
            self.polygon(np.array([a + n, b + n, b - n, a - n]))
        # Centre line, pulled in by a quarter cell at each end so that an end lying on a
        # cell boundary does not mark the cell beyond it.
        inset = min(0.25 * self.res / length, 0.5) if length > 0.0 else 0.0
        steps = max(2, math.ceil(length / (0.5 * self.res)) + 1)
        self.points(a + np.linspace(inset, 1.0 - inset, steps)[:, None] * d)

    def boundary(self, thickness: float) -> None:
        k = max(1, round(thickness / self.res))
        self.occ[:k, :] = self.occ[-k:, :] = True
        self.occ[:, :k] = self.occ[:, -k:] = True


def box_polygon(center: Vec2, size: Size2, yaw: float) -> FloatArray:
    """Corners ``(4, 2)`` of a rectangle of ``size`` at ``center`` turned by ``yaw``."""
    hx, hy = 0.5 * size[0], 0.5 * size[1]
    local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack((center[0] + c * local[:, 0] - s * local[:, 1],
                            center[1] + s * local[:, 0] + c * local[:, 1]))


def rasterize(spec: WorldSpec) -> BoolArray:
    """The static occupancy grid ``bool[H, W]`` of a :class:`WorldSpec`."""
    width = round(spec.size[0] / spec.resolution)
    height = round(spec.size[1] / spec.resolution)
    ras = _Raster(width, height, spec.resolution, *spec.origin)
    if spec.boundary:
        ras.boundary(spec.boundary_thickness)
    for w in spec.walls:
        ras.wall(np.asarray(w.from_), np.asarray(w.to), w.thickness)
    for b in spec.boxes:
        ras.polygon(box_polygon(b.center, b.size, b.yaw))
    for c in spec.circles:
        ras.circle(c.center[0], c.center[1], c.radius)
    for p in spec.polygons:
        ras.polygon(np.asarray(p.points, dtype=np.float64))
    return ras.occ


# --- building worlds ---------------------------------------------------------------------
def _pose(v: tuple[float, ...]) -> Pose2D:
    return Pose2D(float(v[0]), float(v[1]), float(v[2]) if len(v) > 2 else 0.0)


def _check_places(world: World, file: str) -> None:
    """Spawn and waypoints must be inside the grid and in a free cell."""
    places = [("spawn", world.spawn)] + [(f"waypoints.{k}", p) for k, p in world.waypoints.items()]
    for key, p in places:
        if not world.in_bounds(p.x, p.y):
            x0, y0, x1, y1 = world.bounds
            raise ConfigError(f"({p.x}, {p.y}) is outside the world [{x0}, {x1}] x [{y0}, {y1}]",
                              file=file, key_path=key, suggestion="move it inside the world")
        if not world.is_free(p.x, p.y):
            raise ConfigError(f"({p.x}, {p.y}) is inside an obstacle", file=file, key_path=key,
                              suggestion="move it to free space")


def world_from_spec(spec: WorldSpec, file: str = "", source: Path | None = None) -> World:
    """Rasterise a validated :class:`WorldSpec` into a :class:`World`."""
    cells = round(spec.size[0] / spec.resolution) * round(spec.size[1] / spec.resolution)
    if cells > MAX_CELLS or min(spec.size) < spec.resolution:
        raise ConfigError(f"size {list(spec.size)} at resolution {spec.resolution} gives "
                          f"{cells} cells (allowed 1..{MAX_CELLS})", file=file, key_path="size",
                          suggestion="use a coarser resolution or a smaller world")
    if spec.boundary_thickness < spec.resolution * 0.5 and spec.boundary:
        raise ConfigError("boundary_thickness is below half a cell", file=file,
                          key_path="boundary_thickness", suggestion="use at least resolution")
    moving = tuple(
        MovingObstacle(name=m.name or f"obstacle_{i}", shape=m.shape,
                       path=np.asarray(m.path, dtype=np.float64), speed=m.speed, mode=m.mode,
                       radius=m.radius, size=m.size, yaw=m.yaw, phase=m.phase)
        for i, m in enumerate(spec.moving_obstacles))
    world = World(rasterize(spec), spec.resolution, spec.origin[0], spec.origin[1], spec.name,
                  moving, Pose2D(spec.spawn.x, spec.spawn.y, spec.spawn.yaw),
                  {k: _pose(v) for k, v in spec.waypoints.items()}, source,
                  wall_height=spec.wall_height)
    if spec.markers or spec.packages:
        world.markers, world.packages = build_markers(spec, file)
    _check_places(world, file)
    for i, package in enumerate(world.packages):
        if not world.is_free(package.x, package.y):
            raise ConfigError(f"package at ({package.x}, {package.y}) is inside an obstacle",
                              file=file, key_path=f"packages[{i}].position",
                              suggestion="move it to free space")
    return world


def build_markers(spec: WorldSpec, file: str = ""
                  ) -> tuple[tuple[WorldMarker, ...], tuple[PackageSpec, ...]]:
    """The validated markers and packages of ``spec``: known dictionary, id in it, one
    marker per (dictionary, id), positive sizes, markers between floor and wall top."""
    from navstack.core.aruco_dictionaries import (
        check_dictionary_name,
        check_marker_id,
        get_dictionary,
    )

    default = check_dictionary_name(spec.marker_dictionary, "marker_dictionary", file)
    seen: dict[tuple[str, int], str] = {}

    def claim(dictionary: str, marker_id: int, key: str) -> None:
        check_marker_id(dictionary, marker_id, f"{key}.id", file)
        if (dictionary, marker_id) in seen:
            raise ConfigError(f"marker {marker_id} of {dictionary} is already used by "
                              f"{seen[dictionary, marker_id]}", file=file, key_path=key,
                              suggestion="give every marker its own id")
        seen[dictionary, marker_id] = key

    markers = []
    for i, m in enumerate(spec.markers):
        key = f"markers[{i}]"
        name = (check_dictionary_name(m.dictionary, f"{key}.dictionary", file)
                if m.dictionary else default)
        if not m.size > 0.0:
            raise ConfigError(f"marker size must be > 0 m, got {m.size}", file=file,
                              key_path=f"{key}.size", suggestion="the black square's side")
        if m.height - 0.5 * m.size < 0.0 or m.height + 0.5 * m.size > spec.wall_height:
            raise ConfigError(f"a {m.size} m marker centred at height {m.height} m does not "
                              f"fit between the floor and the wall top ({spec.wall_height} m)",
                              file=file, key_path=f"{key}.height")
        claim(name, m.id, key)
        cells = int(get_dictionary(name).markerSize) + 2
        margin = m.size / cells if m.margin is None else m.margin
        markers.append(WorldMarker(m.id, name, m.size, m.position[0], m.position[1], m.height,
                                   m.yaw, margin))
    packages = []
    for i, p in enumerate(spec.packages):
        key = f"packages[{i}]"
        name = (check_dictionary_name(p.dictionary, f"{key}.dictionary", file)
                if p.dictionary else default)
        if min(p.size) <= 0.0 or not p.marker_size > 0.0:
            raise ConfigError(f"package size {list(p.size)} and marker_size {p.marker_size} "
                              "must be > 0 m", file=file, key_path=key)
        if p.marker_size > p.size[2] + 1e-9 or p.marker_size > max(p.size[:2]) + 1e-9:
            raise ConfigError(f"a {p.marker_size} m marker does not fit on any face of a "
                              f"{list(p.size)} m package", file=file,
                              key_path=f"{key}.marker_size")
        claim(name, p.id, key)
        packages.append(PackageSpec(p.name or f"package_{p.id}", p.id, name, p.position[0],
                                    p.position[1], p.yaw, p.size, p.marker_size))
    return tuple(markers), tuple(packages)


def world_from_mapping(data: dict[str, Any], file: str = "",
                       source: Path | None = None) -> World:
    """Validate a primitives mapping (ConfigError naming ``file`` and key path) and build it."""
    try:
        spec = WorldSpec.model_validate(data)
    except ValidationError as exc:
        raise _config_error(exc, WorldSpec, file) from None
    return world_from_spec(spec, file, source)


def world_from_map_file(yaml_path: str | Path) -> World:
    """A world from a ROS map_server YAML + image (see module docstring)."""
    path = Path(yaml_path)
    meta = load_map_yaml(path)
    extras_doc = {k: meta[k] for k in ("name", "spawn", "waypoints") if k in meta}
    try:
        extras = MapWorldExtras.model_validate(extras_doc)
    except ValidationError as exc:
        raise _config_error(exc, MapWorldExtras, str(path)) from None
    grid = load_map(path)
    spawn = None if extras.spawn is None else Pose2D(extras.spawn.x, extras.spawn.y,
                                                     extras.spawn.yaw)
    try:
        world = World.from_occupancy_grid(grid, extras.name or path.stem, spawn,
                                          {k: _pose(v) for k, v in extras.waypoints.items()},
                                          path)
    except SimulationError as exc:
        raise MapFileError(f"{path}: {exc}") from None
    _check_places(world, str(path))
    return world


def read_yaml_mapping(path: Path) -> dict[str, Any]:
    """Read a YAML file that must hold a mapping; ConfigError (one line) otherwise."""
    try:
        doc = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError("world file not found", file=str(path),
                          suggestion="check the path or use a built-in world name") from None
    except OSError as exc:
        raise ConfigError(f"cannot read world file ({exc.strerror})", file=str(path)) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"invalid YAML{where}: {getattr(exc, 'problem', None) or exc}",
                          file=str(path)) from None
    if not isinstance(doc, dict):
        raise ConfigError(f"a world file must be a mapping, got {type(doc).__name__}",
                          file=str(path))
    return doc


def load_world_file(path: str | Path) -> World:
    """Load a primitives YAML or a map_server YAML (told apart by the ``image`` key)."""
    p = Path(path)
    doc = read_yaml_mapping(p)
    if "image" in doc:
        return world_from_map_file(p)
    return world_from_mapping(doc, str(p), p)


__all__ = ["BoxSpec", "CircleSpec", "MarkerSpec", "MovingObstacleSpec", "PackageSpecModel",
           "PolygonSpec",
           "SpawnSpec", "WallSpec", "WorldSpec", "box_polygon", "load_world_file",
           "rasterize", "world_from_map_file", "world_from_mapping", "world_from_spec"]
