"""The two simulated field vehicles: the rover behind its VCU (UDP) and the golf cart
behind its two Arduinos (serial ptys).

* :class:`RoverHil` -- the VCU at a UDP address: decodes the 12-character command
  string, drives the robot with it (skid steer = the simulator's diff-drive base), and
  sends the odometry packet at the profile's odometry rate (track speeds
  ``v -+ w * track / 2`` and yaw rate from the simulated wheel odometry) and the GNSS
  packet at the GNSS rate (from the simulated receiver: position, course and speed
  over ground, its accuracy), both little-endian (:mod:`navstack.drivers.rover_telemetry`).
* :class:`CartHil` -- the Uno on one pty (``'<fi'`` in; :class:`~.firmware.CartUno`
  runs the speed PID and the stepper) and the Mega on another (one ``$CART`` line per
  odometry sample: wheel pulses of the simulated wheel odometry's speed, the mean of
  the IMU readings since the previous line -- read at the profile's IMU rate -- and the
  magnetometer, distorted by the inverse of the calibration the driver applies).

**Same vehicle as in process.**  The firmware drives the simulator's own vehicle
model (acceleration limit, steering slew), and its PID is transparent on it
(:mod:`.firmware`); every sensor is sampled at the instants the in-process simulator
node samples it, so the simulator's random streams are drawn in the same order and a
seed gives the same noise through the wire as in process.  What the wire changes is
only what a wire changes: float32 km/h, whole stepper steps, the line's decimals, and
the odometry the driver dead-reckons from them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from navstack.core.msgs import NavSatStatus, Twist2D
from navstack.drivers.cart_sensors import MAX_LINE
from navstack.drivers.framing import DatagramFramer, FixedFramer, LineFramer
from navstack.drivers.golf_cart import (
    CART_COMMAND,
    decode_cart_command,
    plausible_cart_command,
)
from navstack.drivers.rover_telemetry import (
    STATUS_AUTONOMOUS,
    RoverGnssPacket,
    RoverOdometryPacket,
    encode_rover_gnss,
    encode_rover_odometry,
)
from navstack.drivers.rover_vcu import decode_vcu_command
from navstack.drivers.transport import UdpTransport
from navstack.sim.robot import RobotParams
from navstack.sim.sensors import GRAVITY
from navstack.sim.simulator import Simulator
from navstack.sim.vehicles.bridge import HilVehicle, TelemetrySource
from navstack.sim.vehicles.far_side import FarSide
from navstack.sim.vehicles.firmware import CartMega, CartUno, RoverVcu
from navstack.sim.vehicles.pty import PtyMasterTransport

__all__ = ["CartHil", "RoverHil"]


class RoverHil(HilVehicle):
    """The rover's VCU on UDP (module docstring); ``remote`` is the driver's address."""

    wired = frozenset({"base", "odometry", "gnss"})
    name = "rover VCU"

    def __init__(self, robot: RobotParams, bind: tuple[str, int] = ("127.0.0.1", 0),
                 track_width: float = 0.8) -> None:
        super().__init__()
        self.robot = robot
        self.track_width = track_width
        self.firmware = RoverVcu()
        self.transport = UdpTransport("vcu", bind, None, DatagramFramer())
        self.far_side = FarSide(self.name, {"vcu": self.transport},
                                lambda _link, p: decode_vcu_command(p), self.on_command,
                                ("vcu",))
        self._odom_seq = 0
        self._gnss_seq = 0

    def receive(self, cmd: object, now: float) -> None:
        self.firmware.receive(cmd, now)  # type: ignore[arg-type]

    def actuate(self, sim: Simulator, now: float, dt: float) -> Twist2D | None:
        return self.firmware.output(now)

    def power_off(self) -> None:
        self.firmware.command = None

    def telemetry(self) -> list[TelemetrySource]:
        s = self.robot.sensors
        out = [TelemetrySource("odometry", 1.0 / s.odometry.rate_hz, self._odometry)]
        if s.gnss.enabled:
            out.append(TelemetrySource("gnss", 1.0 / s.gnss.rate_hz, self._gnss))
        return out

    def _odometry(self, sim: Simulator, now: float, dt: float) -> list[tuple[str, bytes]]:
        odom = sim.odom(now)
        if odom is None:
            return []
        v, w = odom.twist.twist.linear.x, odom.twist.twist.angular.z
        half = 0.5 * self.track_width * w
        packet = RoverOdometryPacket(self._odom_seq, round(now * 1000.0), v - half,
                                     v + half, w, 0.0, STATUS_AUTONOMOUS)
        self._odom_seq += 1
        return [("vcu", encode_rover_odometry(packet))]

    def _gnss(self, sim: Simulator, now: float, dt: float) -> list[tuple[str, bytes]]:
        sample = sim.gnss_sample(now)
        if sample is None:
            return []
        fix, vel = sample
        g = self.robot.sensors.gnss
        ok = fix.status.status != NavSatStatus.STATUS_NO_FIX and math.isfinite(fix.latitude)
        course = speed = 0.0
        if vel is not None:
            ve, vn = vel.twist.twist.linear.x, vel.twist.twist.linear.y
            course, speed = math.degrees(math.atan2(ve, vn)) % 360.0, math.hypot(ve, vn)
        packet = RoverGnssPacket(fix.latitude if ok else 0.0, fix.longitude if ok else 0.0,
                                 fix.altitude if ok else 0.0, course, speed,
                                 math.hypot(g.horizontal_noise_std, g.bias_std),
                                 g.vertical_noise_std, 3 if ok else 0, 12 if ok else 0,
                                 self._gnss_seq)
        self._gnss_seq += 1
        return [("vcu", encode_rover_gnss(packet))]


class CartHil(HilVehicle):
    """The golf cart's Uno and Mega on ptys at ``directory/ttyCART_STEERING`` and
    ``directory/ttyCART_SENSORS`` (module docstring)."""

    wired = frozenset({"base", "odometry", "imu", "magnetometer"})
    name = "golf cart Arduinos"

    def __init__(self, robot: RobotParams, directory: Path,
                 accel_calibration: tuple[np.ndarray, np.ndarray] | None = None,
                 mag_calibration: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        super().__init__()
        self.robot = robot
        k = robot.kinematics
        self.steering_path = directory / "ttyCART_STEERING"
        self.sensors_path = directory / "ttyCART_SENSORS"
        self.uno = CartUno(k.wheelbase)
        self.mega = CartMega()
        if accel_calibration is not None:
            self.mega.accel_a, self.mega.accel_b = accel_calibration
        if mag_calibration is not None:
            self.mega.mag_a, self.mega.mag_b = mag_calibration
        self.far_side = FarSide(self.name, {
            "steering": PtyMasterTransport("steering", self.steering_path,
                                           FixedFramer(CART_COMMAND.size,
                                                       plausible_cart_command)),
            "sensors": PtyMasterTransport("sensors", self.sensors_path, LineFramer(MAX_LINE))},
            lambda _link, p: decode_cart_command(p), self.on_command, ("steering",))

    def receive(self, cmd: object, now: float) -> None:
        self.uno.receive(cmd, now)  # type: ignore[arg-type]

    def actuate(self, sim: Simulator, now: float, dt: float) -> Twist2D | None:
        return self.uno.step(now, dt, sim.state.vx)

    def power_off(self) -> None:
        self.uno.command = None

    def telemetry(self) -> list[TelemetrySource]:
        """One stream at the IMU's rate: the Mega reads the MPU9250 every tick (at the
        profile's IMU rate and instants, as the in-process simulator samples it) and
        sends a line with the wheel odometry and the mean of the IMU readings since
        the previous line at the odometry rate."""
        s = self.robot.sensors
        self._line_period = 1.0 / s.odometry.rate_hz
        self._imu_t: float | None = None
        self._line_t: float | None = None
        self._imu_sum = np.zeros(6)
        self._imu_n = 0
        self._imu_last = (0.0, 0.0, 0.0, 0.0, 0.0, GRAVITY)
        rate = max(s.imu.rate_hz, s.odometry.rate_hz) if s.imu.enabled else s.odometry.rate_hz
        return [TelemetrySource("sensors", 1.0 / rate, self._sample)]

    def _sample(self, sim: Simulator, now: float, dt: float) -> list[tuple[str, bytes]]:
        if self._imu_t is None:  # activation: the simulator node reads no IMU then
            self._imu_t = now
        elif sim.imu is not None and now - self._imu_t >= 1.0 / sim.imu.rate_hz - 1e-9:
            imu = sim.imu_sample(now - self._imu_t, now)
            self._imu_t = now
            if imu is not None:
                g, a = imu.angular_velocity, imu.linear_acceleration
                self._imu_sum += (g.x, g.y, g.z, a.x, a.y, a.z)
                self._imu_n += 1
        if self._line_t is not None and now - self._line_t < self._line_period - 1e-9:
            return []
        line_dt = 0.0 if self._line_t is None else now - self._line_t
        self._line_t = now
        if self._imu_n:
            mean = self._imu_sum / self._imu_n
            self._imu_last = tuple(float(v) for v in mean)  # type: ignore[assignment]
            self._imu_sum[:] = 0.0
            self._imu_n = 0
        odom = sim.odom(now)
        speed = odom.twist.twist.linear.x if odom is not None else sim.state.vx
        self.mega.roll(speed, line_dt, now)
        mag = sim.magnetic_field(now)
        mag_ut = (0.0, 0.0, 0.0)
        if mag is not None:
            m = mag.magnetic_field
            mag_ut = (m.x * 1e6, m.y * 1e6, m.z * 1e6)
        gx, gy, gz, ax, ay, az = self._imu_last
        return [("sensors", self.mega.line(now, (ax, ay, az), (gx, gy, gz), mag_ut))]
