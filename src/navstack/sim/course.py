"""The rover's competition course: marker posts, gates and legs in a georeferenced world.

A course YAML (the packaged one is ``navstack/config/rover_mars_yard.yaml``) names a
primitives world, puts it on the Earth (a :class:`~navstack.sim.robot.GeoReferenceParams`),
places the marker posts (ArUco ids, world metres) and the gates (two posts each), and lists
the legs as the rover receives them: a latitude/longitude (decimal degrees or the rover's
``"deg,min,sec"`` strings) and, for a post or gate leg, what to look for there.
:func:`course_world` adds the posts to the world as obstacles, so the simulated lidar and
the collision check see them; :func:`course_robot` gives a robot profile the course's
georeference, so the simulated GNSS reports the yard's coordinates.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, model_validator

from navstack.core.aruco_dictionaries import check_dictionary_name, check_marker_id, get_dictionary
from navstack.core.errors import ConfigError
from navstack.core.params import Params
from navstack.geo.conversions import GeoError, LocalCartesian
from navstack.geo.gps_goal import parse_coordinate
from navstack.sim.gnss import world_to_enu
from navstack.sim.markers import WorldMarker
from navstack.sim.robot import GeoReferenceParams, RobotParams, load_robot
from navstack.sim.world import World
from navstack.sim.world_io import read_yaml_mapping, world_from_mapping
from navstack.sim.worlds import world_path

__all__ = [
    "Course",
    "CourseLeg",
    "DemoSpec",
    "GateSpec",
    "GpsPoint",
    "PostSpec",
    "StartPose",
    "course_robot",
    "course_world",
    "default_course_path",
    "ll_to_world",
    "load_course",
    "post_markers",
    "world_to_ll",
]


class PostSpec(Params):
    """A marker post: ArUco ``id``, position in the world [m], ``radius`` [m]; a marker of
    its id (``marker_size`` [m], the black square's side, centred ``marker_height`` [m]
    above the ground) on each of ``faces`` sides, the first facing ``yaw`` [rad]."""

    id: int = Field(ge=0)
    x: float
    y: float
    radius: float = Field(default=0.15, gt=0.0)
    marker_size: float = Field(default=0.2, gt=0.0)
    marker_height: float = Field(default=0.8, gt=0.0)
    faces: int = Field(default=4, ge=1, le=8)
    yaw: float = 0.0


class StartPose(Params):
    """A world pose [m, rad] (where a benchmark puts the rover for a leg)."""

    x: float
    y: float
    yaw: float = 0.0


class GateSpec(Params):
    """A gate: two marker posts (ids) the rover passes between."""

    name: str
    posts: tuple[int, int]


class GpsPoint(Params):
    """A coordinate as the rover receives it (decimal degrees or ``"deg,min,sec"``)."""

    latitude: str | float
    longitude: str | float


class CourseLeg(GpsPoint):
    """One leg: drive to the coordinate (``gnss``), then find a post (``post``) or pass a
    gate (``gate``) near it."""

    name: str
    kind: Literal["gnss", "post", "gate"]
    post: int | None = None
    gate: str | None = None
    start: StartPose | None = None
    """Where ``navstack bench rover`` starts this leg (world frame); None: not benched
    alone."""


class DemoSpec(Params):
    """The course's demo (``navstack demo --robot rover``): start pose and leg names."""

    start: StartPose
    legs: list[str] = Field(min_length=1)


class Course(Params):
    """A course file: world (a built-in name or a primitives world file's path),
    georeference, posts, gates, legs, GPS waypoints, demo."""

    world: str
    georeference: GeoReferenceParams = Field(default_factory=GeoReferenceParams)
    posts: list[PostSpec] = Field(default_factory=list)
    gates: list[GateSpec] = Field(default_factory=list)
    legs: list[CourseLeg] = Field(default_factory=list)
    gps_waypoints: list[GpsPoint] = Field(default_factory=list)
    demo: DemoSpec | None = None

    @model_validator(mode="after")
    def _references(self) -> Course:
        ids = [p.id for p in self.posts]
        if len(set(ids)) != len(ids):
            raise ValueError(f"posts: duplicate marker ids in {ids}")
        names = [g.name for g in self.gates]
        for g in self.gates:
            for pid in g.posts:
                if pid not in ids:
                    raise ValueError(f"gates: gate '{g.name}' names post {pid}, which is not "
                                     f"in posts (ids {ids})")
        for leg in self.legs:
            if leg.kind == "post" and leg.post not in ids:
                raise ValueError(f"legs: post leg '{leg.name}' needs post: one of {ids}")
            if leg.kind == "gate" and leg.gate not in names:
                raise ValueError(f"legs: gate leg '{leg.name}' needs gate: one of {names}")
        legs = [leg.name for leg in self.legs]
        for name in (self.demo.legs if self.demo is not None else []):
            if name not in legs:
                raise ValueError(f"demo.legs: '{name}' is not a leg (legs: {legs})")
        return self

    def post(self, marker_id: int) -> PostSpec:
        for p in self.posts:
            if p.id == marker_id:
                return p
        raise KeyError(f"no post with marker id {marker_id}")

    def gate(self, name: str) -> GateSpec:
        for g in self.gates:
            if g.name == name:
                return g
        raise KeyError(f"no gate named {name!r}; gates: {[g.name for g in self.gates]}")

    def leg_post_ids(self, leg: CourseLeg) -> tuple[int, ...]:
        """The marker ids a leg looks for: none (GNSS), the post, or the gate's two."""
        if leg.kind == "post" and leg.post is not None:
            return (leg.post,)
        if leg.kind == "gate" and leg.gate is not None:
            return tuple(self.gate(leg.gate).posts)
        return ()

    def leg(self, name: str) -> CourseLeg:
        for leg in self.legs:
            if leg.name == name:
                return leg
        raise KeyError(f"no leg named {name!r}; legs: {[leg.name for leg in self.legs]}")


def default_course_path() -> Path:
    return Path(str(resources.files("navstack") / "config" / "rover_mars_yard.yaml"))


def load_course(path: str | Path | None = None) -> Course:
    """Load and validate a course file (the packaged mars yard course by default).

    Errors are :class:`ConfigError` naming the file and key path; a coordinate that does
    not parse names its leg (``legs[2].latitude``)."""
    p = Path(path) if path is not None else default_course_path()
    course = Course.from_mapping(read_yaml_mapping(p), file=str(p))
    points: list[tuple[str, GpsPoint]] = [(f"legs[{i}]", leg)
                                          for i, leg in enumerate(course.legs)]
    points += [(f"gps_waypoints[{i}]", w) for i, w in enumerate(course.gps_waypoints)]
    for where, point in points:
        try:
            parse_coordinate(point.latitude, f"{where}.latitude", "latitude")
            parse_coordinate(point.longitude, f"{where}.longitude", "longitude")
        except GeoError as exc:
            raise ConfigError(str(exc), file=str(p)) from None
    return course


def post_markers(post: PostSpec, dictionary: str) -> list[WorldMarker]:
    """The ArUco markers on a post: one of its id on each face, 1 mm proud of the post's
    surface, facing out (the competition's posts carry the same marker on every side, so
    a post is recognised from any direction)."""
    cells = int(get_dictionary(dictionary).markerSize) + 2
    out = []
    for k in range(post.faces):
        yaw = math.remainder(post.yaw + 2.0 * math.pi * k / post.faces, 2.0 * math.pi)
        d = post.radius + 1e-3
        out.append(WorldMarker(post.id, dictionary, post.marker_size,
                               post.x + d * math.cos(yaw), post.y + d * math.sin(yaw),
                               post.marker_height, yaw, post.marker_size / cells))
    return out


def course_world(course: Course) -> World:
    """The course's world with its marker posts added as circular obstacles, each with
    its ArUco markers (:func:`post_markers`, the world's ``marker_dictionary``)."""
    path = (Path(course.world) if course.world.endswith((".yaml", ".yml"))
            else world_path(course.world))
    data: dict[str, Any] = read_yaml_mapping(path)
    circles = list(data.get("circles") or [])
    circles += [{"center": [p.x, p.y], "radius": p.radius} for p in course.posts]
    world = world_from_mapping({**data, "circles": circles}, str(path), path)
    dictionary = check_dictionary_name(str(data.get("marker_dictionary", "DICT_4X4_50")),
                                       "marker_dictionary", str(path))
    for i, p in enumerate(course.posts):
        check_marker_id(dictionary, p.id, f"posts[{i}].id", str(path))
        if p.marker_height + 0.5 * p.marker_size > world.wall_height:
            raise ConfigError(f"post {p.id}'s marker top ({p.marker_height + 0.5 * p.marker_size}"
                              f" m) is above the world's wall_height ({world.wall_height} m)",
                              key_path=f"posts[{i}].marker_height")
    markers = [mk for p in course.posts for mk in post_markers(p, dictionary)]
    world.markers = tuple(world.markers) + tuple(markers)
    return world


def course_robot(course: Course, robot: str | Path = "rover",
                 overrides: dict[str, Any] | None = None) -> RobotParams:
    """``robot``'s profile placed on the course's georeference (``overrides`` merged too)."""
    geo = course.georeference.model_dump()
    merged: dict[str, Any] = dict(overrides or {})
    sensors = dict(merged.get("sensors") or {})
    sensors["georeference"] = {**geo, **dict(sensors.get("georeference") or {})}
    merged["sensors"] = sensors
    return load_robot(robot, merged)


def world_to_ll(geo: GeoReferenceParams, x: float, y: float) -> tuple[float, float]:
    """WGS84 (latitude, longitude) of world point (x, y): the simulator's GNSS truth."""
    e, n = world_to_enu(x, y, geo.world_yaw)
    lat, lon, _ = LocalCartesian(geo.latitude, geo.longitude, geo.altitude).reverse(e, n, 0.0)
    return float(lat), float(lon)


def ll_to_world(geo: GeoReferenceParams, latitude: float, longitude: float
                ) -> tuple[float, float]:
    """World (x, y) [m] of a WGS84 point (the inverse of :func:`world_to_ll`)."""
    e, n, _ = LocalCartesian(geo.latitude, geo.longitude, geo.altitude).forward(
        latitude, longitude, geo.altitude)
    c, s = math.cos(geo.world_yaw), math.sin(geo.world_yaw)
    return float(c * e + s * n), float(-s * e + c * n)
