"""NMEA and UBX decoding on the libraries' own documented examples, into NavSatFix."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyubx2 import GET, UBXMessage

from navstack.core.msgs import NavSatFix, NavSatStatus
from navstack.drivers.errors import MalformedPacket
from navstack.drivers.gnss import KNOT, decode_nmea, decode_ubx, velocity_enu
from navstack.drivers.vehicles import decode_gnss_packet

# pynmea2's README / test suite examples
GGA = "$GPGGA,184353.07,1929.045,S,02410.506,E,1,04,2.6,100.00,M,-33.9,M,,0000*6D"
RMC = "$GPRMC,225446,A,4916.45,N,12311.12,W,000.5,054.7,191194,020.3,E*68"
VTG = "$GPVTG,108.53,T,,M,0.04,N,0.07,K,A*31"
# pyubx2's README example (NAV-VELNED)
VELNED = (b"\xb5b\x01\x12$\x000D\n\x18\xfd\xff\xff\xff\xf1\xff\xff\xff\xfc\xff\xff\xff\x10\x00"
          b"\x00\x00\x0f\x00\x00\x00\x83\xf5\x01\x00A\x00\x00\x00\xf0\xdfz\x00\xd0\xa6")


def _nav_pvt(**over: object) -> bytes:
    """A NAV-PVT built by pyubx2's serializer with the README's NAV-POSLLH figures
    (lat 52.6206345, lon -2.1601284, height 86327 mm, hAcc 38885 mm, vAcc 16557 mm)."""
    fields: dict[str, object] = dict(
        iTOW=403327000, year=2021, month=3, day=2, hour=16, min=1, second=48, validDate=1,
        validTime=1, fixType=3, gnssFixOk=1, numSV=12, lon=-2.1601284, lat=52.6206345,
        height=86327, hMSL=37844, hAcc=38885, vAcc=16557, velN=-3, velE=-15, velD=-4,
        gSpeed=15, headMot=128.387, pDOP=1.5)
    fields.update(over)
    return bytes(UBXMessage("NAV", "NAV-PVT", GET, **fields).serialize())


def test_gga_fix_and_covariance() -> None:
    r = decode_nmea(GGA, stamp=12.5, frame_id="gps")
    fix = r.fix
    assert r.message == "GGA" and fix is not None
    assert fix.header.stamp == 12.5 and fix.header.frame_id == "gps"
    assert fix.latitude == pytest.approx(-(19 + 29.045 / 60))
    assert fix.longitude == pytest.approx(24 + 10.506 / 60)
    assert fix.altitude == pytest.approx(100.0 - 33.9)  # MSL + geoid separation
    assert fix.status.status == NavSatStatus.STATUS_FIX
    # nmea_navsat_driver: sigma_h = HDOP * 4 m for a GPS fix, sigma_v twice that
    assert np.allclose(np.diag(fix.position_covariance), [(2.6 * 4) ** 2] * 2 + [(5.2 * 4) ** 2])
    assert fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_APPROXIMATED
    assert (r.hdop, r.satellites) == (2.6, 4)


def test_gga_quality_maps_status_and_error() -> None:
    from navstack.drivers.cart_sensors import nmea_checksum

    def gga(quality: int) -> str:
        body = f"GPGGA,184353.07,1929.045,S,02410.506,E,{quality},04,2.6,100.00,M,-33.9,M,,0000"
        return f"${body}*{nmea_checksum(body)}"

    rtk = decode_nmea(gga(4)).fix
    assert rtk is not None and rtk.status.status == NavSatStatus.STATUS_GBAS_FIX
    assert rtk.position_covariance[0, 0] == pytest.approx((2.6 * 0.02) ** 2)
    dgps = decode_nmea(gga(2)).fix
    assert dgps is not None and dgps.status.status == NavSatStatus.STATUS_SBAS_FIX
    none = decode_nmea(gga(0)).fix
    assert none is not None and none.status.status == NavSatStatus.STATUS_NO_FIX
    assert math.isnan(none.latitude)


def test_rmc_and_vtg_velocity() -> None:
    r = decode_nmea(RMC)
    assert r.course_deg == pytest.approx(54.7) and r.speed == pytest.approx(0.5 * KNOT)
    assert r.fix is not None and r.fix.latitude == pytest.approx(49.274166666666666)
    assert r.fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN
    v = decode_nmea(VTG.encode())
    assert v.fix is None and v.course_deg == pytest.approx(108.53)
    assert v.speed == pytest.approx(0.07 / 3.6)
    e, n = velocity_enu(90.0, 2.0)
    assert (e, n) == pytest.approx((2.0, 0.0))


def test_rmc_void_carries_nothing() -> None:
    r = decode_nmea("$GPRMC,123519.00,V,4807.038,N,01131.000,E,,,230394,,*24")
    assert r.fix is None and r.course_deg is None


def test_ubx_nav_pvt() -> None:
    r = decode_ubx(_nav_pvt(), stamp=3.0)
    fix = r.fix
    assert r.message == "NAV-PVT" and fix is not None
    assert (fix.latitude, fix.longitude) == pytest.approx((52.6206345, -2.1601284))
    assert fix.altitude == pytest.approx(86.327)
    assert np.allclose(np.diag(fix.position_covariance), [38.885 ** 2, 38.885 ** 2, 16.557 ** 2])
    assert fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    assert fix.status.status == NavSatStatus.STATUS_FIX
    assert r.course_deg == pytest.approx(128.387) and r.speed == pytest.approx(0.015)
    assert r.satellites == 12
    rtk = decode_ubx(_nav_pvt(carrSoln=2)).fix
    assert rtk is not None and rtk.status.status == NavSatStatus.STATUS_GBAS_FIX
    sbas = decode_ubx(_nav_pvt(diffSoln=1)).fix
    assert sbas is not None and sbas.status.status == NavSatStatus.STATUS_SBAS_FIX
    no_fix = decode_ubx(_nav_pvt(fixType=0, gnssFixOk=0)).fix
    assert no_fix is not None and no_fix.status.status == NavSatStatus.STATUS_NO_FIX


def test_ubx_velned_readme_example() -> None:
    r = decode_ubx(VELNED)
    assert r.message == "NAV-VELNED" and r.fix is None
    assert r.course_deg == pytest.approx(1.28387) and r.speed == pytest.approx(0.15)


def test_auto_protocol_dispatch() -> None:
    assert decode_gnss_packet(_nav_pvt()).message == "NAV-PVT"
    assert decode_gnss_packet(GGA.encode() + b"\r\n").message == "GGA"


@pytest.mark.parametrize(("data", "reason"), [
    (GGA.replace("*6D", "*6E"), "ChecksumError"),
    (GGA.replace("*6D", ""), "checksum missing"),
    ("$GPGSV,3,1,11,03,03,111,00,04,15,270,00,06,01,010,00,13,06,292,00*74", "GSV"),
    ("garbage", "ParseError"),
    (b"\xff\xfe$GPGGA", "UnicodeDecodeError"),
])
def test_nmea_rejects(data: str | bytes, reason: str) -> None:
    with pytest.raises(MalformedPacket, match=reason):
        decode_nmea(data)


def test_ubx_rejects() -> None:
    bad = bytearray(_nav_pvt())
    bad[30] ^= 0x40
    with pytest.raises(MalformedPacket, match="UBX"):
        decode_ubx(bytes(bad))
    with pytest.raises(MalformedPacket, match="UBX"):
        decode_ubx(_nav_pvt()[:50])
    ack = b"\xb5b\x05\x01\x02\x00\x06\x01\x0f\x38"  # pyubx2 README: ACK-ACK
    with pytest.raises(MalformedPacket, match="unsupported message 'ACK-ACK'"):
        decode_ubx(ack)
