"""Latitude/longitude <-> the ``map`` frame for operator interfaces (phone "come to me",
Telegram targets), through robot_localization's navsat transform (its ``fromLL`` and
``toLL`` services).

The transform is the one navigation uses when a :class:`NavsatTransformNode` runs (its
datum and heading); otherwise it is fixed from the robot's georeference as
robot_localization's ``datum`` parameter (``wait_for_datum``): the map origin at the
georeference's latitude/longitude with its x axis at ENU yaw ``world_yaw`` -- in the
simulator this is exactly where the simulated GNSS puts the world, on a real robot it is
the surveyed datum of the map.
"""

from __future__ import annotations

from dataclasses import dataclass

from navstack.localization.navsat import NavsatTransform, NavsatTransformParams

__all__ = ["GeoFrame"]


@dataclass
class GeoFrame:
    """Converts between WGS84 (degrees, metres) and the map frame (metres)."""

    transform: NavsatTransform

    @classmethod
    def from_datum(cls, latitude: float, longitude: float, yaw: float = 0.0) -> GeoFrame:
        """Map origin at (``latitude``, ``longitude``), x axis at ENU yaw ``yaw`` [rad]."""
        params = NavsatTransformParams(wait_for_datum=True, datum=(latitude, longitude, yaw),
                                       use_local_cartesian=True)
        return cls(NavsatTransform(params))

    @classmethod
    def for_stack(cls, stack: object) -> GeoFrame:
        """The running navsat transform of ``stack`` if it has one with a computed
        transform, else its robot's georeference as the datum."""
        runtime = getattr(stack, "runtime", None)
        for node in (getattr(runtime, "nodes", None) or {}).values():
            core = getattr(node, "core", None)
            if isinstance(core, NavsatTransform) and core.transform_good:
                return cls(core)
        geo = stack.robot.sensors.georeference  # type: ignore[attr-defined]
        return cls.from_datum(geo.latitude, geo.longitude, geo.world_yaw)

    def to_map(self, latitude: float, longitude: float, altitude: float = 0.0
               ) -> tuple[float, float]:
        """Map (x, y) [m] of a WGS84 point (``fromLL``)."""
        x, y, _ = self.transform.world_from_ll(latitude, longitude, altitude)
        return x, y

    def to_ll(self, x: float, y: float) -> tuple[float, float]:
        """WGS84 (latitude, longitude) [deg] of a map point (``toLL``)."""
        lat, lon, _ = self.transform.ll_from_world(x, y, 0.0)
        return lat, lon
