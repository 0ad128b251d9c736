"""GNSS receivers: NMEA 0183 (pynmea2) and u-blox UBX (pyubx2) into NavSatFix + course/speed.

Real receivers speak NMEA 0183 text sentences or u-blox's binary UBX; both are decoded
with the maintained libraries, pynmea2 and pyubx2, and turned into a
:class:`GnssReading`: a ``sensor_msgs/NavSatFix`` (when the message carries a position)
and the course [deg, clockwise from true north] and speed over ground [m/s] (when it
carries a velocity).

* **GGA** -> fix.  The covariance follows the ROS ``nmea_navsat_driver``: the horizontal
  standard deviation is ``HDOP * epe(quality)`` -- the receiver's user-equivalent range
  error for that fix quality (GPS 4 m, DGPS 0.1 m, RTK fixed 0.02 m, RTK float 4 m,
  WAAS 3 m, PPS 4 m, dead reckoning 10 m) -- the vertical one twice that, type
  ``COVARIANCE_TYPE_APPROXIMATED``.  Status: quality 0 no fix, 2 / 9 SBAS, 4 / 5 GBAS, the
  others FIX.  Altitude is above the ellipsoid (GGA's MSL altitude + geoid separation).
* **RMC** -> course and speed (knots -> m/s) when the status is ``A`` (valid), and a fix
  with ``COVARIANCE_TYPE_UNKNOWN`` (RMC has no HDOP).
* **VTG** -> course and speed (km/h field).
* **UBX NAV-PVT** -> fix and velocity.  Covariance as the ROS ``ublox`` driver: diagonal
  ``hAcc^2, hAcc^2, vAcc^2`` (``COVARIANCE_TYPE_DIAGONAL_KNOWN``); status FIX when
  ``fixType`` is 2-D, 3-D or GNSS+DR and ``gnssFixOK`` is set, SBAS with ``diffSoln``,
  GBAS with ``carrSoln`` (RTK); course ``headMot``, speed ``gSpeed``.
* NAV-POSLLH and NAV-VELNED (older receivers) give the fix and the velocity separately.

Checksums are required (pynmea2 ``check=True``; pyubx2 ``VALCKSUM``).  Whatever the
libraries raise -- bad checksum, unknown sentence, a field that does not convert -- is a
:class:`MalformedPacket`: the libraries parse fields lazily, so every attribute is read
inside the guard.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pynmea2
from pyubx2 import VALCKSUM, UBXReader

from navstack.core.msgs import Header, NavSatFix, NavSatStatus
from navstack.drivers.errors import MalformedPacket

__all__ = ["EPE_BY_QUALITY", "GnssReading", "decode_nmea", "decode_ubx", "velocity_enu"]

KNOT = 1852.0 / 3600.0
EPE_BY_QUALITY: dict[int, float] = {1: 4.0, 2: 0.1, 3: 4.0, 4: 0.02, 5: 4.0, 6: 10.0,
                                    7: 10.0, 8: 10.0, 9: 3.0}
"""User-equivalent range error [m] per GGA fix quality (nmea_navsat_driver's defaults)."""
_STATUS_BY_QUALITY = {0: NavSatStatus.STATUS_NO_FIX, 2: NavSatStatus.STATUS_SBAS_FIX,
                      9: NavSatStatus.STATUS_SBAS_FIX, 4: NavSatStatus.STATUS_GBAS_FIX,
                      5: NavSatStatus.STATUS_GBAS_FIX}
NO_FIX_VARIANCE = 1e12


@dataclass(frozen=True, slots=True, eq=False)
class GnssReading:
    """What one sentence / message said: a fix and/or a velocity over ground."""

    message: str
    """Sentence or message type ("GGA", "RMC", "VTG", "NAV-PVT", ...)."""
    fix: NavSatFix | None = None
    course_deg: float | None = None
    """Course over ground [deg, clockwise from true north]."""
    speed: float | None = None
    """Speed over ground [m/s]."""
    hdop: float | None = None
    satellites: int | None = None


def velocity_enu(course_deg: float, speed: float) -> tuple[float, float]:
    """(east, north) velocity [m/s] for a course over ground and a speed."""
    c = math.radians(course_deg)
    return speed * math.sin(c), speed * math.cos(c)


def _fix(lat: float, lon: float, alt: float, status: int, var_h: float, var_v: float,
         cov_type: int, stamp: float, frame_id: str) -> NavSatFix:
    return NavSatFix(Header(stamp, frame_id), NavSatStatus(status, NavSatStatus.SERVICE_GPS),
                     lat, lon, alt, np.diag([var_h, var_h, var_v]), cov_type)


def _finite(codec: str, data: bytes | str, **values: float) -> None:
    for name, value in values.items():
        if not math.isfinite(value):
            raise MalformedPacket(codec, f"{name} is {value}", data)
    lat, lon = values.get("latitude", 0.0), values.get("longitude", 0.0)
    if abs(lat) > 90.0 or abs(lon) > 180.0:
        raise MalformedPacket(codec, f"position ({lat}, {lon}) outside the globe", data)


def decode_nmea(line: bytes | str, stamp: float = 0.0, frame_id: str = "gps_link"
                ) -> GnssReading:
    """Decode one NMEA sentence (GGA, RMC or VTG, any talker); :class:`MalformedPacket`
    for anything else or anything wrong."""
    codec = "NMEA"
    try:
        text = line.decode("ascii") if isinstance(line, bytes) else line
        msg = pynmea2.parse(text.strip(), check=True)
        kind = msg.sentence_type
        if kind == "GGA":
            return _gga(msg, text, stamp, frame_id)
        if kind == "RMC":
            return _rmc(msg, text, stamp, frame_id)
        if kind == "VTG":
            course = float(msg.true_track) if msg.true_track is not None else None
            speed = float(msg.spd_over_grnd_kmph) / 3.6 \
                if msg.spd_over_grnd_kmph is not None else None
            if course is not None:
                _finite(codec, text, course=course)
            if speed is not None:
                _finite(codec, text, speed=speed)
            return GnssReading("VTG", None, course, speed)
    except MalformedPacket:
        raise
    except Exception as exc:  # the library's own errors, and lazy field conversions
        raise MalformedPacket(codec, f"{type(exc).__name__}: {exc}", line) from None
    raise MalformedPacket(codec, f"unsupported sentence {kind!r} (decoded: GGA, RMC, VTG)", line)


def _gga(msg: pynmea2.GGA, text: str, stamp: float, frame_id: str) -> GnssReading:
    quality = int(msg.gps_qual or 0)
    hdop = float(msg.horizontal_dil) if msg.horizontal_dil else math.nan
    sats = int(msg.num_sats) if msg.num_sats else 0
    if quality == 0 or not msg.lat:
        nan = math.nan
        fix = _fix(nan, nan, nan, NavSatStatus.STATUS_NO_FIX, NO_FIX_VARIANCE, NO_FIX_VARIANCE,
                   NavSatFix.COVARIANCE_TYPE_UNKNOWN, stamp, frame_id)
        return GnssReading("GGA", fix, hdop=None if math.isnan(hdop) else hdop, satellites=sats)
    lat, lon = float(msg.latitude), float(msg.longitude)
    alt = float(msg.altitude or 0.0) + float(msg.geo_sep or 0.0)
    _finite("NMEA GGA", text, latitude=lat, longitude=lon, altitude=alt, hdop=hdop)
    if hdop <= 0.0:
        raise MalformedPacket("NMEA GGA", f"HDOP must be > 0, got {hdop}", text)
    sigma = hdop * EPE_BY_QUALITY.get(quality, 10.0)
    status = _STATUS_BY_QUALITY.get(quality, NavSatStatus.STATUS_FIX)
    fix = _fix(lat, lon, alt, status, sigma ** 2, (2.0 * sigma) ** 2,
               NavSatFix.COVARIANCE_TYPE_APPROXIMATED, stamp, frame_id)
    return GnssReading("GGA", fix, hdop=hdop, satellites=sats)


def _rmc(msg: pynmea2.RMC, text: str, stamp: float, frame_id: str) -> GnssReading:
    if msg.status != "A":
        return GnssReading("RMC")
    lat, lon = float(msg.latitude), float(msg.longitude)
    speed = float(msg.spd_over_grnd or 0.0) * KNOT
    course = float(msg.true_course) if msg.true_course is not None else None
    _finite("NMEA RMC", text, latitude=lat, longitude=lon, speed=speed,
            **({"course": course} if course is not None else {}))
    fix = _fix(lat, lon, math.nan, NavSatStatus.STATUS_FIX, 0.0, 0.0,
               NavSatFix.COVARIANCE_TYPE_UNKNOWN, stamp, frame_id)
    return GnssReading("RMC", fix, course, speed)


def decode_ubx(data: bytes, stamp: float = 0.0, frame_id: str = "gps_link") -> GnssReading:
    """Decode one UBX frame (NAV-PVT, NAV-POSLLH, NAV-VELNED) with its checksum."""
    codec = "UBX"
    try:
        msg = UBXReader.parse(data, validate=VALCKSUM, parsebitfield=1)
        ident = msg.identity
        if ident == "NAV-PVT":
            return _nav_pvt(msg, data, stamp, frame_id)
        if ident == "NAV-POSLLH":
            lat, lon, alt = float(msg.lat), float(msg.lon), float(msg.height) / 1000.0
            h, v = float(msg.hAcc) / 1000.0, float(msg.vAcc) / 1000.0
            _finite(codec, data, latitude=lat, longitude=lon, altitude=alt)
            return GnssReading(ident, _fix(lat, lon, alt, NavSatStatus.STATUS_FIX, h * h, v * v,
                                           NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN, stamp,
                                           frame_id))
        if ident == "NAV-VELNED":
            course, speed = float(msg.heading), float(msg.gSpeed) / 100.0  # cm/s
            _finite(codec, data, course=course, speed=speed)
            return GnssReading(ident, None, course % 360.0, speed)
    except MalformedPacket:
        raise
    except Exception as exc:
        raise MalformedPacket(codec, f"{type(exc).__name__}: {exc}", data) from None
    raise MalformedPacket(codec, f"unsupported message {ident!r} (decoded: NAV-PVT, "
                          "NAV-POSLLH, NAV-VELNED)", data)


def _nav_pvt(msg: object, data: bytes, stamp: float, frame_id: str) -> GnssReading:
    get = msg.__getattribute__
    fix_type, ok = int(get("fixType")), bool(get("gnssFixOk"))
    diff = bool(getattr(msg, "diffSoln", getattr(msg, "difSoln", 0)))
    carr = int(getattr(msg, "carrSoln", 0))
    lat, lon, alt = float(get("lat")), float(get("lon")), float(get("height")) / 1000.0
    h, v = float(get("hAcc")) / 1000.0, float(get("vAcc")) / 1000.0
    course, speed = float(get("headMot")) % 360.0, float(get("gSpeed")) / 1000.0
    _finite("UBX NAV-PVT", data, latitude=lat, longitude=lon, altitude=alt, course=course,
            speed=speed)
    if fix_type in (2, 3, 4) and ok:
        status = (NavSatStatus.STATUS_GBAS_FIX if carr else NavSatStatus.STATUS_SBAS_FIX if diff
                  else NavSatStatus.STATUS_FIX)
    else:
        status = NavSatStatus.STATUS_NO_FIX
    fix = _fix(lat, lon, alt, status, h * h, v * v, NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN,
               stamp, frame_id)
    return GnssReading("NAV-PVT", fix, course, speed, satellites=int(get("numSV")))
