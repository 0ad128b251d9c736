"""WGS84 coordinate conversions: geodetic <-> ECEF <-> local ENU, UTM, and geodesics.

What is used where:

* **Ellipsoid and geodesics** come from GeographicLib (C. F. F. Karney, "Algorithms for
  geodesics", J. Geodesy 87, 2013) through the ``geographiclib`` package:
  :func:`geodesic_inverse` / :func:`geodesic_direct` give distances and azimuths on the
  ellipsoid to nanometre accuracy (GPS goals, checking ENU approximations).
* The Python ``geographiclib`` package has no projections (its C++ ``LocalCartesian``,
  ``Geocentric`` and ``UTMUPS`` classes are not ported), so:

  - **geodetic -> ECEF** is the closed form ``X = (N + h) cos(phi) cos(lambda)`` ...;
  - **ECEF -> geodetic** is Vermeille's exact closed-form solution (H. Vermeille, "Direct
    transformation from geocentric coordinates to geodetic coordinates", J. Geodesy 76,
    2002), valid everywhere outside the 43 km evolute around the Earth's centre;
  - **ENU** is the ECEF difference rotated into the east-north-up frame of a datum
    (what GeographicLib's ``LocalCartesian`` and robot_localization's
    ``use_local_cartesian`` do);
  - **UTM** is the transverse Mercator projection by Krueger's series to sixth order in
    the third flattening n (C. F. F. Karney, "Transverse Mercator with an accuracy of a
    few nanometers", J. Geodesy 85, 2011), which is what GeographicLib's
    ``TransverseMercator`` (hence ``UTMUPS``) implements: error below 5 nm within 3900 km
    of the central meridian.  Zones follow the UTM standard including the Norway and
    Svalbard exceptions; scale k0 = 0.9996, false easting 500 km, false northing 10000 km
    in the southern hemisphere.

Angles at the API are degrees for latitude/longitude (as in NavSatFix) and radians for
yaw, convergence and everything in the robot's frames.  Functions accept floats or numpy
arrays (broadcast together) and are vectorised; a float in gives a float out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
from geographiclib.geodesic import Geodesic
from numpy.typing import NDArray

from navstack.core.errors import NavstackError
from navstack.core.geometry import normalize_angle

FloatArray = NDArray[np.float64]
T = TypeVar("T", float, FloatArray)

__all__ = [
    "UTM_K0", "WGS84_A", "WGS84_F", "GeoError", "GeodesicSolution", "LocalCartesian",
    "UtmPoint", "bearing_to_yaw", "ecef_to_enu", "ecef_to_geodetic", "enu_to_ecef",
    "enu_to_geodetic", "geodesic_direct", "geodesic_inverse", "geodetic_to_ecef",
    "geodetic_to_enu", "geodetic_to_utm", "utm_forward", "utm_to_geodetic", "utm_zone",
    "yaw_to_bearing",
]

_WGS84 = Geodesic.WGS84
WGS84_A: float = float(_WGS84.a)
"""WGS84 equatorial radius [m] (6378137)."""
WGS84_F: float = float(_WGS84.f)
"""WGS84 flattening (1 / 298.257223563)."""
_E2 = WGS84_F * (2.0 - WGS84_F)  # first eccentricity squared
_E = math.sqrt(_E2)
_E2M = 1.0 - _E2
UTM_K0 = 0.9996
"""UTM central scale factor."""
_FALSE_EASTING = 500_000.0
_FALSE_NORTHING_SOUTH = 10_000_000.0


class GeoError(NavstackError, ValueError):
    """A coordinate is out of the domain of a conversion (latitude beyond +-90 deg, a
    point outside the UTM band, an invalid zone); the message names the value and what
    to use instead."""


def _arr(*values: Any) -> list[FloatArray]:
    return [np.asarray(v, dtype=np.float64) for v in np.broadcast_arrays(*values)]


def _like(value: FloatArray, scalar: bool) -> Any:
    return float(value) if scalar else value


def _is_scalar(*values: Any) -> bool:
    return all(np.ndim(v) == 0 for v in values)


def _check_latitude(lat: FloatArray) -> None:
    if not np.all(np.abs(lat) <= 90.0):
        bad = lat[~(np.abs(lat) <= 90.0)]
        first = float(bad.ravel()[0])
        raise GeoError(f"latitude must be within [-90, 90] degrees, got {first}; check that "
                       "latitude and longitude are not swapped")


# --- ECEF --------------------------------------------------------------------------------
def geodetic_to_ecef(lat: T, lon: T, alt: T) -> tuple[T, T, T]:
    """Earth-centred, Earth-fixed (x, y, z) [m] of WGS84 latitude/longitude [deg] and
    height above the ellipsoid [m]."""
    scalar = _is_scalar(lat, lon, alt)
    la, lo, h = _arr(lat, lon, alt)
    _check_latitude(la)
    phi, lam = np.radians(la), np.radians(lo)
    sphi, cphi = np.sin(phi), np.cos(phi)
    n = WGS84_A / np.sqrt(1.0 - _E2 * sphi * sphi)  # prime vertical radius of curvature
    x = (n + h) * cphi * np.cos(lam)
    y = (n + h) * cphi * np.sin(lam)
    z = (n * _E2M + h) * sphi
    return _like(x, scalar), _like(y, scalar), _like(z, scalar)


def ecef_to_geodetic(x: T, y: T, z: T) -> tuple[T, T, T]:
    """WGS84 latitude, longitude [deg] and ellipsoidal height [m] of ECEF (x, y, z) [m].

    Vermeille (2002), exact and closed form: no iteration, nanometre round trips for any
    point more than ~43 km from the Earth's centre (the evolute of the ellipsoid, where
    the nearest surface point is not unique, is refused).
    """
    scalar = _is_scalar(x, y, z)
    X, Y, Z = _arr(x, y, z)
    a2 = WGS84_A * WGS84_A
    e4 = _E2 * _E2
    w2 = X * X + Y * Y
    p = w2 / a2
    q = _E2M * Z * Z / a2
    r = (p + q - e4) / 6.0
    if not np.all(r > 0.0):
        raise GeoError("ECEF point lies within the ellipsoid's evolute (less than ~43 km from "
                       "the Earth's centre): geodetic coordinates are not unique there")
    s = e4 * p * q / (4.0 * r * r * r)
    t = np.cbrt(1.0 + s + np.sqrt(s * (2.0 + s)))
    u = r * (1.0 + t + 1.0 / t)
    v = np.sqrt(u * u + e4 * q)
    w = _E2 * (u + v - q) / (2.0 * v)
    k = np.sqrt(u + v + w * w) - w
    d = k * np.sqrt(w2) / (k + _E2)
    dz = np.hypot(d, Z)
    lat = np.degrees(2.0 * np.arctan2(Z, d + dz))
    lon = np.degrees(np.arctan2(Y, X))
    h = (k + _E2 - 1.0) / k * dz
    return _like(lat, scalar), _like(lon, scalar), _like(h, scalar)


# --- local ENU ---------------------------------------------------------------------------
def _enu_rotation(lat0: float, lon0: float) -> FloatArray:
    """Rows: the east, north and up unit vectors at the datum, in ECEF."""
    phi, lam = math.radians(lat0), math.radians(lon0)
    sp, cp, sl, cl = math.sin(phi), math.cos(phi), math.sin(lam), math.cos(lam)
    return np.array([[-sl, cl, 0.0],
                     [-sp * cl, -sp * sl, cp],
                     [cp * cl, cp * sl, sp]])


class LocalCartesian:
    """East-north-up coordinates [m] about a datum (lat0, lon0 [deg], alt0 [m]).

    The same frame as GeographicLib's ``LocalCartesian`` (x east, y north, z up along the
    ellipsoid normal at the datum): exact, not a flat-earth approximation, so points far
    from the datum get a negative ``up`` from the Earth's curvature.
    """

    def __init__(self, lat0: float, lon0: float, alt0: float = 0.0) -> None:
        _check_latitude(np.asarray(float(lat0)))
        self.lat0, self.lon0, self.alt0 = float(lat0), float(lon0), float(alt0)
        self.origin = np.array(geodetic_to_ecef(self.lat0, self.lon0, self.alt0))
        self.rotation = _enu_rotation(self.lat0, self.lon0)

    def ecef_to_enu(self, x: T, y: T, z: T) -> tuple[T, T, T]:
        scalar = _is_scalar(x, y, z)
        d = np.stack(_arr(x, y, z), axis=-1) - self.origin
        enu = d @ self.rotation.T
        return (_like(enu[..., 0], scalar), _like(enu[..., 1], scalar),
                _like(enu[..., 2], scalar))

    def enu_to_ecef(self, east: T, north: T, up: T) -> tuple[T, T, T]:
        scalar = _is_scalar(east, north, up)
        xyz = np.stack(_arr(east, north, up), axis=-1) @ self.rotation + self.origin
        return (_like(xyz[..., 0], scalar), _like(xyz[..., 1], scalar),
                _like(xyz[..., 2], scalar))

    def forward(self, lat: T, lon: T, alt: T) -> tuple[T, T, T]:
        """(east, north, up) [m] of a geodetic point."""
        return self.ecef_to_enu(*geodetic_to_ecef(lat, lon, alt))

    def reverse(self, east: T, north: T, up: T) -> tuple[T, T, T]:
        """(lat, lon [deg], alt [m]) of a local point."""
        return ecef_to_geodetic(*self.enu_to_ecef(east, north, up))


def ecef_to_enu(x: T, y: T, z: T, lat0: float, lon0: float, alt0: float) -> tuple[T, T, T]:
    """ENU [m] about the datum of an ECEF point."""
    return LocalCartesian(lat0, lon0, alt0).ecef_to_enu(x, y, z)


def enu_to_ecef(east: T, north: T, up: T, lat0: float, lon0: float,
                alt0: float) -> tuple[T, T, T]:
    """ECEF [m] of an ENU point about the datum."""
    return LocalCartesian(lat0, lon0, alt0).enu_to_ecef(east, north, up)


def geodetic_to_enu(lat: T, lon: T, alt: T, lat0: float, lon0: float,
                    alt0: float) -> tuple[T, T, T]:
    """ENU [m] about the datum (lat0, lon0, alt0) of a geodetic point."""
    return LocalCartesian(lat0, lon0, alt0).forward(lat, lon, alt)


def enu_to_geodetic(east: T, north: T, up: T, lat0: float, lon0: float,
                    alt0: float) -> tuple[T, T, T]:
    """Geodetic (lat, lon [deg], alt [m]) of an ENU point about the datum."""
    return LocalCartesian(lat0, lon0, alt0).reverse(east, north, up)


# --- UTM ---------------------------------------------------------------------------------
_N = WGS84_F / (2.0 - WGS84_F)  # third flattening


def _poly(coeffs: tuple[float, ...]) -> float:
    """Evaluate sum c_i n^i, i from 1."""
    return sum(c * _N ** (i + 1) for i, c in enumerate(coeffs))


# Krueger series to n^6 (Karney 2011, eqs. 35 and 36), alpha_j for forward, beta_j reverse
_ALPHA = np.array([
    _poly((1 / 2, -2 / 3, 5 / 16, 41 / 180, -127 / 288, 7891 / 37800)),
    _poly((0, 13 / 48, -3 / 5, 557 / 1440, 281 / 630, -1983433 / 1935360)),
    _poly((0, 0, 61 / 240, -103 / 140, 15061 / 26880, 167603 / 181440)),
    _poly((0, 0, 0, 49561 / 161280, -179 / 168, 6601661 / 7257600)),
    _poly((0, 0, 0, 0, 34729 / 80640, -3418889 / 1995840)),
    _poly((0, 0, 0, 0, 0, 212378941 / 319334400)),
])
_BETA = np.array([
    _poly((1 / 2, -2 / 3, 37 / 96, -1 / 360, -81 / 512, 96199 / 604800)),
    _poly((0, 1 / 48, 1 / 15, -437 / 1440, 46 / 105, -1118711 / 3870720)),
    _poly((0, 0, 17 / 480, -37 / 840, -209 / 4480, 5569 / 90720)),
    _poly((0, 0, 0, 4397 / 161280, -11 / 504, -830251 / 7257600)),
    _poly((0, 0, 0, 0, 4583 / 161280, -108847 / 3991680)),
    _poly((0, 0, 0, 0, 0, 20648693 / 638668800)),
])
_A_RECT = WGS84_A / (1.0 + _N) * (1.0 + _N ** 2 / 4 + _N ** 4 / 64 + _N ** 6 / 256)
_J2 = 2.0 * np.arange(1, 7, dtype=np.float64)  # 2j for j = 1..6


def _taup(tau: FloatArray) -> FloatArray:
    """tan of the conformal latitude from tan of the geodetic latitude (Karney eq. 7)."""
    tau1 = np.hypot(1.0, tau)
    sig = np.sinh(_E * np.arctanh(_E * tau / tau1))
    return np.hypot(1.0, sig) * tau - sig * tau1


def _tau_from_taup(taup: FloatArray) -> FloatArray:
    """Invert :func:`_taup` by Newton's method (Karney eqs. 19-21): converges in <= 3 steps."""
    tau = taup / _E2M
    for _ in range(6):
        taupa = _taup(tau)
        dtau = ((taup - taupa) * (1.0 + _E2M * tau * tau)
                / (_E2M * np.hypot(1.0, tau) * np.hypot(1.0, taupa)))
        tau = tau + dtau
        if np.all(np.abs(dtau) <= 1e-14 * np.maximum(1.0, np.abs(taup))):
            break
    return tau


def _central_meridian(zone: int) -> float:
    return 6.0 * zone - 183.0


def utm_zone(lat: float, lon: float) -> int:
    """Standard UTM zone (1..60) of a point, with the Norway (32V) and Svalbard (31X..37X)
    exceptions; raises :class:`GeoError` outside the UTM band (80 S .. 84 N)."""
    if not -80.0 <= lat <= 84.0:
        raise GeoError(f"latitude {lat} is outside the UTM band [-80, 84]; use UPS or a "
                       "LocalCartesian (ENU) frame there")
    lon = (lon + 180.0) % 360.0 - 180.0
    zone = min(math.floor((lon + 180.0) / 6.0) + 1, 60)
    if 56.0 <= lat < 64.0 and 3.0 <= lon < 12.0:
        return 32
    if lat >= 72.0 and 0.0 <= lon < 42.0:
        return 31 if lon < 9.0 else 33 if lon < 21.0 else 35 if lon < 33.0 else 37
    return zone


def utm_forward(lat: T, lon: T, zone: int,
                northp: bool) -> tuple[T, T, T, T]:
    """Project onto UTM ``zone``: (easting, northing [m], convergence [rad], scale).

    ``convergence`` is the meridian convergence gamma: the bearing of grid north measured
    clockwise from true north, equivalently the angle to *add* to an ENU yaw to get the
    yaw in the UTM grid (robot_localization's ``utm_meridian_convergence``).  ``scale``
    is the point scale factor k.  Points may lie outside the zone (forced zone); the
    series stays accurate to a few nanometres within 3900 km of the central meridian.
    """
    if not 1 <= int(zone) <= 60:
        raise GeoError(f"UTM zone must be 1..60, got {zone}")
    scalar = _is_scalar(lat, lon)
    la, lo = _arr(lat, lon)
    _check_latitude(la)
    lam = np.radians((lo - _central_meridian(int(zone)) + 180.0) % 360.0 - 180.0)
    phi = np.radians(la)
    tau = np.tan(phi)
    taup = _taup(tau)
    clam, slam = np.cos(lam), np.sin(lam)
    xip = np.arctan2(taup, clam)
    etap = np.arcsinh(slam / np.hypot(taup, clam))
    jx = _J2 * xip[..., None]
    je = _J2 * etap[..., None]
    sin_c, cos_c = np.sin(jx), np.cos(jx)
    sinh_e, cosh_e = np.sinh(je), np.cosh(je)
    xi = xip + np.sum(_ALPHA * sin_c * cosh_e, axis=-1)
    eta = etap + np.sum(_ALPHA * cos_c * sinh_e, axis=-1)
    # derivative of the Krueger series (Karney eqs. 13-14): rotation and stretch
    p = 1.0 + np.sum(_J2 * _ALPHA * cos_c * cosh_e, axis=-1)
    q = np.sum(_J2 * _ALPHA * sin_c * sinh_e, axis=-1)
    gamma = np.arctan2(taup * slam, clam * np.hypot(1.0, taup)) + np.arctan2(q, p)
    k = (UTM_K0 * _A_RECT / WGS84_A * np.hypot(p, q) * np.sqrt(_E2M + _E2 * np.cos(phi) ** 2)
         * np.hypot(1.0, tau) / np.hypot(taup, clam))
    easting = _FALSE_EASTING + UTM_K0 * _A_RECT * eta
    northing = UTM_K0 * _A_RECT * xi + (0.0 if northp else _FALSE_NORTHING_SOUTH)
    return (_like(easting, scalar), _like(northing, scalar), _like(gamma, scalar),
            _like(k, scalar))


def utm_to_geodetic(easting: T, northing: T, zone: int, northp: bool) -> tuple[T, T]:
    """Latitude, longitude [deg] of UTM (easting, northing) in ``zone`` and hemisphere."""
    if not 1 <= int(zone) <= 60:
        raise GeoError(f"UTM zone must be 1..60, got {zone}")
    scalar = _is_scalar(easting, northing)
    e, n = _arr(easting, northing)
    xi = (n - (0.0 if northp else _FALSE_NORTHING_SOUTH)) / (UTM_K0 * _A_RECT)
    eta = (e - _FALSE_EASTING) / (UTM_K0 * _A_RECT)
    jx = _J2 * xi[..., None]
    je = _J2 * eta[..., None]
    xip = xi - np.sum(_BETA * np.sin(jx) * np.cosh(je), axis=-1)
    etap = eta - np.sum(_BETA * np.cos(jx) * np.sinh(je), axis=-1)
    sxip, cxip = np.sin(xip), np.cos(xip)
    shetap = np.sinh(etap)
    r = np.hypot(shetap, cxip)
    taup = sxip / r
    lam = np.arctan2(shetap, cxip)
    tau = _tau_from_taup(taup)
    lat = np.degrees(np.arctan(tau))
    lon = _central_meridian(int(zone)) + np.degrees(lam)
    lon = (lon + 180.0) % 360.0 - 180.0
    return _like(lat, scalar), _like(lon, scalar)


@dataclass(frozen=True)
class UtmPoint:
    """A point in UTM: zone, hemisphere, coordinates [m], convergence [rad], scale."""

    zone: int
    northp: bool
    easting: float
    northing: float
    convergence: float
    scale: float


def geodetic_to_utm(lat: float, lon: float, zone: int | None = None) -> UtmPoint:
    """UTM coordinates of one point; ``zone`` None picks the standard zone
    (:func:`utm_zone`), an integer forces that zone (robot_localization's ``setUTMZone``,
    used to keep one grid when a route crosses a zone boundary)."""
    z = utm_zone(lat, lon) if zone is None else int(zone)
    northp = lat >= 0.0
    e, n, g, k = utm_forward(float(lat), float(lon), z, northp)
    return UtmPoint(z, northp, e, n, g, k)


# --- geodesics (geographiclib) --------------------------------------------------------------
@dataclass(frozen=True)
class GeodesicSolution:
    """Shortest path on the ellipsoid: length [m] and forward azimuths [deg, clockwise
    from north] at both ends."""

    distance: float
    azimuth1: float
    azimuth2: float


def geodesic_inverse(lat1: float, lon1: float, lat2: float, lon2: float) -> GeodesicSolution:
    """Distance and azimuths between two points (Karney 2013 via geographiclib)."""
    _check_latitude(np.asarray([lat1, lat2], dtype=np.float64))
    g = _WGS84.Inverse(lat1, lon1, lat2, lon2)
    return GeodesicSolution(float(g["s12"]), float(g["azi1"]), float(g["azi2"]))


def geodesic_direct(lat: float, lon: float, azimuth: float,
                    distance: float) -> tuple[float, float, float]:
    """End point (lat, lon [deg]) and azimuth [deg] after ``distance`` metres along the
    geodesic leaving (lat, lon) at ``azimuth`` degrees clockwise from north."""
    _check_latitude(np.asarray(lat, dtype=np.float64))
    g = _WGS84.Direct(lat, lon, azimuth, distance)
    return float(g["lat2"]), float(g["lon2"]), float(g["azi2"])


def bearing_to_yaw(bearing: T) -> T:
    """ENU yaw (counter-clockwise from east) [rad] of a compass bearing (clockwise from
    north) [rad]; result in (-pi, pi]."""
    return normalize_angle(0.5 * math.pi - bearing)


def yaw_to_bearing(yaw: T) -> T:
    """Compass bearing (clockwise from north) [rad] in [0, 2 pi) of an ENU yaw [rad]."""
    if isinstance(yaw, np.ndarray):
        return np.asarray(np.remainder(0.5 * math.pi - yaw, 2.0 * math.pi))
    return (0.5 * math.pi - float(yaw)) % (2.0 * math.pi)
