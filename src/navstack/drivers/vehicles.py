"""Per-vehicle protocol adapters: a twist in, packets out; packets in, telemetry out.

Pure (no bus, no I/O): :class:`VehicleProtocol` knows which links a vehicle has, how to
frame each, how to encode a command and a stop, and how to turn a received packet into
telemetry records -- :class:`WheelOdometry`, :class:`ImuSample`, :class:`GnssReading`,
:class:`VehicleState`.  The driver node (:mod:`navstack.nodes.vehicle_driver`) moves the
bytes and publishes the records; ``navstack link monitor`` prints them.

* :class:`RoverVcuProtocol` -- link ``vcu`` (UDP): the 12-character command string out;
  GNSS and odometry packets in (:mod:`.rover_telemetry`).  Skid steer: forward speed is
  the mean of the track speeds, the yaw rate the VCU's gyro.
* :class:`GolfCartProtocol` -- link ``steering`` (serial, ``'<fi'`` out), link
  ``sensors`` (serial, ``$CART`` lines in): the speed is the Arduino's wheel speed signed
  with the last commanded direction (the pulse sensor has no direction), the yaw rate the
  calibrated gyro's z axis.
* A ``gnss`` link (either vehicle) carries NMEA or UBX from a receiver (:mod:`.gnss`).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from navstack.core.msgs import Header, NavSatFix, NavSatStatus
from navstack.drivers import cart_sensors, golf_cart, rover_telemetry, rover_vcu
from navstack.drivers.config import AffineCalibration, LinkParams, VehicleConfig
from navstack.drivers.framing import (
    DatagramFramer,
    FixedFramer,
    Framer,
    GnssFramer,
    LineFramer,
)
from navstack.drivers.gnss import GnssReading, decode_nmea, decode_ubx

__all__ = ["GnssReading", "GolfCartProtocol", "ImuSample", "RoverVcuProtocol", "Telemetry",
           "VehicleProtocol", "VehicleState", "WheelOdometry", "decode_gnss_packet",
           "make_protocol", "rover_gnss_reading"]


@dataclass(frozen=True, slots=True)
class WheelOdometry:
    """Body velocity from the wheels (and the vehicle's gyro, when it has one)."""

    t_device: float | None
    """The vehicle's own clock [s] (VCU / Arduino millis), ``None`` if not sent."""
    speed: float
    yaw_rate: float | None
    wheel_speeds: dict[str, float] = field(default_factory=dict)
    """Joint name -> angular velocity [rad/s]."""


@dataclass(frozen=True, slots=True)
class ImuSample:
    t_device: float | None
    accel: tuple[float, float, float]
    gyro: tuple[float, float, float]
    mag_tesla: tuple[float, float, float] | None


@dataclass(frozen=True, slots=True)
class VehicleState:
    estop: bool
    autonomous: bool
    fault: bool


Telemetry = WheelOdometry | ImuSample | GnssReading | VehicleState


def decode_gnss_packet(packet: bytes, protocol: str = "auto", frame_id: str = "gps_link"
                       ) -> GnssReading:
    """NMEA sentence or UBX frame, chosen by ``protocol`` or by the first byte."""
    if protocol == "ubx" or (protocol == "auto" and packet[:2] == b"\xb5\x62"):
        return decode_ubx(packet, frame_id=frame_id)
    return decode_nmea(packet, frame_id=frame_id)


def rover_gnss_reading(p: rover_telemetry.RoverGnssPacket, frame_id: str = "gps_link"
                       ) -> GnssReading:
    """The rover's GNSS packet as a NavSatFix (diagonal covariance from the accuracies)."""
    has_fix = p.fix_type in (2, 3, 4)
    status = NavSatStatus.STATUS_FIX if has_fix else NavSatStatus.STATUS_NO_FIX
    fix = NavSatFix(Header(0.0, frame_id), NavSatStatus(status, NavSatStatus.SERVICE_GPS),
                    p.latitude, p.longitude, p.altitude,
                    np.diag([p.h_acc ** 2, p.h_acc ** 2, p.v_acc ** 2]),
                    NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN)
    return GnssReading("ROVER-GNSS", fix, p.course_deg if has_fix else None,
                       p.speed if has_fix else None, satellites=p.satellites)


class VehicleProtocol(ABC):
    """Links, framing, commands and decoding of one vehicle type."""

    command_link: str

    def __init__(self, config: VehicleConfig) -> None:
        self.config = config

    @property
    def links(self) -> dict[str, LinkParams]:
        return self.config.links

    def framer(self, link: str) -> Framer:
        if link == "gnss":
            return GnssFramer()
        return self._framer(link)

    def decode(self, link: str, packet: bytes) -> list[Telemetry]:
        """Telemetry in ``packet``; :class:`MalformedPacket` if it does not decode."""
        if link == "gnss":
            return [decode_gnss_packet(packet, self.links["gnss"].protocol,
                                       self.config.frames.gps_frame)]
        return self._decode(link, packet)

    @abstractmethod
    def _framer(self, link: str) -> Framer: ...

    @abstractmethod
    def _decode(self, link: str, packet: bytes) -> list[Telemetry]: ...

    @abstractmethod
    def command(self, vx: float, wz: float) -> bytes:
        """The packet for the body twist (on :attr:`command_link`)."""

    @abstractmethod
    def stop(self) -> bytes:
        """The packet that stops the vehicle."""

    @abstractmethod
    def decode_command(self, packet: bytes) -> tuple[float, float]:
        """(vx, wz) a command packet stands for (for logs and ``link monitor``)."""


class RoverVcuProtocol(VehicleProtocol):
    command_link = "vcu"

    def _framer(self, link: str) -> Framer:
        return DatagramFramer()

    def command(self, vx: float, wz: float) -> bytes:
        c = self.config.command
        return rover_vcu.encode_vcu_command(vx, wz, c.mode, compat=c.compat)

    def stop(self) -> bytes:
        return rover_vcu.encode_vcu_command(0.0, 0.0, self.config.command.mode)

    def decode_command(self, packet: bytes) -> tuple[float, float]:
        cmd = rover_vcu.decode_vcu_command(packet)
        return cmd.linear_x, cmd.angular_z

    def _decode(self, link: str, packet: bytes) -> list[Telemetry]:
        p = rover_telemetry.decode_rover_telemetry(packet)
        if isinstance(p, rover_telemetry.RoverGnssPacket):
            return [rover_gnss_reading(p, self.config.frames.gps_frame)]
        r = self.config.geometry.wheel_radius
        return [WheelOdometry(p.t_ms / 1000.0, 0.5 * (p.left_speed + p.right_speed), p.yaw_rate,
                              {"left_wheel_joint": p.left_speed / r,
                               "right_wheel_joint": p.right_speed / r}),
                VehicleState(p.estop, bool(p.status & rover_telemetry.STATUS_AUTONOMOUS),
                             bool(p.status & rover_telemetry.STATUS_MOTOR_FAULT))]


def _apply(cal: AffineCalibration, values: tuple[float, float, float]
           ) -> tuple[float, float, float]:
    if cal.is_identity:
        return values
    x, y, z = cart_sensors.calibrate(values, cal.A, cal.b)
    return float(x), float(y), float(z)


class GolfCartProtocol(VehicleProtocol):
    command_link = "steering"

    def __init__(self, config: VehicleConfig) -> None:
        super().__init__(config)
        self._direction = 1.0

    def _framer(self, link: str) -> Framer:
        if link == "steering":
            return FixedFramer(golf_cart.CART_COMMAND.size, golf_cart.plausible_cart_command)
        return LineFramer(cart_sensors.MAX_LINE)

    def command(self, vx: float, wz: float) -> bytes:
        g, c = self.config.geometry, self.config.command
        delta = golf_cart.cart_steering(vx, wz, g.wheel_base, g.wheel_separation,
                                        c.steering_mode)
        if vx != 0.0:
            self._direction = math.copysign(1.0, vx)
        return golf_cart.encode_cart_command(vx, delta)

    def stop(self) -> bytes:
        return golf_cart.STOP_PACKET

    def decode_command(self, packet: bytes) -> tuple[float, float]:
        cmd = golf_cart.decode_cart_command(packet)
        wz = cmd.speed * math.tan(cmd.steering) / self.config.geometry.wheel_base
        return cmd.speed, wz

    def _decode(self, link: str, packet: bytes) -> list[Telemetry]:
        if link == "steering":  # the Uno sends nothing back; echo for monitors
            vx, wz = self.decode_command(packet)
            return [WheelOdometry(None, vx, wz)]
        s = cart_sensors.parse_sensor_line(packet)
        cal = self.config.imu_calibration
        accel = _apply(cal.accel, s.accel)
        mag = _apply(cal.mag, s.mag_ut)
        t = s.t_ms / 1000.0
        speed = self._direction * s.speed
        wheel = speed / cart_sensors.WHEEL_RADIUS
        return [WheelOdometry(t, speed, s.gyro[2], {"rear_wheel_joint": wheel}),
                ImuSample(t, accel, s.gyro, (mag[0] * 1e-6, mag[1] * 1e-6, mag[2] * 1e-6))]


def make_protocol(config: VehicleConfig) -> VehicleProtocol:
    """The adapter for ``config.type``."""
    if config.type == "rover_vcu":
        return RoverVcuProtocol(config)
    return GolfCartProtocol(config)
