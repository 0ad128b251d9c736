"""The simulated robot in its world, without any bus: physics, sensors, collisions.

``Simulator`` is a pure, deterministic object (one ``numpy.random.Generator`` seeded at
construction, explicit time): :mod:`navstack.sim.node` wraps it in a lifecycle node that
publishes ``/scan``, ``/odom``, ``/imu``, ``/tf``, ``/clock`` and ``/ground_truth`` (and
``/gps/fix``, ``/gps/vel``, ``/imu/mag`` when the profile enables GNSS / magnetometer).

Moving obstacles yield: each has its own clock, held still during a step in which its
motion would bring it closer to the robot than ``yield_margin`` (0.6 m) beyond their
bounding circles — people and forklifts stop for a robot rather than walk through it —
and an obstacle held for ``turn_back_after`` (4 s) turns back along its path, so a
face-off in a corridor always resolves.  When turning back would close in on a robot as
well (a robot beside the end of a pingpong path, where both ways lead back past it, or
robots on both sides) the obstacle instead steps aside (up to ``sidestep_max``, 0.6 m)
and walks on past it, yielding only within ``pass_margin`` (0 m: its bounding circle
stays 0.05 m off the robot's circumscribed circle); where the robot stands too close to
pass it backs away from the robot, off its path (up to ``step_away_max``, 2.5 m), so the
robot can move.  Once clear of every robot's yield radius it walks back onto its path.
A person squeezes past or makes room for a robot that stands in the way rather than wait
for it for good.  The run stays deterministic (clocks, offsets, directions and hold
times depend only on the simulated history).

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
from navstack.sim.world import MovingObstacle, ObstacleClock, ObstacleState, World

_NO_CIRCLES = np.zeros((0, 3), dtype=np.float64)


def _shrink(off: tuple[float, float], by: float) -> tuple[float, float] | None:
    """An offset ``by`` metres shorter (``None`` once it reaches the path)."""
    n = math.hypot(*off)
    if n <= by:
        return None
    return off[0] * (1.0 - by / n), off[1] * (1.0 - by / n)


def _closes_in(obstacle: MovingObstacle, clock: float, off: tuple[float, float] | None,
               robots: list[tuple[float, float]], d_now: list[float], keep: float) -> bool:
    """Whether the obstacle at ``clock`` (+ ``off``) is nearer than ``keep`` to a robot it
    was farther from (``d_now``: its distances to ``robots`` before the step)."""
    nx, ny, _ = obstacle.pose_at(clock)
    if off:
        nx, ny = nx + off[0], ny + off[1]
    return any(d_next < keep and d_next < d
               for d_next, d in zip([math.hypot(nx - rx, ny - ry) for rx, ry in robots],
                                    d_now, strict=True))


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
        self._moving_bounds = [
            (o, radius + (o.radius if o.shape == "circle" else 0.5 * math.hypot(*o.size)) + 0.05)
            for o in world.moving_obstacles]
        self.obstacle_clocks: tuple[ObstacleClock, ...] = (0.0,) * len(world.moving_obstacles)
        """Each moving obstacle's clock, or its :class:`ObstacleState` while off its path."""
        self._clocks = [0.0] * len(world.moving_obstacles)
        self._offsets: list[tuple[float, float] | None] = [None] * len(world.moving_obstacles)
        self._obstacle_dir = [1.0] * len(world.moving_obstacles)
        self._obstacle_held = [0.0] * len(world.moving_obstacles)
        self._obstacle_near = [True] * len(world.moving_obstacles)
        self._obstacle_passing = [False] * len(world.moving_obstacles)
        self._obstacle_backing = [False] * len(world.moving_obstacles)
        self._far_slack = [0.0] * len(world.moving_obstacles)
        k = robot.kinematics
        self.robot_speed_bound = math.hypot(max(abs(k.max_vel_x), abs(k.min_vel_x or 0.0)),
                                            abs(k.max_vel_y))
        self.yield_margin = 0.6
        self.turn_back_after = 4.0
        self.pass_margin = 0.0
        self.sidestep_max = 0.6
        self.step_away_max = 2.5
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
        self._far_slack = [0.0] * len(self._far_slack)  # distances changed: re-evaluate

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
                self._advance_obstacles(dt)
            else:  # a fleet: the owner has advanced the shared obstacles for this step
                self.obstacle_clocks = owner.obstacle_clocks
                self._obstacle_near = owner._obstacle_near
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

    def _advance_obstacles(self, dt: float) -> None:
        """Advance each obstacle's clock unless that step would close in on the robot.

        An obstacle far from the robot is not even evaluated: ``_far_slack`` is a lower
        bound on its distance, shrunk by the most both can have moved since the last
        exact evaluation, and only when it drops below the yield radius is the pose
        computed again (physics runs at 50 Hz; most obstacles are far most of the time).
        An obstacle that stepped aside to pass a robot walks back onto its path once it
        is clear of every robot (:meth:`_pass_step`).
        """
        robots = [(self.state.x, self.state.y)]
        robots += [(p.state.x, p.state.y) for p in self.peers]
        clocks, offsets = self._clocks, self._offsets
        reach = self.robot_speed_bound * dt
        for i, (obstacle, bound) in enumerate(self._moving_bounds):
            step = self._obstacle_dir[i] * dt
            radius = bound + self.yield_margin + obstacle.speed * dt
            back = obstacle.speed * dt  # how far it may walk back toward its path per step
            off = offsets[i]
            self._far_slack[i] -= obstacle.speed * dt + reach + (back if off else 0.0)
            if self._far_slack[i] > radius:  # certainly far: just walk
                self._obstacle_held[i] = 0.0
                self._obstacle_near[i] = False
                self._obstacle_passing[i] = self._obstacle_backing[i] = False
                clocks[i] += step
                if off:
                    offsets[i] = _shrink(off, back)
                continue
            cx, cy, _ = obstacle.pose_at(clocks[i])
            if off:
                cx, cy = cx + off[0], cy + off[1]
            d_now = [math.hypot(cx - rx, cy - ry) for rx, ry in robots]
            d_cur = min(d_now)
            self._far_slack[i] = d_cur
            if d_cur > radius:
                self._obstacle_held[i] = 0.0
                self._obstacle_near[i] = False
                self._obstacle_passing[i] = self._obstacle_backing[i] = False
                clocks[i] += step
                if off:
                    offsets[i] = _shrink(off, back)
                continue
            self._obstacle_near[i] = True
            if self._obstacle_passing[i]:
                if self._pass_step(i, step, robots, d_now, (cx, cy)):
                    continue
            # hold while the step would close in on any robot within the yield margin
            elif not _closes_in(obstacle, clocks[i] + step, off, robots, d_now,
                                bound + self.yield_margin):
                self._obstacle_held[i] = 0.0
                clocks[i] += step
                continue
            self._obstacle_held[i] += dt  # hold: wait for the robot ...
            if self._obstacle_held[i] >= self.turn_back_after:
                self._obstacle_held[i] = 0.0
                keep = bound + (self.pass_margin if self._obstacle_passing[i]
                                else self.yield_margin)
                if not _closes_in(obstacle, clocks[i] - step, off, robots, d_now, keep):
                    self._obstacle_dir[i] = -self._obstacle_dir[i]  # ... then turn back
                else:  # both ways lead past a robot: step aside and walk past it
                    self._obstacle_passing[i] = True
        self.obstacle_clocks = tuple(
            c if not o else ObstacleState(c, o[0], o[1]) for c, o in zip(clocks, offsets,
                                                                          strict=True))

    def _pass_step(self, i: int, step: float, robots: list[tuple[float, float]],
                   d_now: list[float], at: tuple[float, float]) -> bool:
        """One step of obstacle ``i`` walking past a robot it could not wait out; whether
        it moved.

        It walks on along its path while edging sideways, away from the nearest robot, by
        up to its speed per step (at most ``sidestep_max`` off its path, and only onto
        cells its body clears), while that step keeps it beyond ``pass_margin`` of every
        robot's bounding circle.  Where no such step exists (the robot stands in its way
        too close to pass) it backs away from the robot, off its path (up to
        ``step_away_max``; along a wall when the straight way is blocked), and holds once
        it can do neither: it makes room as a person does, and the robot can then pass.
        """
        obstacle, bound = self._moving_bounds[i]
        clock, off, keep = self._clocks[i], self._offsets[i], bound + self.pass_margin
        ax, ay, heading = obstacle.pose_at(clock)
        bx, by, _ = obstacle.pose_at(clock + step)
        if bx != ax or by != ay:  # the path's own direction (a box may keep a fixed yaw)
            heading = math.atan2(by - ay, bx - ax)
        nx, ny = -math.sin(heading), math.cos(heading)
        rx, ry = robots[min(range(len(robots)), key=d_now.__getitem__)]
        side = 1.0 if (at[0] - rx) * nx + (at[1] - ry) * ny >= 0.0 else -1.0
        edge = obstacle.speed * abs(step)
        ox, oy = off if off else (0.0, 0.0)
        lateral = max(-self.sidestep_max, min(self.sidestep_max,
                                              ox * nx + oy * ny + side * edge))
        aside = (ox + (lateral - (ox * nx + oy * ny)) * nx,
                 oy + (lateral - (ox * nx + oy * ny)) * ny)
        passing: list[tuple[float, tuple[float, float] | None]] = [
            (clock + step, aside), (clock + step, off), (clock, aside)]
        backing: list[tuple[float, tuple[float, float] | None]] = []
        gap = min(d_now)
        if gap > 0.0:  # back away from the nearest robot (straight, else along a wall)
            ux, uy = (at[0] - rx) / gap * edge, (at[1] - ry) / gap * edge
            for dx, dy in ((ux, uy), (ux, 0.0), (0.0, uy)):
                away = (ox + dx, oy + dy)
                if math.hypot(*away) <= self.step_away_max:
                    backing.append((clock, away))
        # once it has started to back away it keeps doing so until clear of the robot
        # (walking on again at once would close in, back away, close in ... in place)
        candidates = backing if self._obstacle_backing[i] else passing + backing
        for k, (clock_next, off_next) in enumerate(candidates):
            if clock_next == clock and off_next == off:
                continue
            if not self._clear_of_walls(obstacle, clock_next, off_next):
                continue
            if _closes_in(obstacle, clock_next, off_next, robots, d_now, keep):
                continue
            if candidates is not backing and k >= len(passing):
                self._obstacle_backing[i] = True
            self._obstacle_held[i] = 0.0 if clock_next != clock else self._obstacle_held[i]
            self._clocks[i] = clock_next
            self._offsets[i] = off_next if off_next != (0.0, 0.0) else None
            return True
        return False

    def _clear_of_walls(self, obstacle: MovingObstacle, clock: float,
                        off: tuple[float, float] | None) -> bool:
        """Whether the obstacle's body at ``clock`` + ``off`` clears the static grid (on
        its path it always may be: paths are the world author's)."""
        if not off:
            return True
        x, y, _ = obstacle.pose_at(clock)
        w = self.world
        col = math.floor((x + off[0] - w.origin_x) / w.resolution)
        row = math.floor((y + off[1] - w.origin_y) / w.resolution)
        if not (0 <= row < self._dist.shape[0] and 0 <= col < self._dist.shape[1]):
            return True  # outside the grid is free space
        extent = obstacle.radius if obstacle.shape == "circle" else 0.5 * math.hypot(*obstacle.size)
        return bool(self._dist[row, col] >= extent + w.resolution)

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
        for (obstacle, bound), clock, near in zip(self._moving_bounds, self.obstacle_clocks,
                                                  self._obstacle_near, strict=True):
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
