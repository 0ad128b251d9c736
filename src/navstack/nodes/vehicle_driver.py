"""``VehicleDriverNode``: a vehicle link on the bus (``/cmd_vel`` in; odometry, IMU, GNSS,
wheel speeds and status out).

The wire work is in :mod:`navstack.drivers` (codecs, transports, the watchdog); this node
only moves messages, on the runtime's clock (simulated time in simulation, the wall
clock on hardware):

* ``/cmd_vel`` (Twist) -> the vehicle's command packet, sent at once and then repeated
  at ``command.rate_hz`` (the VCU / Arduino sees a steady stream, as twist_mux gives
  it).  A command older than ``command.timeout`` becomes zero; a NaN/inf command is
  refused and counted.  While the link is lost the stop packet is sent instead.
* Received packets are read by one thread per link, queued with their wall time, and
  drained every ``1 / poll_rate_hz`` (or by :meth:`poll`): decoded by the vehicle's
  protocol; a packet that does not decode is counted per link and codec (never raised).
* Wheel odometry -> ``/odom`` (nav_msgs/Odometry, dead-reckoned: heading from the yaw
  rate, position along the arc) and ``odom -> base_link`` on ``/tf``; wheel speeds ->
  ``/joint_states``; IMU -> ``/imu`` (no orientation: covariance[0] = -1) and
  ``/imu/mag``; GNSS -> ``/gps/fix`` (NavSatFix) and ``/gps/vel`` (ENU velocity from
  course and speed over ground).  Everything is stamped with the node's clock on arrival.
* The watchdog watches the telemetry link (rover ``vcu``, cart ``sensors``): silent for
  ``watchdog.timeout`` -> "link lost": stop packets, status ERROR, and a
  :class:`~navstack.core.msgs.NavigationHold` on ``/navigation/hold`` so navigation
  pauses; ``restore_count`` good packets in a row -> released, navigation resumes.
* ``/vehicle/status`` (DiagnosticStatus) every ``status_period`` and on each change:
  level, "link ok" / "link lost: ...", and per link packets, rates, malformed counts,
  I/O errors, reconnects and last-seen age.

``transports`` may be given (tests, the hardware-in-the-loop harness); otherwise they
are built from the vehicle YAML's links.  ``command_listeners`` are told of every packet
written (wall time of the command, bytes) -- the latency benchmark uses it.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from navstack.core.msgs import (
    DiagnosticStatus,
    Header,
    Imu,
    JointState,
    KeyValue,
    MagneticField,
    NavigationHold,
    NavSatFix,
    Odometry,
    Pose2D,
    PoseWithCovariance,
    Quaternion,
    TFMessage,
    Transform,
    TransformStamped,
    Twist,
    TwistWithCovariance,
    TwistWithCovarianceStamped,
    Vector3,
)
from navstack.drivers.config import LinkParams, VehicleConfig
from navstack.drivers.errors import EncodeError, MalformedPacket
from navstack.drivers.framing import Framer
from navstack.drivers.gnss import GnssReading, velocity_enu
from navstack.drivers.odometry import DeadReckoning
from navstack.drivers.transport import (
    Backoff,
    LinkReader,
    SerialTransport,
    Transport,
    UdpTransport,
    parse_endpoint,
)
from navstack.drivers.vehicles import (
    ImuSample,
    Telemetry,
    VehicleProtocol,
    VehicleState,
    WheelOdometry,
    make_protocol,
)
from navstack.drivers.watchdog import LinkWatchdog
from navstack.runtime.bus import LATCHED, SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime

__all__ = ["VehicleDriverNode", "build_transport"]

TELEMETRY_LINK = {"rover_vcu": "vcu", "golf_cart": "sensors"}
CommandListener = Callable[[bytes, float], None]


def build_transport(name: str, link: LinkParams, framer: Framer) -> Transport:
    """The transport a vehicle YAML's link describes (not opened yet)."""
    backoff = Backoff(link.reconnect_initial, link.reconnect_max)
    if link.type == "udp":
        assert link.bind is not None
        remote = parse_endpoint(link.remote, f"links.{name}.remote") if link.remote else None
        return UdpTransport(name, parse_endpoint(link.bind, f"links.{name}.bind"), remote,
                            framer, backoff)
    assert link.port is not None
    return SerialTransport(name, link.port, link.baudrate, framer, backoff)


@dataclass
class _Command:
    vx: float = 0.0
    wz: float = 0.0
    t: float = -math.inf
    wall: float = 0.0
    """``time.perf_counter()`` when it arrived."""


class VehicleDriverNode(Node):
    """See module docstring."""

    def __init__(self, runtime: Runtime, config: VehicleConfig,
                 transports: Mapping[str, Transport] | None = None,
                 name: str = "vehicle_driver", threaded: bool = True) -> None:
        super().__init__(name, runtime)
        self.config = config
        self.protocol: VehicleProtocol = make_protocol(config)
        self.transports: dict[str, Transport] = dict(transports) if transports is not None else {
            n: build_transport(n, p, self.protocol.framer(n)) for n, p in config.links.items()}
        self.telemetry_link = TELEMETRY_LINK[config.type]
        self.threaded = threaded
        self._inbox: deque[tuple[str, bytes, float]] = deque()
        self.packets_queued: dict[str, int] = dict.fromkeys(self.transports, 0)
        """Packets each link's reader has queued so far (the lock-step harness waits on it)."""
        self._readers = {n: LinkReader(t, self._sink(n)) for n, t in self.transports.items()}
        w = config.watchdog
        self.watchdog = LinkWatchdog(w.timeout, w.restore_count)
        self.odometry = DeadReckoning()
        self._odom_t_device: float | None = None
        self._odom_t: float | None = None
        self._wheel_positions: dict[str, float] = {}
        self._cmd = _Command()
        self._last_send = -math.inf
        self.command_listeners: list[CommandListener] = []
        self.rejected_commands = 0
        self.commands_sent = 0
        self.stops_sent = 0
        self.telemetry_count: dict[str, int] = {}
        self.vehicle_state: VehicleState | None = None
        self.status_message = "starting"
        self.last_gnss: GnssReading | None = None

    # --- lifecycle -----------------------------------------------------------------------
    def on_configure(self) -> None:
        c = self.config
        self.pub_odom = self.create_publisher("/odom", Odometry, QoS(depth=10))
        self.pub_tf = self.create_publisher("/tf", TFMessage, QoS(depth=100))
        self.pub_imu = self.create_publisher("/imu", Imu, SENSOR_DATA)
        self.pub_mag = self.create_publisher("/imu/mag", MagneticField, SENSOR_DATA)
        self.pub_fix = self.create_publisher("/gps/fix", NavSatFix, SENSOR_DATA)
        self.pub_gps_vel = self.create_publisher("/gps/vel", TwistWithCovarianceStamped,
                                                 SENSOR_DATA)
        self.pub_joints = self.create_publisher("/joint_states", JointState, SENSOR_DATA)
        self.pub_status = self.create_publisher("/vehicle/status", DiagnosticStatus,
                                                QoS(depth=10))
        self.pub_hold = self.create_publisher(c.watchdog.hold_topic, NavigationHold, LATCHED)
        self.create_subscription(c.command.topic, Twist, self._on_cmd, QoS(depth=1))
        self.create_timer(1.0 / c.command.rate_hz, self._on_rate)
        self.create_timer(1.0 / c.poll_rate_hz, self.poll)
        self.create_timer(c.status_period, self._publish_status)

    def on_activate(self) -> None:
        for transport in self.transports.values():
            try:
                transport.open()
            except Exception as exc:  # logged; the back-off retries it
                transport.stats.io_error(str(exc))
                self.log.warning("%s", exc)
            if self.threaded:
                self._readers[transport.name].start()
        self.watchdog.start(self.now)
        self._publish_status()

    def on_deactivate(self) -> None:
        self._write(self.protocol.stop(), self.now, time.perf_counter(), stop=True)
        for reader in self._readers.values():
            reader.stop()

    def on_shutdown(self) -> None:
        for reader in self._readers.values():
            reader.stop()
        for transport in self.transports.values():
            transport.close()

    # --- commands ------------------------------------------------------------------------
    def _on_cmd(self, msg: Twist) -> None:
        vx, wz = msg.linear.x, msg.angular.z
        if not (math.isfinite(vx) and math.isfinite(wz)):
            self.rejected_commands += 1
            self.log.warning("rejected %s: non-finite (vx=%s, wz=%s)", self.config.command.topic,
                             vx, wz)
            return
        wall = time.perf_counter()
        self._cmd = _Command(vx, wz, self.now, wall)
        if self.config.command.send_on_update:
            self.send_command(wall)

    def _on_rate(self) -> None:
        period = 1.0 / self.config.command.rate_hz
        if self.now - self._last_send >= period - 1e-9:
            self.send_command()

    def send_command(self, wall: float | None = None) -> None:
        """Send the current command (zero if stale, the stop packet while the link is lost).

        ``wall``: when the command arrived (``time.perf_counter``), for the latency
        listeners; a repeat of an older command counts from now."""
        now, cmd = self.now, self._cmd
        wall = time.perf_counter() if wall is None else wall
        if self.watchdog.lost:
            self._write(self.protocol.stop(), now, wall, stop=True)
            return
        fresh = now - cmd.t <= self.config.command.timeout
        vx, wz = (cmd.vx, cmd.wz) if fresh else (0.0, 0.0)
        try:
            packet = self.protocol.command(vx, wz)
        except EncodeError as exc:
            self.rejected_commands += 1
            self.log.warning("%s", exc)
            return
        self._write(packet, now, wall, stop=False)

    def _write(self, packet: bytes, now: float, wall: float, stop: bool) -> None:
        transport = self.transports.get(self.protocol.command_link)
        if transport is None:
            return
        self._last_send = now
        if transport.write(packet):
            self.commands_sent += 1
            self.stops_sent += int(stop)
            for listener in self.command_listeners:
                listener(packet, wall)

    @property
    def last_command(self) -> tuple[float, float, float]:
        """(vx, wz, time) of the last accepted ``/cmd_vel``."""
        return self._cmd.vx, self._cmd.wz, self._cmd.t

    # --- telemetry -----------------------------------------------------------------------
    def _sink(self, link: str) -> Callable[[list[bytes], float], None]:
        def push(packets: list[bytes], wall: float) -> None:
            for p in packets:
                self._inbox.append((link, p, wall))
            self.packets_queued[link] = self.packets_queued.get(link, 0) + len(packets)
        return push

    def read_now(self, timeout: float = 0.0) -> int:
        """Poll every transport once on this thread (when no reader threads run)."""
        n = 0
        for name, transport in self.transports.items():
            packets = transport.poll(timeout)
            self._sink(name)(packets, time.monotonic())
            n += len(packets)
        return n

    def poll(self) -> None:
        """Decode and publish everything received; run the watchdog."""
        if not self.threaded:
            self.read_now()
        now = self.now
        while self._inbox:
            link, packet, _ = self._inbox.popleft()
            try:
                records = self.protocol.decode(link, packet)
            except MalformedPacket as exc:
                self.transports[link].stats.bad_packet(exc)
                continue
            if link == self.telemetry_link:
                self.watchdog.feed(now)
            for record in records:
                self._publish(record, now)
        event = self.watchdog.check(now)
        if event == "lost":
            silence = self.watchdog.silence(now)
            self.status_message = (f"link lost: no valid packet on '{self.telemetry_link}' for "
                                   f"{silence:.2f} s")
            self.log.warning("%s: %s", self.config.name or self.config.type, self.status_message)
            self.pub_hold.publish(NavigationHold(True, self.name, self.status_message, now))
            self.send_command()
            self._publish_status()
        elif event == "restored":
            self.status_message = "link ok"
            self.pub_hold.publish(NavigationHold(False, self.name, "link restored", now))
            self._publish_status()
        elif self.status_message == "starting" and self.watchdog.last_valid is not None:
            self.status_message = "link ok"

    def _publish(self, record: Telemetry, now: float) -> None:
        kind = type(record).__name__
        self.telemetry_count[kind] = self.telemetry_count.get(kind, 0) + 1
        if isinstance(record, WheelOdometry):
            self._odometry(record, now)
        elif isinstance(record, ImuSample):
            self._imu(record, now)
        elif isinstance(record, GnssReading):
            self._gnss(record, now)
        else:
            self.vehicle_state = record

    def _odometry(self, r: WheelOdometry, now: float) -> None:
        f = self.config.frames
        if r.t_device is None:  # the command link's echo: nothing measured
            return
        dt = 0.0
        if self._odom_t_device is not None:
            dt = r.t_device - self._odom_t_device
            if not 0.0 < dt < 1.0:  # device reboot / wrap: fall back to the node's clock
                dt = now - (self._odom_t if self._odom_t is not None else now)
        self._odom_t_device, self._odom_t = r.t_device, now
        w = r.yaw_rate if r.yaw_rate is not None else 0.0
        self.odometry.update(r.speed, w, dt)
        o = self.odometry
        pose = Pose2D(o.x, o.y, o.yaw)
        cov = np.diag([1e-3 + 1e-3 * o.distance, 1e-3 + 1e-3 * o.distance, 1e6, 1e6, 1e6,
                       1e-3 + 1e-3 * o.distance])
        twist_cov = np.diag([1e-2, 1e-4, 1e6, 1e6, 1e6, 1e-3])
        self.pub_odom.publish(Odometry(Header(now, f.odom_frame), f.base_frame,
                                       PoseWithCovariance(pose.to_pose(), cov),
                                       TwistWithCovariance(Twist.planar(r.speed, 0.0, w),
                                                           twist_cov)))
        if f.publish_tf:
            self.pub_tf.publish(TFMessage((TransformStamped(
                Header(now, f.odom_frame), f.base_frame, Transform.from_pose2d(pose)),)))
        if r.wheel_speeds:
            names = tuple(r.wheel_speeds)
            for n in names:
                self._wheel_positions[n] = self._wheel_positions.get(n, 0.0) + \
                    r.wheel_speeds[n] * dt
            self.pub_joints.publish(JointState(Header(now, f.base_frame), names,
                                               tuple(self._wheel_positions[n] for n in names),
                                               tuple(r.wheel_speeds[n] for n in names)))

    def _imu(self, s: ImuSample, now: float) -> None:
        frame = self.config.frames.imu_frame
        no_orientation = np.zeros((3, 3))
        no_orientation[0, 0] = -1.0
        self.pub_imu.publish(Imu(Header(now, frame), Quaternion(), no_orientation,
                                 Vector3(*s.gyro), np.eye(3) * 1e-5, Vector3(*s.accel),
                                 np.eye(3) * 1e-2))
        if s.mag_tesla is not None:
            self.pub_mag.publish(MagneticField(Header(now, frame), Vector3(*s.mag_tesla),
                                               np.eye(3) * 1e-14))

    def _gnss(self, r: GnssReading, now: float) -> None:
        self.last_gnss = r
        frame = self.config.frames.gps_frame
        if r.fix is not None and r.message != "RMC":  # RMC has no accuracy: GGA / UBX win
            f = r.fix
            self.pub_fix.publish(NavSatFix(Header(now, frame), f.status, f.latitude,
                                           f.longitude, f.altitude, f.position_covariance,
                                           f.position_covariance_type))
        if r.course_deg is not None and r.speed is not None:
            ve, vn = velocity_enu(r.course_deg, r.speed)
            self.pub_gps_vel.publish(TwistWithCovarianceStamped(
                Header(now, frame), TwistWithCovariance(Twist.planar(ve, vn, 0.0),
                                                        np.diag([0.01, 0.01, 1e6, 1e6, 1e6,
                                                                 1e6]))))

    # --- status --------------------------------------------------------------------------
    def link_stats(self) -> dict[str, dict[str, object]]:
        return {n: t.stats.snapshot() for n, t in self.transports.items()}

    def _publish_status(self) -> None:
        lost = self.watchdog.lost
        level = DiagnosticStatus.ERROR if lost else (
            DiagnosticStatus.WARN if self.watchdog.last_valid is None else DiagnosticStatus.OK)
        values = [KeyValue("link_lost", str(lost).lower()),
                  KeyValue("commands_sent", str(self.commands_sent)),
                  KeyValue("rejected_commands", str(self.rejected_commands))]
        for name, s in self.link_stats().items():
            age = s["last_rx_age"]
            values += [KeyValue(f"{name}.{k}", f"{v:.2f}" if isinstance(v, float) else str(v))
                       for k, v in s.items() if k not in ("link", "last_rx_age",
                                                          "malformed_by_codec")]
            values.append(KeyValue(f"{name}.last_rx_age",
                                   "never" if age is None else f"{age:.3f}"))
        if self.vehicle_state is not None:
            values.append(KeyValue("estop", str(self.vehicle_state.estop).lower()))
        self.pub_status.publish(DiagnosticStatus(level, f"{self.name}: {self.config.type}",
                                                 self.status_message,
                                                 self.config.name or self.config.type,
                                                 tuple(values)))
