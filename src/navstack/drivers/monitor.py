"""Decoding a live link for people: ``navstack link monitor`` prints one line per packet.

:class:`PacketDescriber` frames and decodes a stream with one protocol and turns each
packet into a line of text, or a ``MALFORMED`` line with the reason -- bring-up on a
real vehicle is mostly finding out which bytes come back.

Protocols: ``rover_vcu`` (the 12-character command strings and the VCU's GNSS and
odometry packets, told apart by length), ``golf_cart`` (the ``'<fi'`` command),
``cart_sensors`` (the sensor Arduino's lines), ``gnss`` (NMEA sentences and UBX frames).
"""

from __future__ import annotations

from navstack.core.errors import UnknownNameError
from navstack.drivers import cart_sensors, golf_cart, rover_telemetry, rover_vcu
from navstack.drivers.errors import MalformedPacket
from navstack.drivers.framing import (
    DatagramFramer,
    FixedFramer,
    Framer,
    GnssFramer,
    LineFramer,
)
from navstack.drivers.gnss import GnssReading
from navstack.drivers.vehicles import decode_gnss_packet

__all__ = ["PROTOCOLS", "PacketDescriber"]

PROTOCOLS = ("rover_vcu", "golf_cart", "cart_sensors", "gnss")


class PacketDescriber:
    """Framer + decoder + one-line text for a protocol."""

    def __init__(self, protocol: str, datagrams: bool) -> None:
        if protocol not in PROTOCOLS:
            raise UnknownNameError("link protocol", protocol, PROTOCOLS)
        self.protocol = protocol
        self.datagrams = datagrams
        self.ok = 0
        self.malformed = 0

    def framer(self) -> Framer:
        if self.datagrams:
            return DatagramFramer()
        if self.protocol == "golf_cart":
            return FixedFramer(golf_cart.CART_COMMAND.size, golf_cart.plausible_cart_command)
        if self.protocol == "gnss":
            return GnssFramer()
        return LineFramer(cart_sensors.MAX_LINE if self.protocol == "cart_sensors" else 256)

    def describe(self, packet: bytes) -> str:
        try:
            text = self._describe(packet)
        except MalformedPacket as exc:
            self.malformed += 1
            return f"MALFORMED {exc}"
        self.ok += 1
        return text

    def _describe(self, packet: bytes) -> str:
        p = self.protocol
        if p == "rover_vcu":
            if len(packet) == rover_vcu.VCU_COMMAND_LENGTH:
                c = rover_vcu.decode_vcu_command(packet)
                return (f"VCU command {packet.decode()}: linear_x {c.linear_x:+.3f} m/s, "
                        f"angular_z {c.angular_z:+.2f} rad/s, LED {c.mode}")
            t = rover_telemetry.decode_rover_telemetry(packet)
            if isinstance(t, rover_telemetry.RoverGnssPacket):
                return (f"GNSS #{t.seq}: {t.latitude:.7f}, {t.longitude:.7f}, "
                        f"{t.altitude:.1f} m, COG {t.course_deg:.1f} deg, SOG {t.speed:.2f} "
                        f"m/s, fix type {t.fix_type}, {t.satellites} sats, hAcc "
                        f"{t.h_acc:.2f} m")
            return (f"odometry #{t.seq} t={t.t_ms} ms: tracks {t.left_speed:+.3f} / "
                    f"{t.right_speed:+.3f} m/s, yaw rate {t.yaw_rate:+.3f} rad/s, status "
                    f"{t.status:#04x}" + (" E-STOP" if t.estop else ""))
        if p == "golf_cart":
            cart = golf_cart.decode_cart_command(packet)
            return (f"cart command {packet.hex(' ')}: {cart.speed_kmh:+.2f} km/h "
                    f"({cart.speed:+.3f} m/s), {cart.steps:+d} steps ({cart.steering:+.3f} rad)")
        if p == "cart_sensors":
            s = cart_sensors.parse_sensor_line(packet)
            return (f"sensors #{s.seq} t={s.t_ms} ms: {s.pulses} pulses, v {s.speed:.3f} m/s, "
                    f"accel {s.accel}, gyro {s.gyro}, mag {s.mag_ut} uT")
        r: GnssReading = decode_gnss_packet(packet)
        parts = [r.message]
        if r.fix is not None:
            parts.append(f"{r.fix.latitude:.7f}, {r.fix.longitude:.7f}, {r.fix.altitude:.1f} m, "
                         f"status {r.fix.status.status}, sigma_h "
                         f"{r.fix.position_covariance[0, 0] ** 0.5:.2f} m")
        if r.course_deg is not None:
            parts.append(f"COG {r.course_deg:.1f} deg")
        if r.speed is not None:
            parts.append(f"SOG {r.speed:.2f} m/s")
        return ": ".join(parts[:1]) + (" " + ", ".join(parts[1:]) if parts[1:] else "")
