"""Motion-shape critics: RotateToGoal, Oscillation, PreferForward, Twirling, RotateBeforeStart.

The first four follow ``dwb_critics`` of the same names; ``RotateBeforeStart`` is a
navstack addition (see its docstring).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.control.dwb.critic_base import (
    CriticContext,
    CriticParams,
    FloatArray,
    TrajectoryCritic,
    register_critic,
)
from navstack.control.dwb.params import DWBParams
from navstack.control.dwb.trajectory_generator import TrajectoryBatch
from navstack.core.geometry import angle_diff
from navstack.core.msgs import Pose2D, Twist2D
from navstack.core.polygon import Footprint

_SPEED_EPS = 1e-12


def _end_yaw(batch: TrajectoryBatch, lookahead_time: float) -> FloatArray:
    """Yaw scored for rotation: at ``lookahead_time`` if >= 0, else the final pose's."""
    if lookahead_time >= 0.0:
        return batch.pose_at_time(lookahead_time)[:, 2]
    return batch.final_poses()[:, 2]


def _stop_then_turn(batch: TrajectoryBatch, current_speed_sq: float, rotating: bool,
                    slowing_factor: float, heading_error: FloatArray) -> FloatArray:
    """Shared scoring of "slow down, then rotate in place" critics.

    Before ``rotating``: samples not slower than now are rejected (code 1), the rest
    score ``speed^2 * slowing_factor + heading_error``.  While ``rotating``: samples that
    translate are rejected (code 2) and pure rotations score ``heading_error``.  With the
    controller-period dynamic window a moving robot may not reach zero translation in
    one cycle; then the slowest reachable translation counts as "not translating", so
    the robot brakes while it turns instead of every sample being rejected (with Nav2's
    full-range window zero is always reachable and this is exactly Nav2's rule).
    """
    speed_sq = batch.velocities[:, 0] ** 2 + batch.velocities[:, 1] ** 2
    if not rotating:
        scores = speed_sq * slowing_factor + heading_error
        return np.where(speed_sq >= current_speed_sq, -1.0, scores)
    slowest = float(speed_sq.min()) if len(speed_sq) else 0.0
    return np.where(speed_sq > slowest + _SPEED_EPS, -2.0, heading_error)


class RotateToGoalParams(CriticParams):
    """``slowing_factor`` weights speed while braking; ``lookahead_time`` < 0 scores the end yaw."""

    slowing_factor: float = 5.0
    lookahead_time: float = -1.0


@register_critic("RotateToGoal")
class RotateToGoalCritic(TrajectoryCritic[RotateToGoalParams]):
    """Within ``xy_goal_tolerance`` of the goal: stop, then only rotate toward the goal yaw.

    ``in_window`` latches once the robot is within the tolerance and ``rotating`` once it
    is also slower than ``trans_stopped_velocity`` (both DWB-level parameters); a new
    plan or reset clears them.  Nav2 scale: 32.
    """

    params_model = RotateToGoalParams
    reasons = ("not slowing down near goal", "translation near goal")
    default_scale = 32.0

    in_window = False
    rotating = False
    current_speed_sq = 0.0
    goal_yaw = 0.0

    def reset(self) -> None:
        self.in_window = False
        self.rotating = False

    def prepare(self, ctx: CriticContext) -> bool:
        d_sq = (ctx.pose.x - ctx.goal.x) ** 2 + (ctx.pose.y - ctx.goal.y) ** 2
        self.in_window = self.in_window or d_sq <= self.dwb.xy_goal_tolerance ** 2
        self.current_speed_sq = ctx.velocity.vx ** 2 + ctx.velocity.vy ** 2
        self.rotating = self.rotating or (
            self.in_window and self.current_speed_sq <= self.dwb.trans_stopped_velocity ** 2)
        self.goal_yaw = ctx.goal.theta
        return True

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        if not self.in_window:
            return np.zeros(len(batch))
        yaw = _end_yaw(batch, self.params.lookahead_time)
        err = np.abs(angle_diff(yaw, np.full_like(yaw, self.goal_yaw)))
        return _stop_then_turn(batch, self.current_speed_sq, self.rotating,
                               self.params.slowing_factor, err)


class OscillationParams(CriticParams):
    """Reset distances/time of the oscillation flags and the x-only threshold (Nav2 defaults)."""

    oscillation_reset_dist: float = 0.05
    oscillation_reset_angle: float = 0.2
    oscillation_reset_time: float = -1.0
    x_only_threshold: float = 0.05


class _CommandTrend:
    """``OscillationCritic::CommandTrend``: remembers a sign flip of one velocity axis."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.sign = 0
        self.positive_only = False
        self.negative_only = False

    def update(self, velocity: float) -> bool:
        flipped = False
        if velocity < 0.0:
            if self.sign > 0:
                self.negative_only = flipped = True
            self.sign = -1
        elif velocity > 0.0:
            if self.sign < 0:
                self.positive_only = flipped = True
            self.sign = 1
        return flipped

    def oscillating(self, velocity: FloatArray) -> NDArray[np.bool_]:
        return (self.positive_only & (velocity < 0.0)) | (self.negative_only & (velocity > 0.0))

    def has_sign_flipped(self) -> bool:
        return self.positive_only or self.negative_only


@register_critic("Oscillation")
class OscillationCritic(TrajectoryCritic[OscillationParams]):
    """Rejects reversing a velocity axis again right after it flipped sign.

    After the chosen command flips the sign of vx (or of vy/wz while
    ``|vx| <= x_only_threshold``), commands going back to the old sign are rejected until
    the robot has moved ``oscillation_reset_dist`` or turned ``oscillation_reset_angle``
    (or ``oscillation_reset_time`` passed, if >= 0) since the flip.
    """

    params_model = OscillationParams
    reasons = ("oscillating",)

    def __init__(self, name: str, params: OscillationParams, dwb: DWBParams,
                 footprint: Footprint | None = None) -> None:
        super().__init__(name, params, dwb, footprint)
        self.x_trend, self.y_trend, self.theta_trend = (_CommandTrend(), _CommandTrend(),
                                                        _CommandTrend())
        self.pose = Pose2D()
        self.prev_stationary_pose = Pose2D()
        self.prev_reset_time = 0.0

    def reset(self) -> None:
        self.x_trend.reset()
        self.y_trend.reset()
        self.theta_trend.reset()

    def prepare(self, ctx: CriticContext) -> bool:
        self.pose = ctx.pose
        return True

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        v = batch.velocities
        bad = (self.x_trend.oscillating(v[:, 0]) | self.y_trend.oscillating(v[:, 1])
               | self.theta_trend.oscillating(v[:, 2]))
        return np.where(bad, -1.0, 0.0)

    def _set_flags(self, cmd: Twist2D) -> bool:
        flag = self.x_trend.update(cmd.vx)
        thr = self.params.x_only_threshold
        if thr < 0.0 or abs(cmd.vx) <= thr:
            flag |= self.y_trend.update(cmd.vy)
            flag |= self.theta_trend.update(cmd.wz)
        return flag

    def _reset_available(self, now: float) -> bool:
        p = self.params
        if p.oscillation_reset_dist >= 0.0 and self.pose.distance_to(
                self.prev_stationary_pose) > p.oscillation_reset_dist:
            return True
        if p.oscillation_reset_angle >= 0.0 and abs(angle_diff(
                self.pose.theta, self.prev_stationary_pose.theta)) > p.oscillation_reset_angle:
            return True
        return p.oscillation_reset_time >= 0.0 and now - self.prev_reset_time > \
            p.oscillation_reset_time

    def debrief(self, cmd: Twist2D, ctx: CriticContext) -> None:
        if self._set_flags(cmd):
            self.prev_stationary_pose = self.pose
            self.prev_reset_time = ctx.now
        flipped = (self.x_trend.has_sign_flipped() or self.y_trend.has_sign_flipped()
                   or self.theta_trend.has_sign_flipped())
        if flipped and self._reset_available(ctx.now):
            self.reset()


class PreferForwardParams(CriticParams):
    """Nav2 defaults: ``penalty`` 1, ``strafe_x`` 0.1, ``strafe_theta`` 0.2, ``theta_scale`` 10."""

    penalty: float = 1.0
    strafe_x: float = 0.1
    strafe_theta: float = 0.2
    theta_scale: float = 10.0


@register_critic("PreferForward")
class PreferForwardCritic(TrajectoryCritic[PreferForwardParams]):
    """Penalises reversing and strafing/creeping; otherwise ``|wz| * theta_scale``."""

    params_model = PreferForwardParams

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        p = self.params
        vx, wz = batch.velocities[:, 0], batch.velocities[:, 2]
        penalised = (vx < 0.0) | ((vx < p.strafe_x) & (np.abs(wz) < p.strafe_theta))
        return np.where(penalised, p.penalty, np.abs(wz) * p.theta_scale)


@register_critic("Twirling")
class TwirlingCritic(TrajectoryCritic[CriticParams]):
    """Cost ``|wz|`` for spinning while driving (Nav2 default scale 0 = off)."""

    default_scale = 0.0

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        return np.abs(batch.velocities[:, 2])


class RotateBeforeStartParams(CriticParams):
    """RPP's ``rotate_to_heading_min_angle``, ``lookahead_dist``; ``slowing_factor`` [s^2/m^2]."""

    rotate_to_heading_min_angle: float = 0.785
    lookahead_dist: float = 0.6
    slowing_factor: float = 5.0


@register_critic("RotateBeforeStart", namespace="navstack")
class RotateBeforeStartCritic(TrajectoryCritic[RotateBeforeStartParams]):
    """navstack addition: turn in place toward the path before starting to follow it.

    Modelled on Regulated Pure Pursuit's ``use_rotate_to_heading``: while the heading
    error to the plan (direction to the plan point ``lookahead_dist`` ahead of the
    closest one) exceeds ``rotate_to_heading_min_angle`` at the start of a plan, the robot
    brakes and then only rotates, scored by the remaining heading error, exactly as
    ``RotateToGoal`` does at the goal.  Once aligned it stays off until the next plan or
    reset, so sharp corners later on are left to the other critics.  Not in the default
    critic list; scale 32 like ``RotateToGoal``.
    """

    params_model = RotateBeforeStartParams
    reasons = ("not slowing down to turn toward the path", "translation before facing the path")
    default_scale = 32.0

    started = False
    active = False
    target_heading = 0.0
    current_speed_sq = 0.0

    def reset(self) -> None:
        self.started = False
        self.active = False

    def _path_heading(self, ctx: CriticContext) -> float | None:
        plan = ctx.plan
        if len(plan) == 0:
            return None
        d = np.hypot(plan[:, 0] - ctx.pose.x, plan[:, 1] - ctx.pose.y)
        closest = int(np.argmin(d))
        ahead = np.nonzero(d[closest:] >= self.params.lookahead_dist)[0]
        target = plan[closest + int(ahead[0])] if len(ahead) else plan[-1]
        if math.hypot(target[0] - ctx.pose.x, target[1] - ctx.pose.y) < 1e-9:
            return None
        return math.atan2(target[1] - ctx.pose.y, target[0] - ctx.pose.x)

    def prepare(self, ctx: CriticContext) -> bool:
        self.active = False
        if self.started:
            return True
        near_goal = ctx.pose.distance_to(ctx.goal) <= self.dwb.xy_goal_tolerance
        heading = None if near_goal else self._path_heading(ctx)
        if heading is None or abs(angle_diff(heading, ctx.pose.theta)) <= \
                self.params.rotate_to_heading_min_angle:
            self.started = True
            return True
        self.active = True
        self.target_heading = heading
        self.current_speed_sq = ctx.velocity.vx ** 2 + ctx.velocity.vy ** 2
        return True

    def score(self, batch: TrajectoryBatch, ctx: CriticContext) -> FloatArray:
        if not self.active:
            return np.zeros(len(batch))
        yaw = batch.final_poses()[:, 2]
        err = np.abs(angle_diff(yaw, np.full_like(yaw, self.target_heading)))
        rotating = self.current_speed_sq <= self.dwb.trans_stopped_velocity ** 2
        return _stop_then_turn(batch, self.current_speed_sq, rotating,
                               self.params.slowing_factor, err)
