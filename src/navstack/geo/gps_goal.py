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
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from navstack.geo.conversions import GeoError, bearing_to_yaw, geodesic_inverse

__all__ = ["FixGoalFilter", "GpsGoal", "LocalOrigin", "course_over_ground", "format_dms",
           "gps_goal_in_odom", "odom_axis_course", "parse_coordinate"]

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


def course_over_ground(east: Sequence[float], north: Sequence[float],
                       min_speed: float = 0.5) -> float:
    """The mean course over ground [deg clockwise from north, 0..360) of GNSS velocity
    samples (ENU, m/s): the rover's heading calibration averages the receiver's course
    while it drives straight.  Samples slower than ``min_speed`` (starting up, a course
    that is mostly noise) are left out; the mean is circular (the vector sum of the unit
    courses), so 359 and 1 degrees average to 0.  :class:`GeoError` when no sample is
    fast enough."""
    if len(east) != len(north):
        raise ValueError("east and north need the same number of samples")
    se = sn = 0.0
    used = 0
    for ve, vn in zip(east, north, strict=True):
        speed = math.hypot(ve, vn)
        if math.isfinite(speed) and speed >= min_speed:
            se += ve / speed
            sn += vn / speed
            used += 1
    if used == 0:
        raise GeoError(f"heading calibration: none of {len(east)} GNSS velocity samples "
                       f"reached {min_speed:g} m/s; drive straight faster or longer")
    return math.degrees(math.atan2(se, sn)) % 360.0


def odom_axis_course(course_deg: float, odom_yaw: float) -> float:
    """Compass bearing [deg] of the odom frame's x axis, from the rover's course over
    ground ``course_deg`` measured while its odom yaw was ``odom_yaw`` [rad]: a robot at
    odom yaw theta has ENU yaw yaw0 + theta, so the x axis' bearing is course + theta."""
    return (course_deg + math.degrees(odom_yaw)) % 360.0


class FixGoalFilter:
    """The GPS goal in the odom frame, averaged over the fixes of the last ``window`` s.

    Each fix places the goal by :func:`gps_goal_in_odom` from the antenna's odom position
    at the fix's time (the rover's "recompute the goal from the latest fix"); the goal
    does not move in odom, so the estimates are averaged: white fix noise of sigma per
    axis shrinks to sigma / sqrt(n) (2 m at 5 Hz over 10 s: 0.28 m).  A slowly wandering
    receiver bias is common to all the fixes and stays -- no filter on GNSS alone can
    remove it.  The window keeps wheel-odometry drift between the oldest and newest fix
    small."""

    def __init__(self, latitude: float, longitude: float, axis_course_deg: float,
                 window: float = 10.0) -> None:
        if not window > 0.0:
            raise ValueError(f"window must be > 0 s, not {window!r}")
        self.latitude = parse_coordinate(latitude, "goal.latitude", "latitude")
        self.longitude = parse_coordinate(longitude, "goal.longitude", "longitude")
        self.axis_course_deg = axis_course_deg
        self.window = window
        self._samples: deque[tuple[float, float, float]] = deque()

    def add_fix(self, stamp: float, fix_latitude: float, fix_longitude: float,
                antenna_x: float, antenna_y: float) -> tuple[float, float]:
        """Add the fix taken at ``stamp`` with the antenna at odom (``antenna_x``,
        ``antenna_y``); returns the averaged goal (x, y) in odom."""
        origin = LocalOrigin(fix_latitude, fix_longitude, self.axis_course_deg)
        g = gps_goal_in_odom(origin, self.latitude, self.longitude)
        if self._samples and stamp < self._samples[-1][0]:
            self._samples.clear()
        self._samples.append((stamp, antenna_x + g.x, antenna_y + g.y))
        while self._samples[0][0] < stamp - self.window:
            self._samples.popleft()
        return self.goal()

    @property
    def fixes(self) -> int:
        return len(self._samples)

    def goal(self) -> tuple[float, float]:
        """The averaged goal in odom; :class:`GeoError` before the first fix."""
        if not self._samples:
            raise GeoError("no GNSS fix yet: the GPS goal cannot be placed")
        n = len(self._samples)
        return (sum(s[1] for s in self._samples) / n, sum(s[2] for s in self._samples) / n)
