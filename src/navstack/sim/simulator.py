"""The simulated robot in its world, without any bus: physics, sensors, collisions.

``Simulator`` is a pure, deterministic object (one ``numpy.random.Generator`` seeded at
construction, explicit time): :mod:`navstack.sim.node` wraps it in a lifecycle node that
publishes ``/scan``, ``/odom``, ``/imu``, ``/tf``, ``/clock`` and ``/ground_truth`` (and
``/gps/fix``, ``/gps/vel``, ``/imu/mag`` when the profile enables GNSS / magnetometer).

Moving obstacles (people, forklifts) make way for the robot: they hold, turn back, step
aside or back away rather than walk through it (:mod:`navstack.sim.walkers`); the run
stays deterministic.

Contact model: a step whose footprint would overlap an obstacle is not taken — the robot
stays where it was with zero velocity, as a real base stalls against a wall.  A blocked
step counts as a new collision only when the previous blocked step is more than
``contact_release_s`` (0.5 s) ago, so a robot creeping against a wall (alternating tiny
free and blocked steps) is one collision, not one per step.

Fleets (:mod:`navstack.sim.fleet`): ``peers`` are the other robots in the same world.
Their bodies are obstacles to this robot's lidar (their footprint edges are ray-cast like
a box obstacle's) and to its contact model (a step into a peer's footprint is blocked and
counted in ``collisions`` and ``robot_collisions``).  One robot owns the moving obstacles
and yields them to every robot of the fleet; the others follow its obstacle clocks
(``obstacle_owner``), so all robots live in one world at one instant.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from navstack.core.errors import ConfigError, InvalidMessage
from navstack.core.msgs import (
    Imu,
    LaserScan,
    MagneticField,
    NavSatFix,
    Odometry,
    PointCloud2,
    Pose2D,
    Twist,
    Twist2D,
    TwistWithCovarianceStamped,
)
from navstack.sim.collision import footprint_collides, polygon_hits_moving
from navstack.sim.gnss import GnssModel, MagnetometerModel
from navstack.sim.kinematics import RobotState, integrate_pose, make_model
from navstack.sim.lidar3d import Lidar3dModel, cast_cloud
from navstack.sim.packages import PackageWorld
from navstack.sim.raycast import cast_rays
from navstack.sim.robot import RobotParams
from navstack.sim.sensors import GroundTruthModel, ImuModel, LidarModel, WheelOdometryModel
from navstack.sim.walkers import WalkerTraffic
from navstack.sim.world import ObstacleClock, World

_NO_CIRCLES = np.zeros((0, 3), dtype=np.float64)


class Simulator:
    """One robot in one world.  All methods take or use explicit simulated time."""

    def __init__(self, world: World, robot: RobotParams, seed: int = 0,
                 spawn: Pose2D | None = None) -> None:
        self.world = world
        self.robot = robot
        self.rng = np.random.default_rng(seed)
        self.model = make_model(robot.kinematics)
        # the physical body: navigation's footprint_padding is a planning margin only
        self.footprint = robot.updated(footprint_padding=0.0).footprint_model()
        self._fp_local = np.ascontiguousarray(self.footprint.polygon, dtype=np.float64)
        radius = self.footprint.circumscribed_radius
        self._dist = world.distance_field()
        self._broad_radius = radius + 1.5 * world.resolution
        k = robot.kinematics
        self.walkers = WalkerTraffic(
            world, radius,
            math.hypot(max(abs(k.max_vel_x), abs(k.min_vel_x or 0.0)), abs(k.max_vel_y)),
            self._dist)
        self.obstacle_clocks: tuple[ObstacleClock, ...] = self.walkers.states
        """Each moving obstacle's clock, or its
        :class:`~navstack.sim.world.ObstacleState` while off its path."""
        self.obstacle_near = self.walkers.near
        """Whether each moving obstacle is within its yield radius of a robot."""
        start = spawn or world.spawn
        self.state = RobotState(x=start.x, y=start.y, yaw=start.theta)
        self._imu_prev_state: RobotState | None = None
        self.command = Twist2D()
        self.command_time = -math.inf
        self.cmd_timeout = 0.5
        self.time = 0.0
        self.collisions = 0
        self.in_contact = False
        self.contact_release_s = 0.5
        self._last_contact_t = -math.inf
        self.rejected_commands = 0
        self.last_rejection = ""
        sensors = robot.sensors
        self.lidar = LidarModel(sensors.lidar) if sensors.lidar.enabled else None
        self.odometry = (WheelOdometryModel(sensors.odometry, holonomic=self.model.holonomic)
                         if sensors.odometry.enabled else None)
        self.imu = ImuModel(sensors.imu) if sensors.imu.enabled else None
        self.gyro_odometry = (self.odometry is not None
                              and sensors.odometry.yaw_rate_source == "imu")
        """Odometry's yaw rate from the gyro (``odometry.yaw_rate_source: imu``)."""
        self._unsigned_speed = sensors.odometry.unsigned_speed
        self._direction = 1.0
        if self.gyro_odometry and self.imu is None:
            raise ConfigError(f"robot '{robot.name}': odometry.yaw_rate_source 'imu' needs "
                              f"the IMU; enable sensors.imu or use 'wheels'",
                              key_path="sensors.odometry.yaw_rate_source")
        self._gyro = [0.0, 0.0, 0.0]  # sum of gyro z since the last odometry, count, last mean
        self._gyro_pose: tuple[float, float, float] | None = None
        self._gyro_t = 0.0
        self.ground_truth = GroundTruthModel(sensors.ground_truth)
        # GNSS and magnetometer draw from their own streams so that enabling them leaves
        # the noise of every other sensor (and so existing seeded runs) unchanged
        self.gnss = (GnssModel(sensors.gnss, sensors.georeference)
                     if sensors.gnss.enabled else None)
        self.magnetometer = (MagnetometerModel(sensors.magnetometer, sensors.georeference)
                             if sensors.magnetometer.enabled else None)
        self.gnss_rng = np.random.default_rng([seed, 1])
        self.magnetometer_rng = np.random.default_rng([seed, 2])
        self.lidar3d = Lidar3dModel(sensors.lidar3d) if sensors.lidar3d.enabled else None
        self.lidar3d_rng = np.random.default_rng([seed, 3])
        self.heights: NDArray[np.float64] | None = None
        """Per-cell obstacle heights [m] for the 3-D lidar (default: uniform)."""
        self.distance_travelled = 0.0
        # marked packages on the floor and the gripper (sim/packages.py)
        self.packages = PackageWorld(world.packages, robot.gripper, self._fp_local)
        self.peers: tuple[Simulator, ...] = ()
        """Other robots in the same world (a fleet); empty for a robot alone."""
        self.obstacle_owner: Simulator | None = None
        """The fleet robot whose obstacle clocks this one follows (``None``: its own)."""
        self.robot_collisions = 0
        """Collisions (as counted in ``collisions``) whose contact was another robot."""

    # --- commands ------------------------------------------------------------------
    def set_command(self, cmd: Twist2D, now: float) -> bool:
        """Accept a body-frame velocity command; NaN/inf is rejected and counted."""
        if not cmd.is_finite():
            self.rejected_commands += 1
            self.last_rejection = (f"rejected /cmd_vel at t={now:.3f} s: non-finite values "
                                   f"(vx={cmd.vx}, vy={cmd.vy}, wz={cmd.wz}); keeping last command")
            return False
        self.command = cmd
        self.command_time = now
        if cmd.vx != 0.0:
            self._direction = math.copysign(1.0, cmd.vx)
        return True

    def teleport(self, pose: Pose2D) -> None:
        """Move the robot instantly (kidnapping tests); velocities reset to zero."""
        self.state = RobotState(x=pose.x, y=pose.y, yaw=pose.theta)
        self._imu_prev_state = None
        self.walkers.forget_distances()  # distances changed: re-evaluate

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.state.x, self.state.y, self.state.yaw)

    # --- physics -------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance physics by ``dt`` seconds under the current command."""
        cmd = self.command if self.time - self.command_time <= self.cmd_timeout else Twist2D()
        try:
            new = self.model.step(self.state, cmd, dt)
        except InvalidMessage as exc:  # defensive: set_command filters these already
            self.rejected_commands += 1
            self.last_rejection = str(exc)
            new = self.model.step(self.state, Twist2D(), dt)
        self.time += dt
        if self.obstacle_clocks:
            owner = self.obstacle_owner
            if owner is None:
                robots = [(self.state.x, self.state.y)]
                robots += [(p.state.x, p.state.y) for p in self.peers]
                self.walkers.advance(dt, robots)
                self.obstacle_clocks = self.walkers.states
            else:  # a fleet: the owner has advanced the shared obstacles for this step
                self.obstacle_clocks = owner.obstacle_clocks
                self.obstacle_near = owner.obstacle_near
        moved = new.x != self.state.x or new.y != self.state.y or new.yaw != self.state.yaw
        if moved:
            blocked = self._collides(new) or self._touches_package(new)
            hit_robot = not blocked and bool(self.peers) and self._touches_robot(new)
            if blocked or hit_robot:
                if self.time - self._last_contact_t > self.contact_release_s:
                    self.collisions += 1
                    self.robot_collisions += hit_robot
                self._last_contact_t = self.time
                new = replace(self.state, vx=0.0, vy=0.0, wz=0.0)
        self.in_contact = self.time - self._last_contact_t <= self.contact_release_s
        self.distance_travelled += math.hypot(new.x - self.state.x, new.y - self.state.y)
        self.state = new
        if self.odometry is not None:  # wheel encoders count every step
            self.odometry.integrate(new, dt, self.rng)
        if self.packages.specs:
            self.packages.update(self.pose, self.time)

    def _touches_package(self, state: RobotState) -> bool:
        """Footprint contact with a package on the floor (counted per package)."""
        if not self.packages.specs:
            return False
        return self.packages.contact(self._footprint_at(state),
                                     Pose2D(state.x, state.y, state.yaw), self.time)

    def _collides(self, state: RobotState) -> bool:
        """Footprint contact at ``state``, with a cheap broad phase first.

        The static part is skipped when the distance field at the robot's cell exceeds
        the circumscribed radius plus 1.5 cells (no occupied square can reach the
        footprint), the moving part when every obstacle's bounding circle is farther
        than that radius; only then is the exact polygon test run.
        """
        w = self.world
        col = math.floor((state.x - w.origin_x) / w.resolution)
        row = math.floor((state.y - w.origin_y) / w.resolution)
        near_static = True
        if 0 <= row < self._dist.shape[0] and 0 <= col < self._dist.shape[1]:
            near_static = self._dist[row, col] <= self._broad_radius
        near_moving = False
        for (obstacle, bound), clock, near in zip(self.walkers.bounds, self.obstacle_clocks,
                                                  self.obstacle_near, strict=True):
            if not near:  # more than yield_margin away: cannot touch within one step
                continue
            ox, oy, _ = obstacle.pose_in(clock)
            if math.hypot(ox - state.x, oy - state.y) <= bound:
                near_moving = True
                break
        if not (near_static or near_moving):
            return False
        return footprint_collides(w, self._footprint_at(state), self.obstacle_clocks)

    def _touches_robot(self, state: RobotState) -> bool:
        """Footprint contact at ``state`` with a peer's body where it stands now."""
        reach = 2.0 * self.footprint.circumscribed_radius
        poly: NDArray[np.float64] | None = None
        for peer in self.peers:
            other = peer.footprint.circumscribed_radius
            if math.hypot(peer.state.x - state.x, peer.state.y - state.y) > reach + other:
                continue
            if poly is None:
                poly = self._footprint_at(state)
            if polygon_hits_moving(poly, _NO_CIRCLES, peer.body()[None]):
                return True
        return False

    def body(self) -> NDArray[np.float64]:
        """The physical footprint ``(N, 2)`` in the world where the robot stands now."""
        return self._footprint_at(self.state)

    def _footprint_at(self, state: RobotState) -> NDArray[np.float64]:
        """Footprint polygon in the world at ``state`` (plain numpy: runs every step)."""
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        return self._fp_local @ np.array([[c, s], [-s, c]]) + (state.x, state.y)

    # --- sensors -------------------------------------------------------------------
    def lidar_pose(self) -> tuple[float, float, float]:
        """World pose (x, y, yaw) of the lidar from the robot pose and its mount."""
        assert self.lidar is not None
        m = self.lidar.mount
        c, s = math.cos(self.state.yaw), math.sin(self.state.yaw)
        return (self.state.x + c * m.x - s * m.y, self.state.y + s * m.x + c * m.y,
                self.state.yaw + m.yaw)

    def true_ranges(self) -> NDArray[np.float64]:
        assert self.lidar is not None
        lx, ly, lyaw = self.lidar_pose()
        circles, segments = self._sensed_moving(self.lidar.params.range_max)
        w = self.world
        return cast_rays(w.occupied, w.origin_x, w.origin_y, w.resolution, lx, ly, lyaw,
                         self.lidar.beam_angles, self.lidar.params.range_min,
                         self.lidar.params.range_max, circles, segments)

    def _sensed_moving(self, range_max: float) -> tuple[NDArray[np.float64],
                                                        NDArray[np.float64]]:
        """Moving shapes a sensor sees: the world's moving obstacles and, in a fleet, the
        outline edges ``(x1, y1, x2, y2)`` of every peer within ``range_max`` of it."""
        circles, segments = self.world.moving_at(self.obstacle_clocks)
        if not self.peers:
            return circles, segments
        parts = [segments]
        for peer in self.peers:
            reach = range_max + self.footprint.circumscribed_radius \
                + peer.footprint.circumscribed_radius
            if math.hypot(peer.state.x - self.state.x, peer.state.y - self.state.y) > reach:
                continue
            poly = peer.body()
            parts.append(np.concatenate((poly, np.roll(poly, -1, axis=0)), axis=1))
        return circles, np.ascontiguousarray(np.concatenate(parts), dtype=np.float64)

    def scan(self, now: float) -> LaserScan | None:
        if self.lidar is None:
            return None
        return self.lidar.measure(self.true_ranges(), now, self.rng)

    def point_cloud(self, now: float) -> PointCloud2 | None:
        """A 3-D lidar revolution (``None`` without one), :mod:`navstack.sim.lidar3d`."""
        model = self.lidar3d
        if model is None:
            return None
        p, w, m = model.params, self.world, model.mount
        if self.heights is None:
            self.heights = np.full(w.occupied.shape, p.obstacle_height)
        c, s = math.cos(self.state.yaw), math.sin(self.state.yaw)
        sx, sy = self.state.x + c * m.x - s * m.y, self.state.y + s * m.x + c * m.y
        circles, segments = self._sensed_moving(p.range_max)
        dist = cast_cloud(w.occupied, self.heights, w.origin_x, w.origin_y, w.resolution,
                          (sx, sy, m.z), self.state.yaw + m.yaw, model.azimuths,
                          model.elevations, p.range_max, circles, segments,
                          p.moving_obstacle_height)
        return model.cloud(dist, now, self.lidar3d_rng)

    def odom(self, now: float) -> Odometry | None:
        """The wheel-odometry message for the encoder counts integrated so far."""
        if self.odometry is None:
            return None
        msg = self.odometry.message(now)
        if self.gyro_odometry or self._unsigned_speed:
            return self._dead_reckoning(msg, now)
        return msg

    def _dead_reckoning(self, msg: Odometry, now: float) -> Odometry:
        """``yaw_rate_source: imu``: the wheels' speed with the mean gyro z of the IMU
        samples since the previous message; ``unsigned_speed``: the speed's magnitude
        with the commanded direction; dead-reckoned over the message period -- what the
        cart's driver computes from its sensor Arduino's lines
        (:class:`navstack.drivers.odometry.DeadReckoning`).  The covariances stay the
        wheel model's."""
        w = msg.twist.twist.angular.z
        if self.gyro_odometry:
            total, n, last = self._gyro
            w = total / n if n else last
            self._gyro = [0.0, 0.0, w]
        v = msg.twist.twist.linear.x
        if self._unsigned_speed:
            v = self._direction * abs(v)
        if self._gyro_pose is None:
            p0 = self.odometry.pose if self.odometry is not None else Pose2D()
            self._gyro_pose = (p0.x, p0.y, p0.theta)
        else:
            x, y, yaw = self._gyro_pose
            x, y, yaw = integrate_pose(x, y, yaw, v, 0.0, w, now - self._gyro_t)
            self._gyro_pose = (x, y, math.atan2(math.sin(yaw), math.cos(yaw)))
        self._gyro_t = now
        return replace(msg, pose=replace(msg.pose, pose=Pose2D(*self._gyro_pose).to_pose()),
                       twist=replace(msg.twist, twist=Twist.planar(v, 0.0, w)))

    def imu_sample(self, dt: float, now: float) -> Imu | None:
        """An IMU sample; acceleration from the state ``dt`` ago (the previous sample)."""
        if self.imu is None:
            return None
        msg = self.imu.measure(self.state, self._imu_prev_state, dt, now, self.rng)
        self._imu_prev_state = self.state
        if self.gyro_odometry and msg is not None:
            self._gyro[0] += msg.angular_velocity.z
            self._gyro[1] += 1
        return msg

    def gnss_sample(self, now: float
                    ) -> tuple[NavSatFix, TwistWithCovarianceStamped | None] | None:
        """A GNSS fix and ENU velocity (``None`` without a GNSS; velocity ``None`` when
        the receiver has no fix)."""
        if self.gnss is None:
            return None
        return self.gnss.measure(self.state, now, self.gnss_rng)

    def magnetic_field(self, now: float) -> MagneticField | None:
        """A magnetometer sample (``None`` without a magnetometer)."""
        if self.magnetometer is None:
            return None
        return self.magnetometer.measure(self.state, now, self.magnetometer_rng)

    def truth(self, now: float) -> Odometry:
        return self.ground_truth.measure(self.state, now)
