"""Great-circle distance (haversine) for choosing the nearest of a few named places.

The haversine formula on a sphere of radius 6371008.8 m (the IUGG mean Earth radius R1) is
what the golf cart's Telegram bot used to pick the target nearest to a chat's location:
its error against the WGS84 geodesic is below 0.5 % -- enough to rank places, not to
navigate (use :func:`navstack.geo.conversions.geodesic_inverse` for that).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["MEAN_EARTH_RADIUS", "haversine", "nearest"]

MEAN_EARTH_RADIUS = 6371008.8
"""IUGG mean Earth radius R1 [m]."""


def haversine(lat1: ArrayLike, lon1: ArrayLike, lat2: ArrayLike, lon2: ArrayLike
              ) -> NDArray[np.float64]:
    """Great-circle distance [m] between points given in degrees (numpy broadcasting)."""
    p1, p2 = np.radians(np.asarray(lat1, float)), np.radians(np.asarray(lat2, float))
    dlat = p2 - p1
    dlon = np.radians(np.asarray(lon2, float) - np.asarray(lon1, float))
    a = np.sin(dlat / 2.0) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dlon / 2.0) ** 2
    return np.asarray(2.0 * MEAN_EARTH_RADIUS * np.arcsin(np.sqrt(np.clip(a, 0.0, 1.0))))


def nearest(lat: float, lon: float, lats: ArrayLike, lons: ArrayLike) -> tuple[int, float]:
    """Index of the point of (``lats``, ``lons``) nearest to (``lat``, ``lon``) and its
    distance [m]; ValueError for an empty list."""
    d = haversine(lat, lon, lats, lons)
    if d.size == 0:
        raise ValueError("no places to choose from")
    i = int(np.argmin(d))
    return i, float(d.reshape(-1)[i])
