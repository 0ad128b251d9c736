"""``SimulatorNode``: the simulator on the bus.

Physics is event-driven: whenever something observes or commands the robot (a sensor
sample, a ``/cmd_vel`` message) the simulation first advances to ``now`` in steps of at
most ``1 / physics_rate_hz``.  The trajectory is the same as with a fixed-rate physics
timer (exact arc integration, collision checks every step) at a fraction of the events.

Subscribes ``/cmd_vel`` (Twist, body frame); publishes ``/clock``, ``/odom``
(nav_msgs/Odometry, odom -> base_link), ``/tf`` (odom -> base_link at the odometry
rate, and map -> odom when ``perfect_localization`` is on so navigation can run before
localization exists: at 10 Hz, future-dated by 0.1 s as AMCL's ``transform_tolerance``
does), ``/tf_static`` (base_link -> sensor frames), ``/scan``, ``/imu``, ``/ground_truth``, the
3-D lidar's PointCloud2 when the profile enables one (``/velodyne_points``),
(the true pose in ``map``), and when enabled ``/gps/fix`` (NavSatFix), ``/gps/vel`` (ENU
velocity, TwistWithCovarianceStamped) and ``/imu/mag`` (MagneticField) -- topic names
from the profile.  Each sensor runs on its own timer at its configured rate.

``wired`` names the parts that talk to the stack through a vehicle link instead
(hardware-in-the-loop: :mod:`navstack.sim.vehicles`): ``"base"`` -- the robot takes its
motion from the simulated vehicle's firmware, not from ``/cmd_vel``; ``"odometry"``,
``"imu"``, ``"gnss"``, ``"magnetometer"`` -- the vehicle samples them and sends them over
the wire, so the node does not publish them (nor, without its own odometry,
``odom -> base_link`` or the perfect ``map -> odom``).  Static mounts are still published.
"""

from __future__ import annotations

from collections.abc import Collection

from navstack.core.msgs import (
    Clock,
    Header,
    Imu,
    LaserScan,
    MagneticField,
    Marker,
    MarkerArray,
    NavSatFix,
    Odometry,
    Point,
    PointCloud2,
    Pose,
    Pose2D,
    TFMessage,
    Transform,
    TransformStamped,
    Twist,
    TwistWithCovarianceStamped,
    Vector3,
)
from navstack.core.msgs.geometry_msgs import Quaternion
from navstack.runtime.bus import SENSOR_DATA, QoS
from navstack.runtime.node import Node, Runtime
from navstack.sim.fleet import FleetSimulator
from navstack.sim.simulator import Simulator

OBSTACLES_PERIOD = 0.1
"""Period [s] of ``/sim/obstacles`` (the demo samples clearance at this period too)."""


class SimulatorNode(Node):
    """Runs :class:`Simulator` physics at ``physics_rate_hz`` and publishes its sensors."""

    def __init__(self, runtime: Runtime, sim: Simulator, physics_rate_hz: float = 50.0,
                 perfect_localization: bool = True, name: str = "simulator",
                 wired: Collection[str] = ()) -> None:
        super().__init__(name, runtime)
        unknown = set(wired) - WIRED_PARTS
        if unknown:
            raise ValueError(f"wired: unknown {sorted(unknown)}; choose from "
                             f"{sorted(WIRED_PARTS)}")
        self.wired = frozenset(wired)
        self.sim = sim
        self.physics_dt = 1.0 / physics_rate_hz
        self.perfect_localization = perfect_localization
        self.clock_period = 0.1  # /clock for recorders; in-process nodes use the scheduler
        self._last_clock_t = -1.0
        self.map_odom_period = 0.1
        self.map_odom_tolerance = 0.1
        self._next_map_odom_t = 0.0  # elapsed seconds (scheduler.elapsed)
        self._physics_el: float | None = None
        self._last_imu_t = 0.0
        self._odom_after_imu = False
        self._odom_pose = Pose2D()
        self.scans_published = 0
        self.odom_published = 0

    def on_configure(self) -> None:
        self.pub_clock = self.create_publisher("/clock", Clock, QoS(depth=1))
        self.pub_odom = self.create_publisher("/odom", Odometry, QoS(depth=10))
        self.pub_tf = self.create_publisher("/tf", TFMessage, QoS(depth=100))
        self.pub_tf_static = self.create_publisher("/tf_static", TFMessage,
                                                   QoS(depth=1, latched=True))
        self.pub_scan = self.create_publisher("/scan", LaserScan, SENSOR_DATA)
        self.pub_imu = self.create_publisher("/imu", Imu, SENSOR_DATA)
        self.pub_truth = self.create_publisher("/ground_truth", Odometry, QoS(depth=10))
        if "base" not in self.wired:
            self.create_subscription("/cmd_vel", Twist, self._on_cmd, QoS(depth=1))
        sensors = self.sim.robot.sensors
        if self.sim.lidar is not None:
            self.create_timer(1.0 / sensors.lidar.rate_hz, self._scan)
        if self.sim.lidar3d is not None:
            self.pub_cloud = self.create_publisher(_topic(sensors.lidar3d.topic), PointCloud2,
                                                   SENSOR_DATA)
            self.create_timer(1.0 / sensors.lidar3d.rate_hz, self._cloud)
        if self.sim.odometry is not None and "odometry" not in self.wired:
            self.create_timer(1.0 / sensors.odometry.rate_hz, self._odom)
        if self.sim.imu is not None and "imu" not in self.wired:
            self.create_timer(1.0 / sensors.imu.rate_hz, self._imu)
        if sensors.ground_truth.enabled:
            self.create_timer(1.0 / sensors.ground_truth.rate_hz, self._truth)
            self.pub_footprint = self.create_publisher("/sim/footprint", Marker,
                                                       QoS(depth=1, latched=True))
            if self.sim.world.moving_obstacles:
                self.pub_obstacles = self.create_publisher("/sim/obstacles", MarkerArray,
                                                           QoS(depth=1))
                self.create_timer(OBSTACLES_PERIOD, self._obstacles)
        if self.sim.gnss is not None and "gnss" not in self.wired:
            self.pub_fix = self.create_publisher(_topic(sensors.gnss.topic), NavSatFix,
                                                 SENSOR_DATA)
            self.pub_gps_vel = self.create_publisher(_topic(sensors.gnss.velocity_topic),
                                                     TwistWithCovarianceStamped, SENSOR_DATA)
            self.create_timer(1.0 / sensors.gnss.rate_hz, self._gnss)
        if self.sim.magnetometer is not None and "magnetometer" not in self.wired:
            self.pub_mag = self.create_publisher(_topic(sensors.magnetometer.topic),
                                                 MagneticField, SENSOR_DATA)
            self.create_timer(1.0 / sensors.magnetometer.rate_hz, self._mag)

    def on_activate(self) -> None:
        sensors = self.sim.robot.sensors
        # REP-120's base_footprint (base_link projected on the ground; the same pose for a
        # planar robot): Nav2 files name it (amcl, collision_monitor base_frame_id)
        static = [TransformStamped(Header(self.now, "base_link"), "base_footprint",
                                   Transform(Vector3(0.0, 0.0, 0.0), Quaternion.from_yaw(0.0)))]
        if self.sim.lidar is not None:
            static.append(self._static_tf(sensors.lidar.frame_id, sensors.lidar.mount))
        if self.sim.imu is not None:
            static.append(self._static_tf(sensors.imu.frame_id, sensors.imu.mount))
        if self.sim.lidar3d is not None:
            static.append(self._static_tf(sensors.lidar3d.frame_id, sensors.lidar3d.mount))
        if self.sim.gnss is not None:
            static.append(self._static_tf(sensors.gnss.frame_id, sensors.gnss.mount))
        if self.sim.magnetometer is not None:
            static.append(self._static_tf(sensors.magnetometer.frame_id,
                                          sensors.magnetometer.mount))
        self.pub_tf_static.publish(TFMessage(tuple(static)))
        if sensors.ground_truth.enabled:
            outline = [Point(float(x), float(y), 0.0) for x, y in self.sim.footprint.polygon]
            self.pub_footprint.publish(Marker(Header(self.now, "base_link"), "footprint", 0,
                                              Marker.LINE_STRIP,
                                              points=(*outline, outline[0])))
        self._last_imu_t = self.now
        if "odometry" not in self.wired:
            self._odom()

    def _static_tf(self, frame: str, mount: object) -> TransformStamped:
        m = mount
        return TransformStamped(
            Header(self.now, "base_link"), frame,
            Transform(Vector3(m.x, m.y, m.z), Quaternion.from_yaw(m.yaw)))  # type: ignore[attr-defined]

    # --- callbacks -------------------------------------------------------------------
    def advance(self) -> None:
        """Step physics up to the current time (sub-steps of at most ``physics_dt``)."""
        sim, now, dt = self.sim, self.now, self.physics_dt
        # physics steps from the scheduler's elapsed time and the physics' own elapsed
        # sum: the same floats whatever the clock's start value (``now - sim.time`` on
        # absolute seconds gave remainders that differed in their last bits with it)
        el = self.runtime.scheduler.elapsed
        if self._physics_el is None:
            self._physics_el = self.runtime.scheduler.to_elapsed(sim.time)
        if self._physics_el >= el - 1e-9:
            return
        while self._physics_el < el - 1e-9:
            step = min(dt, el - self._physics_el)
            sim.step(step)
            self._physics_el += step
        if now - self._last_clock_t >= self.clock_period - 1e-9:
            self._last_clock_t = now
            self.pub_clock.publish(Clock(now))

    def _on_cmd(self, msg: Twist) -> None:
        self.advance()
        if not self.sim.set_command(msg.to_twist2d(), self.now):
            self.log.warning(self.sim.last_rejection)

    def _scan(self) -> None:
        self.advance()
        scan = self.sim.scan(self.now)
        if scan is not None:
            self.scans_published += 1
            self.pub_scan.publish(scan)

    def _cloud(self) -> None:
        self.advance()
        cloud = self.sim.point_cloud(self.now)
        if cloud is not None:
            self.pub_cloud.publish(cloud)

    def _odom(self) -> None:
        self.advance()
        if self._imu_due(self.now):
            # gyro odometry: an IMU sample due at this instant belongs to this message
            # (the cart's Mega reads its IMU before it writes the line); the IMU's timer
            # publishes it after its sample, so the random stream keeps its order
            self._odom_after_imu = True
            return
        self._publish_odom()

    def _publish_odom(self) -> None:
        now = self.now
        odom = self.sim.odom(now)
        if odom is None:
            return
        self.odom_published += 1
        self.pub_odom.publish(odom)
        p = odom.pose.pose
        self._odom_pose = p.to_pose2d()
        tfs = [TransformStamped(Header(now, odom.header.frame_id), odom.child_frame_id,
                                Transform(Vector3(p.position.x, p.position.y, 0.0), p.orientation))]
        el = self.runtime.scheduler.elapsed  # the rate on elapsed time: start-independent
        if self.perfect_localization and el >= self._next_map_odom_t:
            # like AMCL: map->odom at a lower rate, future-dated by transform_tolerance
            # so lookups at the newest odometry time never wait for it
            transform = Transform.from_pose2d(self.sim.pose.compose(self._odom_pose.inverse()))
            if self._next_map_odom_t == 0.0:
                tfs.append(TransformStamped(Header(now, "map"), odom.header.frame_id, transform))
            tfs.append(TransformStamped(Header(now + self.map_odom_tolerance, "map"),
                                        odom.header.frame_id, transform))
            self._next_map_odom_t = el + self.map_odom_period
        self.pub_tf.publish(TFMessage(tuple(tfs)))

    def _imu_due(self, now: float) -> bool:
        imu = self.sim.imu
        return (self.sim.gyro_odometry and imu is not None and "imu" not in self.wired
                and now - self._last_imu_t >= 1.0 / imu.rate_hz - 1e-9)

    def _imu(self) -> None:
        self.advance()
        now = self.now
        msg = self.sim.imu_sample(now - self._last_imu_t, now)
        self._last_imu_t = now
        if msg is not None:
            self.pub_imu.publish(msg)
        if self._odom_after_imu:
            self._odom_after_imu = False
            self._publish_odom()

    def _gnss(self) -> None:
        self.advance()
        sample = self.sim.gnss_sample(self.now)
        if sample is None:
            return
        fix, vel = sample
        self.pub_fix.publish(fix)
        if vel is not None:
            self.pub_gps_vel.publish(vel)

    def _mag(self) -> None:
        self.advance()
        msg = self.sim.magnetic_field(self.now)
        if msg is not None:
            self.pub_mag.publish(msg)

    def _truth(self) -> None:
        self.advance()
        self.pub_truth.publish(self.sim.truth(self.now))

    def _obstacles(self) -> None:
        self.advance()
        header = Header(self.now, "map")
        markers = []
        for i, (o, clock) in enumerate(zip(self.sim.world.moving_obstacles,
                                           self.sim.obstacle_clocks, strict=True)):
            x, y, heading = o.pose_in(clock)
            if o.shape == "circle":
                kind, scale = Marker.CYLINDER, Vector3(2 * o.radius, 2 * o.radius, 1.7)
            else:
                kind, scale = Marker.CUBE, Vector3(o.size[0], o.size[1], 1.0)
            markers.append(Marker(header, o.name, i, kind,
                                  pose=Pose(Point(x, y, 0.0), Quaternion.from_yaw(heading)),
                                  scale=scale))
        self.pub_obstacles.publish(MarkerArray(tuple(markers)))


WIRED_PARTS = frozenset({"base", "odometry", "imu", "gnss", "magnetometer"})


def _topic(name: str) -> str:
    """Absolute topic name (profile topics are written without the leading slash)."""
    return name if name.startswith("/") else "/" + name


class FleetSimulatorNode(SimulatorNode):
    """One robot of a :class:`~navstack.sim.fleet.FleetSimulator` on its own namespace's
    bus: publishes that robot's sensors; advancing it advances the whole fleet (every
    robot sees the others where they are at the same instant)."""

    def __init__(self, runtime: Runtime, fleet: FleetSimulator, robot: str,
                 perfect_localization: bool = True, wired: Collection[str] = ()) -> None:
        super().__init__(runtime, fleet.sim(robot), 1.0 / fleet.physics_dt,
                         perfect_localization, wired=wired)
        self.fleet = fleet

    def advance(self) -> None:
        now = self.now
        self.fleet.advance_to(now)
        if now - self._last_clock_t >= self.clock_period - 1e-9:
            self._last_clock_t = now
            self.pub_clock.publish(Clock(now))
