"""Predefined goal targets of the Telegram bot: where a chat's location sends the robot.

The golf cart's bot kept a list of places; a location shared in the chat selected the
place nearest to it (haversine distance) and the robot was sent there with that place's
heading.  A target file (YAML) lists them::

    targets:
      - name: Library            # shown in the chat
        latitude: 38.406658      # WGS84 degrees: what a shared location is compared with
        longitude: -110.791413
        yaw: 1.5708              # heading of the goal in the map frame [rad]
        x: 44.5                  # optional: the goal in the map frame [m]; default:
        y: 27.0                  #   the latitude/longitude through the navsat transform

Without a file the bot uses the world's named waypoints, placed on the Earth by the
navsat transform (:class:`~navstack.interfaces.geo_frame.GeoFrame`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import Field

from navstack.core.config_files import load_yaml
from navstack.core.errors import ConfigError
from navstack.core.msgs import Pose2D
from navstack.core.params import Params
from navstack.geo.distance import nearest
from navstack.interfaces.geo_frame import GeoFrame

__all__ = ["Target", "load_targets", "nearest_target", "targets_from_waypoints"]


@dataclass(frozen=True)
class Target:
    """A place the bot can send the robot to: where it is on the Earth and the goal pose."""

    name: str
    latitude: float
    longitude: float
    x: float
    y: float
    yaw: float

    def describe(self) -> str:
        return (f"{self.name} ({self.latitude:.6f}, {self.longitude:.6f}; map "
                f"x={self.x:.1f} y={self.y:.1f}, heading {math.degrees(self.yaw):.0f} deg)")


class _TargetEntry(Params):
    name: str = Field(min_length=1, max_length=64)
    latitude: float = Field(ge=-90.0, le=90.0, allow_inf_nan=False)
    longitude: float = Field(ge=-180.0, le=180.0, allow_inf_nan=False)
    yaw: float = Field(ge=-2.0 * math.pi, le=2.0 * math.pi, allow_inf_nan=False)
    x: float | None = Field(None, allow_inf_nan=False)
    y: float | None = Field(None, allow_inf_nan=False)


class _TargetFile(Params):
    targets: tuple[_TargetEntry, ...] = Field(min_length=1)


def load_targets(path: str | Path, geo: GeoFrame) -> list[Target]:
    """Targets from a YAML file (module docstring); ConfigError naming the file and entry."""
    data = load_yaml(Path(path))
    parsed = _TargetFile.from_mapping(data, file=str(path))
    return _resolve(parsed.targets, geo, str(path))


def _resolve(entries: tuple[_TargetEntry, ...], geo: GeoFrame, file: str) -> list[Target]:
    out: list[Target] = []
    names: set[str] = set()
    for i, e in enumerate(entries):
        if e.name in names:
            raise ConfigError(f"target name '{e.name}' appears twice", file=file,
                              key_path=f"targets[{i}].name", suggestion="names must be unique")
        names.add(e.name)
        if (e.x is None) != (e.y is None):
            raise ConfigError("give both x and y, or neither", file=file,
                              key_path=f"targets[{i}]")
        x, y = (e.x, e.y) if e.x is not None and e.y is not None else geo.to_map(
            e.latitude, e.longitude)
        out.append(Target(e.name, e.latitude, e.longitude, x, y,
                          math.atan2(math.sin(e.yaw), math.cos(e.yaw))))
    return out


def targets_from_waypoints(waypoints: Mapping[str, Pose2D], geo: GeoFrame) -> list[Target]:
    """The world's named waypoints as targets, located on the Earth by ``geo``."""
    out = []
    for name, p in waypoints.items():
        lat, lon = geo.to_ll(p.x, p.y)
        out.append(Target(name, lat, lon, p.x, p.y, p.theta))
    return out


def nearest_target(targets: list[Target], latitude: float, longitude: float
                   ) -> tuple[Target, float]:
    """The target nearest to a location by haversine distance, and that distance [m]."""
    if not targets:
        raise ValueError("the bot has no targets")
    i, d = nearest(latitude, longitude, [t.latitude for t in targets],
                   [t.longitude for t in targets])
    return targets[i], d


def target_table(targets: list[Target]) -> list[dict[str, Any]]:
    """Plain rows for status replies and JSON."""
    return [{"name": t.name, "latitude": t.latitude, "longitude": t.longitude, "x": t.x,
             "y": t.y, "yaw": t.yaw} for t in targets]
