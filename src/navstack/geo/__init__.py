"""Geodesy for outdoor robots: WGS84 geodetic, ECEF, local ENU and UTM coordinates, and
geodesics (distances and bearings on the ellipsoid, via geographiclib).

See :mod:`navstack.geo.conversions`.
"""

from navstack.geo.conversions import (
    WGS84_A,
    WGS84_F,
    GeodesicSolution,
    GeoError,
    LocalCartesian,
    UtmPoint,
    bearing_to_yaw,
    ecef_to_geodetic,
    enu_to_geodetic,
    geodesic_direct,
    geodesic_inverse,
    geodetic_to_ecef,
    geodetic_to_enu,
    geodetic_to_utm,
    utm_to_geodetic,
    utm_zone,
    yaw_to_bearing,
)

__all__ = [
    "WGS84_A", "WGS84_F", "GeoError", "GeodesicSolution", "LocalCartesian", "UtmPoint",
    "bearing_to_yaw", "ecef_to_geodetic", "enu_to_geodetic", "geodesic_direct",
    "geodesic_inverse", "geodetic_to_ecef", "geodetic_to_enu", "geodetic_to_utm",
    "utm_to_geodetic", "utm_zone", "yaw_to_bearing",
]
