"""Velocity sampling and trajectory rollout for DWB, all samples at once.

Follows ``dwb_plugins``: ``OneDVelocityIterator`` (per-axis samples between the
velocities reachable within the acceleration time, with an exact zero inserted where the
range crosses it), ``XYThetaIterator`` (x-major product of the axes, filtered by
``KinematicParameters::isValidSpeed``) and ``StandardTrajectoryGenerator``
(``getTimeSteps`` discretisation by distance/angle or time, per-step velocity ramp
toward the command under the acceleration limits, Euler integration, optional repeated
last point).  The samples are built with numpy and rolled out by one compiled (numba)
kernel into a single ``(samples, steps, 3)`` array; samples needing fewer steps are
padded with their final pose, and ``lengths`` says how many poses are real.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.control.dwb.params import TrajectoryGeneratorParams
from navstack.core.msgs import Pose2D, Twist2D
from navstack.core.registry import PluginRegistry

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
EPSILON = 1e-5
"""Nav2's ``dwb_plugins::EPSILON`` used by the iterators' comparisons."""


@numba.njit(cache=True)
def project_velocity(v0: float, accel: float, decel: float, dt: float, target: float) -> float:
    """``dwb_plugins::projectVelocity``: the velocity ``dt`` after ``v0`` moving toward ``target``.

    ``decel`` is negative (Nav2 convention); the result never passes ``target``.
    """
    if v0 < target:
        return min(target, v0 + accel * dt)
    return max(target, v0 + decel * dt)


def axis_samples(current: float, vmin: float, vmax: float, acc: float, decel: float,
                 acc_time: float, num_samples: int) -> FloatArray:
    """``OneDVelocityIterator``: the samples of one velocity axis, ascending.

    The window is ``[project(current -> vmin), project(current -> vmax)]`` after
    ``acc_time``; ``num_samples`` (at least 2) evenly spaced values span it, a collapsed
    window gives one value, and ``0.0`` is inserted when the window straddles zero
    without containing it (so stopping an axis is always among the samples when
    reachable).
    """
    cur = min(max(current, vmin), vmax)
    hi = float(project_velocity(cur, acc, decel, acc_time, vmax))
    lo = float(project_velocity(cur, acc, decel, acc_time, vmin))
    if abs(hi - lo) < EPSILON:
        return np.array([lo])
    vals = np.linspace(lo, hi, max(2, num_samples))
    near_zero = np.abs(vals) < 1e-9
    vals[near_zero] = 0.0
    if lo < 0.0 < hi and not near_zero.any():
        vals = np.insert(vals, int(np.searchsorted(vals, 0.0)), 0.0)
    return vals


@dataclass
class KinematicLimits:
    """Current (speed-limited) maxima next to the configured ones (``KinematicsHandler``)."""

    max_vel_x: float
    max_vel_y: float
    max_vel_theta: float
    max_speed_xy: float
    base_max_vel_x: float
    base_max_vel_y: float
    base_max_vel_theta: float
    base_max_speed_xy: float

    @staticmethod
    def from_params(p: TrajectoryGeneratorParams) -> KinematicLimits:
        return KinematicLimits(p.max_vel_x, p.max_vel_y, p.max_vel_theta, p.max_speed_xy,
                               p.max_vel_x, p.max_vel_y, p.max_vel_theta, p.max_speed_xy)

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """``KinematicsHandler::setSpeedLimit``: 0 restores, else percent or absolute [m/s].

        An absolute limit scales every maximum by ``limit / base_max_speed_xy`` so the
        trajectory shapes are preserved; a limit above the configured speed is ignored.
        """
        if limit == 0.0:
            self.max_vel_x, self.max_vel_y = self.base_max_vel_x, self.base_max_vel_y
            self.max_vel_theta, self.max_speed_xy = self.base_max_vel_theta, self.base_max_speed_xy
            return
        if limit < 0.0:
            raise ValueError(f"speed limit must be >= 0 (0 = no limit), got {limit}")
        if percentage:
            ratio = limit / 100.0
        elif limit < self.base_max_speed_xy:
            ratio = limit / self.base_max_speed_xy
        else:
            return
        self.max_vel_x = self.base_max_vel_x * ratio
        self.max_vel_y = self.base_max_vel_y * ratio
        self.max_vel_theta = self.base_max_vel_theta * ratio
        self.max_speed_xy = self.base_max_speed_xy * ratio if percentage else limit


@dataclass
class TrajectoryBatch:
    """Simulated trajectories of all velocity samples, in the costmap frame.

    ``velocities`` ``(N, 3)``: commanded (vx [m/s], vy [m/s], wz [rad/s]) per sample.
    ``poses`` ``(N, T, 3)``: x [m], y [m], theta [rad] (not wrapped), pose 0 is the start;
    rows are padded with their final pose beyond ``lengths``.
    ``lengths`` ``(N,)``: number of real poses.  ``dt`` ``(N,)``: step duration [s].
    ``cache`` holds per-batch derived arrays (cell indices) shared by critics.
    """

    velocities: FloatArray
    poses: FloatArray
    lengths: IntArray
    dt: FloatArray
    cache: dict[str, Any] = field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return int(self.velocities.shape[0])

    @property
    def num_steps(self) -> int:
        return int(self.poses.shape[1])

    def valid_mask(self) -> NDArray[np.bool_]:
        """``(N, T)``: True where the pose is a real (not padded) trajectory point."""
        return np.arange(self.num_steps)[None, :] < self.lengths[:, None]

    def take(self, idx: IntArray) -> TrajectoryBatch:
        """The sub-batch of samples ``idx`` (cached per-sample arrays follow along)."""
        n = len(self)
        cache = {k: tuple(a[idx] for a in v) if isinstance(v, tuple) else v[idx]
                 for k, v in self.cache.items()
                 if (v[0] if isinstance(v, tuple) else v).shape[:1] == (n,)}
        return TrajectoryBatch(self.velocities[idx], self.poses[idx], self.lengths[idx],
                               self.dt[idx], cache)

    def final_poses(self) -> FloatArray:
        """``(N, 3)``: last pose of each trajectory."""
        return self.poses[:, -1, :]

    def pose_at_time(self, t: float) -> FloatArray:
        """``(N, 3)``: pose at time ``t`` [s] along each trajectory, linearly interpolated.

        ``dwb_core::projectPose``; times past the end give the final pose.
        """
        n_real = self.lengths - 1
        u = np.clip(t / self.dt, 0.0, None)
        k0 = np.minimum(np.floor(u).astype(np.int64), n_real)
        k1 = np.minimum(k0 + 1, n_real)
        frac = np.clip(u - k0, 0.0, 1.0)[:, None]
        rows = np.arange(len(self))
        return self.poses[rows, k0] * (1.0 - frac) + self.poses[rows, k1] * frac


class StandardTrajectoryGenerator:
    """``dwb_plugins::StandardTrajectoryGenerator`` over a controller-period dynamic window.

    Samples are the velocities reachable within ``sim_period`` of the current one;
    each is rolled out for ``sim_time`` with the velocity ramping toward it at the
    acceleration limits (``computeNewVelocity``), integrated with Euler steps
    (``computeNewPosition``).
    """

    ramp_velocity = True

    def __init__(self, params: TrajectoryGeneratorParams | None = None) -> None:
        self.params = params or TrajectoryGeneratorParams()
        self.limits = KinematicLimits.from_params(self.params)

    def reset(self) -> None:
        """Nothing is carried between cycles (Nav2's ``reset`` is a no-op here too)."""

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        self.limits.set_speed_limit(limit, percentage)

    def sample_velocities(self, current: Twist2D) -> FloatArray:
        """``(N, 3)`` admissible commands (x-major order, as ``XYThetaIterator``)."""
        p, lim, t = self.params, self.limits, self.params.sim_period
        return _sample_window(
            current.vx, current.vy, current.wz,
            np.array([p.min_vel_x, p.min_vel_y, -lim.max_vel_theta]),
            np.array([lim.max_vel_x, lim.max_vel_y, lim.max_vel_theta]),
            np.array([p.acc_lim_x, p.acc_lim_y, p.acc_lim_theta]),
            np.array([p.decel_lim_x, p.decel_lim_y, p.decel_lim_theta]), t,
            np.array([p.vx_samples, p.vy_samples, p.vtheta_samples], dtype=np.int64),
            lim.max_speed_xy, p.min_speed_xy, p.min_speed_theta)

    def sample_velocities_numpy(self, current: Twist2D) -> FloatArray:
        """:meth:`sample_velocities` built from :func:`axis_samples` with numpy (the
        reference the compiled :func:`_sample_window` is tested against)."""
        p, lim, t = self.params, self.limits, self.params.sim_period
        xs = axis_samples(current.vx, p.min_vel_x, lim.max_vel_x, p.acc_lim_x, p.decel_lim_x,
                          t, p.vx_samples)
        ys = axis_samples(current.vy, p.min_vel_y, lim.max_vel_y, p.acc_lim_y, p.decel_lim_y,
                          t, p.vy_samples)
        ths = axis_samples(current.wz, -lim.max_vel_theta, lim.max_vel_theta, p.acc_lim_theta,
                           p.decel_lim_theta, t, p.vtheta_samples)
        gx, gy, gth = np.meshgrid(xs, ys, ths, indexing="ij")
        vel = np.column_stack((gx.ravel(), gy.ravel(), gth.ravel()))
        return vel[self.valid_speeds(vel)]

    def valid_speeds(self, vel: FloatArray) -> NDArray[np.bool_]:
        """``XYThetaIterator::isValidSpeed`` for ``(N, 3)`` commands."""
        p, lim = self.params, self.limits
        vmag_sq = vel[:, 0] ** 2 + vel[:, 1] ** 2
        ok = np.ones(len(vel), dtype=bool)
        if lim.max_speed_xy >= 0.0:
            ok &= vmag_sq <= lim.max_speed_xy ** 2 + EPSILON
        if p.min_speed_xy >= 0.0 and p.min_speed_theta >= 0.0:
            ok &= ~((vmag_sq + EPSILON < p.min_speed_xy ** 2)
                    & (np.abs(vel[:, 2]) + EPSILON < p.min_speed_theta))
        ok &= ~((vmag_sq == 0.0) & (vel[:, 2] == 0.0))
        return ok

    def num_steps(self, vel: FloatArray) -> IntArray:
        """``getTimeSteps``: integration steps per command (at least 1)."""
        p = self.params
        if p.discretize_by_time:
            steps = np.full(len(vel), math.ceil(p.sim_time / p.time_granularity), np.int64)
        else:
            lin = np.hypot(vel[:, 0], vel[:, 1]) * p.sim_time / p.linear_granularity
            ang = np.abs(vel[:, 2]) * p.sim_time / p.angular_granularity
            steps = np.ceil(np.maximum(lin, ang)).astype(np.int64)
        return np.maximum(steps, 1)

    def generate(self, pose: Pose2D, velocity: Twist2D,
                 commands: FloatArray | None = None) -> TrajectoryBatch:
        """Roll out ``commands`` (default: :meth:`sample_velocities`) from ``pose``."""
        p = self.params
        vel = self.sample_velocities(velocity) if commands is None else np.asarray(commands)
        vel = np.ascontiguousarray(vel, dtype=np.float64).reshape(-1, 3)
        steps = self.num_steps(vel) if len(vel) else np.zeros(0, np.int64)
        extra = 2 if p.include_last_point else 1
        t_max = int(steps.max()) if len(vel) else 1
        dt = p.sim_time / steps.astype(np.float64)
        limits = np.array([[p.acc_lim_x, p.decel_lim_x], [p.acc_lim_y, p.decel_lim_y],
                           [p.acc_lim_theta, p.decel_lim_theta]])
        poses = np.empty((len(vel), t_max + extra, 3))
        _rollout(vel, steps, dt, np.array([pose.x, pose.y, pose.theta]),
                 np.array([velocity.vx, velocity.vy, velocity.wz]), limits,
                 self.ramp_velocity, poses)
        return TrajectoryBatch(vel, poses, steps + extra, dt)


@numba.njit(cache=True)
def _rollout(vel: FloatArray, steps: IntArray, dt: FloatArray, start: FloatArray,
             start_vel: FloatArray, limits: FloatArray, ramp: bool,
             poses: FloatArray) -> None:
    """Euler rollout of every command (``generateTrajectory``), padding with the last pose.

    Per step the velocity moves toward the command under the acceleration limits
    (``computeNewVelocity``; held at the command when ``ramp`` is False), then the pose
    advances by it (``computeNewPosition``).
    """
    n, t_total = poses.shape[0], poses.shape[1]
    for i in range(n):
        x, y, th = start[0], start[1], start[2]
        vx, vy, wz = start_vel[0], start_vel[1], start_vel[2]
        h = dt[i]
        poses[i, 0, 0] = x
        poses[i, 0, 1] = y
        poses[i, 0, 2] = th
        for k in range(1, t_total):
            if k <= steps[i]:
                if ramp:
                    vx = project_velocity(vx, limits[0, 0], limits[0, 1], h, vel[i, 0])
                    vy = project_velocity(vy, limits[1, 0], limits[1, 1], h, vel[i, 1])
                    wz = project_velocity(wz, limits[2, 0], limits[2, 1], h, vel[i, 2])
                else:
                    vx, vy, wz = vel[i, 0], vel[i, 1], vel[i, 2]
                c, s = np.cos(th), np.sin(th)
                x += (vx * c - vy * s) * h
                y += (vx * s + vy * c) * h
                th += wz * h
            poses[i, k, 0] = x
            poses[i, k, 1] = y
            poses[i, k, 2] = th


@numba.njit(cache=True)
def _axis(current: float, vmin: float, vmax: float, acc: float, decel: float,
          acc_time: float, num_samples: int) -> FloatArray:
    """:func:`axis_samples` compiled; ``np.linspace``'s arithmetic (``i * step + lo``,
    last value exactly ``hi``) so the samples are bit-identical."""
    cur = min(max(current, vmin), vmax)
    hi = project_velocity(cur, acc, decel, acc_time, vmax)
    lo = project_velocity(cur, acc, decel, acc_time, vmin)
    if abs(hi - lo) < EPSILON:
        return np.array([lo])
    num = max(2, num_samples)
    div = num - 1
    delta = hi - lo
    step = delta / div
    vals = np.empty(num + 1)
    has_zero = False
    for i in range(num):
        v = (i / div) * delta + lo if step == 0.0 else i * step + lo
        if i == num - 1:
            v = hi
        if abs(v) < 1e-9:
            v = 0.0
            has_zero = True
        vals[i] = v
    if lo < 0.0 < hi and not has_zero:
        k = 0
        while k < num and vals[k] < 0.0:
            k += 1
        for j in range(num, k, -1):
            vals[j] = vals[j - 1]
        vals[k] = 0.0
        return vals
    return vals[:num]


@numba.njit(cache=True)
def _sample_window(vx: float, vy: float, wz: float, vmin: FloatArray, vmax: FloatArray,
                   acc: FloatArray, decel: FloatArray, acc_time: float, samples: IntArray,
                   max_speed_xy: float, min_speed_xy: float,
                   min_speed_theta: float) -> FloatArray:
    """Axis samples, their x-major product and ``isValidSpeed`` in one compiled pass
    (same values and order as :meth:`StandardTrajectoryGenerator.sample_velocities_numpy`)."""
    xs = _axis(vx, vmin[0], vmax[0], acc[0], decel[0], acc_time, samples[0])
    ys = _axis(vy, vmin[1], vmax[1], acc[1], decel[1], acc_time, samples[1])
    ths = _axis(wz, vmin[2], vmax[2], acc[2], decel[2], acc_time, samples[2])
    out = np.empty((xs.shape[0] * ys.shape[0] * ths.shape[0], 3))
    n = 0
    check_max = max_speed_xy >= 0.0
    max_sq = max_speed_xy ** 2 + EPSILON
    check_min = min_speed_xy >= 0.0 and min_speed_theta >= 0.0
    min_sq = min_speed_xy ** 2
    for a in xs:
        for b in ys:
            vmag_sq = a ** 2 + b ** 2
            for c in ths:
                if check_max and not vmag_sq <= max_sq:
                    continue
                if check_min and (vmag_sq + EPSILON < min_sq
                                  and abs(c) + EPSILON < min_speed_theta):
                    continue
                if vmag_sq == 0.0 and c == 0.0:
                    continue
                out[n, 0] = a
                out[n, 1] = b
                out[n, 2] = c
                n += 1
    return out[:n].copy()


class LimitedAccelGenerator(StandardTrajectoryGenerator):
    """``dwb_plugins::LimitedAccelGenerator``: the commanded velocity holds from the first step.

    The window already limits commands to what one controller period can reach, so the
    rollout applies the command directly instead of ramping toward it.
    """

    ramp_velocity = False


TRAJECTORY_GENERATORS: PluginRegistry[type[StandardTrajectoryGenerator]] = PluginRegistry(
    "dwb trajectory generator")
TRAJECTORY_GENERATORS.register("StandardTrajectoryGenerator", StandardTrajectoryGenerator,
                               aliases=("dwb_plugins::StandardTrajectoryGenerator",))
TRAJECTORY_GENERATORS.register("LimitedAccelGenerator", LimitedAccelGenerator,
                               aliases=("dwb_plugins::LimitedAccelGenerator",))
