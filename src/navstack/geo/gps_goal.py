"""GPS goals for outdoor missions: coordinate strings and placing a lat/lon goal in odom.

The planetary rover's GPS goal controller (see ``FIELD-ROBOTS.md``) takes goal coordinates
as decimal degrees or ``"deg,min,sec"`` strings, where a leading minus negates the whole
value (``"-79,22,45"`` is -79.379167, not -79 + 22' + 45"). It solves the WGS84 geodesic
inverse problem from the local origin (the first fix, robot_localization's
``publish_origin``-style datum) to the goal -- distance ``s12`` and initial azimuth
``azi1`` (Karney 2013, via geographiclib) -- and rotates the east/north offset by the
initial course over ground measured in the heading-calibration drive, so the goal lands
in the odom frame whose x axis is the rover's heading at the origin. The goal faces the
target: its yaw is the direction from the robot to the goal.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from navstack.geo.conversions import GeoError, bearing_to_yaw, geodesic_inverse

__all__ = ["GpsGoal", "LocalOrigin", "format_dms", "gps_goal_in_odom", "parse_coordinate"]

_DECIMAL = re.compile(r"^[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?$")
_LIMITS = {"latitude": 90.0, "longitude": 180.0}


def parse_coordinate(value: str | float | int, field: str = "coordinate",
                     kind: str = "latitude") -> float:
    """Degrees of a latitude/longitude given as a number, a decimal string or a
    ``"deg,min,sec"`` string (the rover's format; a leading ``-`` negates the whole value).

    ``field`` names the value in errors (``"legs[2].latitude"``); ``kind`` is
    ``"latitude"`` (|value| <= 90) or ``"longitude"`` (|value| <= 180).
    Raises :class:`GeoError` naming the field, the text and what would fix it."""
    if kind not in _LIMITS:
        raise ValueError(f"kind must be 'latitude' or 'longitude', not {kind!r}")
    limit = _LIMITS[kind]
    if isinstance(value, bool):
        raise GeoError(f"{field}: {value!r} is not a {kind}; give decimal degrees "
                       "(43.658611) or a 'deg,min,sec' string ('43,39,31')")
    if isinstance(value, (int, float)):
        degrees = float(value)
    else:
        degrees = _parse_text(str(value), field, kind)
    if not math.isfinite(degrees) or abs(degrees) > limit:
        raise GeoError(f"{field}: {value!r} is outside the {kind} range "
                       f"[-{limit:g}, {limit:g}] degrees")
    return degrees


def _parse_text(text: str, field: str, kind: str) -> float:
    stripped = text.strip()
    if _DECIMAL.match(stripped):
        return float(stripped)
    negative = stripped.startswith("-")
    body = stripped[1:] if negative or stripped.startswith("+") else stripped
    parts = [p.strip() for p in body.split(",")]
    hint = ("give decimal degrees (43.658611) or 'deg,min,sec' ('43,39,31'; a leading '-' "
            "negates the whole value)")
    if len(parts) != 3 or not all(re.fullmatch(r"\d+(\.\d*)?", p) for p in parts):
        raise GeoError(f"{field}: {text!r} is not a {kind}; {hint}")
    deg, minutes, seconds = (float(p) for p in parts)
    if deg != int(deg):
        raise GeoError(f"{field}: {text!r} has fractional degrees in deg,min,sec form; "
                       "put the fraction in the minutes and seconds")
    if minutes >= 60.0 or seconds >= 60.0:
        raise GeoError(f"{field}: {text!r} has minutes or seconds >= 60; {hint}")
    value = deg + minutes / 60.0 + seconds / 3600.0
    return -value if negative else value


def format_dms(degrees: float) -> str:
    """The rover's ``"deg,min,sec"`` string of ``degrees`` (seconds to 1e-4 s)."""
    sign = "-" if degrees < 0 else ""
    total = round(abs(degrees) * 3600.0, 4)
    deg, rest = divmod(total, 3600.0)
    minutes, seconds = divmod(rest, 60.0)
    return f"{sign}{int(deg)},{int(minutes)},{seconds:.4f}".rstrip("0").rstrip(".")


@dataclass(frozen=True)
class LocalOrigin:
    """The local origin of GPS goals: the fix where odometry started and the initial
    course over ground (compass bearing, degrees clockwise from north) of the odom x axis."""

    latitude: float
    longitude: float
    course_deg: float

    def __post_init__(self) -> None:
        parse_coordinate(self.latitude, "origin.latitude", "latitude")
        parse_coordinate(self.longitude, "origin.longitude", "longitude")
        if not math.isfinite(self.course_deg):
            raise GeoError(f"origin.course_deg: {self.course_deg!r} is not a finite bearing")


@dataclass(frozen=True)
class GpsGoal:
    """A GPS goal in the odom frame: position [m], yaw facing the target [rad], and the
    geodesic ``distance`` [m] / ``bearing`` [deg from north] from the origin."""

    x: float
    y: float
    yaw: float
    distance: float
    bearing: float


def gps_goal_in_odom(origin: LocalOrigin, latitude: float, longitude: float,
                     robot_xy: tuple[float, float] = (0.0, 0.0)) -> GpsGoal:
    """Place the lat/lon goal in the odom frame of ``origin``; yaw faces it from
    ``robot_xy`` (the origin by default).

    east/north = s12 (sin azi1, cos azi1); odom = R(-yaw0) (east, north) with yaw0 the ENU
    yaw of the initial course."""
    g = geodesic_inverse(origin.latitude, origin.longitude, latitude, longitude)
    azimuth = math.radians(g.azimuth1)
    east, north = g.distance * math.sin(azimuth), g.distance * math.cos(azimuth)
    yaw0 = bearing_to_yaw(math.radians(origin.course_deg))
    c, s = math.cos(yaw0), math.sin(yaw0)
    x, y = c * east + s * north, -s * east + c * north
    dx, dy = x - robot_xy[0], y - robot_xy[1]
    yaw = math.atan2(dy, dx) if math.hypot(dx, dy) > 1e-9 else 0.0
    return GpsGoal(x, y, yaw, g.distance, g.azimuth1 % 360.0)
