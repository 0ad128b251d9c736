"""GPS waypoints: latitude/longitude lists (and their YAML) placed in the ``map`` frame.

Nav2's ``followGpsWaypoints`` sends ``geographic_msgs/GeoPose`` waypoints to the waypoint
follower, which converts each with robot_localization's ``fromLL`` and then follows them
like map waypoints.  The conversion must carry the rotation between the map frame and
east-north: a map whose x axis is not east (any map made by SLAM or surveyed on site)
rotates every point *and* every heading by the navsat transform's yaw.  A known Nav2 bug
dropped that yaw, so GPS waypoints landed rotated about the datum in such a map; here
both the position and the heading go through the same
:class:`~navstack.interfaces.geo_frame.GeoFrame`.

YAML, as in Nav2's GPS waypoint demo (``nav2_gps_waypoint_follower_demo``)::

    waypoints:
      - {latitude: 38.4066, longitude: -110.7916}          # faces the way it is driven
      - {latitude: "38,24,25.2", longitude: "-110,47,29.5", yaw: 1.57}   # ENU yaw [rad]

Coordinates are decimal degrees or the rover's ``"deg,min,sec"`` strings; ``yaw`` is the
heading at the waypoint in ENU (0 east, pi/2 north).  Without a yaw a waypoint faces away
from the previous one (the first from the robot), so the robot never turns round on a
waypoint for nothing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D, PoseStamped
from navstack.geo.conversions import GeoError
from navstack.geo.gps_goal import parse_coordinate
from navstack.interfaces.geo_frame import GeoFrame

__all__ = ["GpsWaypoint", "gps_waypoint", "gps_waypoints_in_map", "load_gps_waypoints"]


@dataclass(frozen=True)
class GpsWaypoint:
    """A GPS waypoint: latitude/longitude [deg], optional ENU yaw [rad] at it."""

    latitude: float
    longitude: float
    yaw: float | None = None


def gps_waypoint(value: Any, field: str = "waypoint") -> GpsWaypoint:
    """A :class:`GpsWaypoint` from a waypoint, a ``(lat, lon[, yaw])`` tuple, a mapping
    with ``latitude``/``longitude``[/``yaw``] or an object with those attributes (a
    GeoPose-like message).  :class:`GeoError` names ``field`` when it is not one."""
    if isinstance(value, GpsWaypoint):
        return value
    yaw: Any = None
    if isinstance(value, dict):
        unknown = sorted(set(value) - {"latitude", "longitude", "yaw"})
        if unknown or "latitude" not in value or "longitude" not in value:
            raise GeoError(f"{field}: needs latitude and longitude (and optionally yaw), "
                           f"got keys {sorted(value)}")
        lat, lon, yaw = value["latitude"], value["longitude"], value.get("yaw")
    elif isinstance(value, (tuple, list)) and len(value) in (2, 3):
        lat, lon = value[0], value[1]
        yaw = value[2] if len(value) == 3 else None
    elif hasattr(value, "latitude") and hasattr(value, "longitude"):
        lat, lon, yaw = value.latitude, value.longitude, getattr(value, "yaw", None)
    else:
        raise GeoError(f"{field}: {value!r} is not a GPS waypoint; give (latitude, longitude"
                       "[, yaw]) or a mapping with latitude and longitude")
    latitude = parse_coordinate(lat, f"{field}.latitude", "latitude")
    longitude = parse_coordinate(lon, f"{field}.longitude", "longitude")
    if yaw is not None and (isinstance(yaw, bool) or not isinstance(yaw, (int, float))
                            or not math.isfinite(yaw)):
        raise GeoError(f"{field}.yaw: {yaw!r} is not a heading; give the ENU yaw in radians")
    return GpsWaypoint(latitude, longitude, None if yaw is None else float(yaw))


def load_gps_waypoints(path: str | Path) -> list[GpsWaypoint]:
    """Read a GPS waypoint YAML (``waypoints:`` list); :class:`ConfigError` naming the file
    and the waypoint on any problem."""
    p = Path(path)
    try:
        doc = yaml.safe_load(p.read_text())
    except FileNotFoundError:
        raise ConfigError("GPS waypoint file not found", file=str(p)) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"invalid YAML: {exc}", file=str(p)) from None
    items = doc.get("waypoints") if isinstance(doc, dict) else None
    if not isinstance(items, list) or not items:
        raise ConfigError("needs a non-empty 'waypoints' list of {latitude, longitude[, yaw]}",
                          file=str(p), key_path="waypoints")
    try:
        return [gps_waypoint(w, f"waypoints[{i}]") for i, w in enumerate(items)]
    except GeoError as exc:
        raise ConfigError(str(exc), file=str(p)) from None


def gps_waypoints_in_map(frame: GeoFrame, waypoints: Sequence[Any],
                         start: tuple[float, float] = (0.0, 0.0), stamp: float = 0.0
                         ) -> list[PoseStamped]:
    """Map-frame poses of ``waypoints`` (anything :func:`gps_waypoint` takes): positions
    through ``fromLL``; an ENU yaw rotated by the transform's yaw into the map; without a
    yaw, facing away from the previous point (``start`` for the first)."""
    points = [gps_waypoint(w, f"waypoints[{i}]") for i, w in enumerate(waypoints)]
    if not points:
        raise GeoError("waypoints: the list is empty; give at least one (latitude, longitude)")
    transform = frame.transform.transform
    rotation = transform.yaw if transform is not None else 0.0
    poses = []
    previous = start
    for w in points:
        x, y = frame.to_map(w.latitude, w.longitude)
        if w.yaw is not None:
            yaw = math.remainder(w.yaw + rotation, 2.0 * math.pi)
        else:
            yaw = math.atan2(y - previous[1], x - previous[0])
        poses.append(PoseStamped.from_pose2d(Pose2D(x, y, yaw), "map", stamp))
        previous = (x, y)
    return poses
