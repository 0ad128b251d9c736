"""Velocity critics: Constraint, PreferForward, Twirling, VelocityDeadband (Nav2
``mppi::critics``).

Each scores the state velocities of a trajectory (step 0 the robot's own, step
``t >= 1`` the clamped control ``t - 1``):

* **ConstraintCritic** ``sum_t (max(vx - vx_max, 0) + max(vx_min - vx, 0) + extra) * dt``,
  ``extra`` = ``max(|vy| - vy_max, 0)`` for Omni (Nav2's axis-wise check) or
  ``max(min_turning_r - |vx| / |wz|, 0)`` for Ackermann.  The limits are the configured
  ones (Nav2 reads them once; speed limits clip the control sequence instead);
* **PreferForwardCritic** ``sum_t max(-vx, 0) * dt``, off within
  ``threshold_to_consider`` of the goal;
* **TwirlingCritic** ``mean_t |wz|``, off within the goal tolerance;
* **VelocityDeadbandCritic** ``sum_t (max(d_vx - |vx|, 0) + max(d_wz - |wz|, 0)
  [+ max(d_vy - |vy|, 0)]) * dt`` for ``deadband_velocities = [d_vx, d_vy, d_wz]``.

Every term is ``(raw * cost_weight) ** cost_power``.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.control.mppi.critics.base import (
    Critic,
    CriticData,
    WeightedCriticParams,
    register_critic,
)
from navstack.control.mppi.models import KIND_ACKERMANN, KIND_OMNI

FloatArray = NDArray[np.float64]
Float32Array = NDArray[np.float32]

@numba.njit(cache=True, fastmath=True)
def constraint_critic(controls: Float32Array, init: FloatArray, kind: int, vx_max: float,
                      vx_min: float, vy_max: float, min_turning_r: float, scale: float,
                      power: float, costs: FloatArray) -> None:
    """ConstraintCritic: ``(scale * sum_t violation_t) ** power`` over ``controls``
    (3, T, B) with ``init`` (3,) the step-0 velocity."""
    n_steps, batch = controls.shape[1], controls.shape[2]
    f32 = np.float32
    hi, lo, vy_hi, r = f32(vx_max), f32(vx_min), f32(vy_max), f32(min_turning_r)
    zero, eps = f32(0.0), f32(1e-6)
    first = max(init[0] - vx_max, 0.0) + max(vx_min - init[0], 0.0)
    if kind == KIND_OMNI:
        first += max(abs(init[1]) - vy_max, 0.0)
    elif kind == KIND_ACKERMANN:
        first += max(min_turning_r - abs(init[0]) / max(abs(init[2]), 1e-6), 0.0)
    acc = np.full(batch, f32(first))
    for t in range(n_steps - 1):
        for i in range(batch):
            vx = controls[0, t, i]
            acc[i] += max(vx - hi, zero) + max(lo - vx, zero)
        if kind == KIND_OMNI:
            for i in range(batch):
                acc[i] += max(abs(controls[1, t, i]) - vy_hi, zero)
        elif kind == KIND_ACKERMANN:
            for i in range(batch):
                ratio = abs(controls[0, t, i]) / max(abs(controls[2, t, i]), eps)
                acc[i] += max(r - ratio, zero)
    _finish(acc, scale, power, costs)


@numba.njit(cache=True, fastmath=True)
def prefer_forward_critic(controls: Float32Array, init: FloatArray, scale: float,
                          power: float, costs: FloatArray) -> None:
    """PreferForwardCritic: ``(scale * sum_t max(-vx_t, 0)) ** power``."""
    n_steps, batch = controls.shape[1], controls.shape[2]
    zero = np.float32(0.0)
    acc = np.full(batch, np.float32(max(-init[0], 0.0)))
    for t in range(1, n_steps):
        for i in range(batch):
            acc[i] += max(-controls[0, t - 1, i], zero)
    _finish(acc, scale, power, costs)


@numba.njit(cache=True, fastmath=True)
def twirling_critic(controls: Float32Array, init: FloatArray, scale: float, power: float,
                    costs: FloatArray) -> None:
    """TwirlingCritic: ``(scale * sum_t |wz_t|) ** power``."""
    n_steps, batch = controls.shape[1], controls.shape[2]
    acc = np.full(batch, np.float32(abs(init[2])))
    for t in range(1, n_steps):
        for i in range(batch):
            acc[i] += abs(controls[2, t - 1, i])
    _finish(acc, scale, power, costs)


@numba.njit(cache=True, fastmath=True)
def deadband_critic(controls: Float32Array, init: FloatArray, holonomic: bool,
                    band: FloatArray, scale: float, power: float, costs: FloatArray) -> None:
    """VelocityDeadbandCritic: ``(scale * sum_t sum_axis max(d - |v|, 0)) ** power``
    with ``band`` (3,) = |deadband_velocities|."""
    n_steps, batch = controls.shape[1], controls.shape[2]
    f32 = np.float32
    dvx, dvy, dwz, zero = f32(band[0]), f32(band[1]), f32(band[2]), f32(0.0)
    first = max(band[0] - abs(init[0]), 0.0) + max(band[2] - abs(init[2]), 0.0)
    if holonomic:
        first += max(band[1] - abs(init[1]), 0.0)
    acc = np.full(batch, f32(first))
    for t in range(1, n_steps):
        for i in range(batch):
            acc[i] += (max(dvx - abs(controls[0, t - 1, i]), zero)
                       + max(dwz - abs(controls[2, t - 1, i]), zero))
        if holonomic:
            for i in range(batch):
                acc[i] += max(dvy - abs(controls[1, t - 1, i]), zero)
    _finish(acc, scale, power, costs)


@numba.njit(cache=True)
def _finish(acc: Float32Array, scale: float, power: float, costs: FloatArray) -> None:
    for i in range(acc.shape[0]):
        v = acc[i] * scale
        costs[i] += v if power == 1.0 else v ** power


class _VelocityCritic(Critic):
    params: WeightedCriticParams

    def _active(self, data: CriticData) -> bool:
        return self.params.enabled


class ConstraintCriticParams(WeightedCriticParams):
    """``ConstraintCritic``: penalises sampled velocities outside ``vx_min..vx_max``
    (and ``|vy| > vy_max`` for Omni, turning radius below ``min_turning_r`` for
    Ackermann), integrated over time (``sum(violation) * model_dt``)."""

    cost_weight: float = Field(4.0, ge=0.0)


@register_critic("ConstraintCritic")
class ConstraintCritic(_VelocityCritic):
    """Penalise sampled velocities outside the kinematic limits."""

    params_model = ConstraintCriticParams
    params: ConstraintCriticParams

    def score(self, data: CriticData) -> None:
        if not self._active(data):
            return
        c, p = self.controller_params, self.params
        constraint_critic(data.controls, data.state[3:], self.model.kind, c.vx_max, c.vx_min,
                          c.vy_max, self.model.min_turning_r, data.model_dt * p.cost_weight,
                          float(p.cost_power), data.costs)


class PreferForwardCriticParams(WeightedCriticParams):
    """``PreferForwardCritic``: integrated reverse speed ``sum(max(-vx, 0)) * dt``,
    active farther than ``threshold_to_consider`` from the goal."""

    cost_weight: float = Field(5.0, ge=0.0)
    threshold_to_consider: float = Field(0.5, ge=0.0)


@register_critic("PreferForwardCritic")
class PreferForwardCritic(_VelocityCritic):
    """Penalise reversing away from the goal."""

    params_model = PreferForwardCriticParams
    params: PreferForwardCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not self._active(data) or data.goal_distance < p.threshold_to_consider:
            return
        prefer_forward_critic(data.controls, data.state[3:], data.model_dt * p.cost_weight,
                              float(p.cost_power), data.costs)


class TwirlingCriticParams(WeightedCriticParams):
    """``TwirlingCritic``: mean |wz| over the trajectory, off within the goal checker's
    xy tolerance (navstack: the controller's ``xy_goal_tolerance``)."""

    cost_weight: float = Field(10.0, ge=0.0)


@register_critic("TwirlingCritic")
class TwirlingCritic(_VelocityCritic):
    """Penalise rotation (holonomic robots that could spin while translating)."""

    params_model = TwirlingCriticParams
    params: TwirlingCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not self._active(data) \
                or data.goal_distance < self.controller_params.xy_goal_tolerance:
            return
        twirling_critic(data.controls, data.state[3:], p.cost_weight / data.controls.shape[1],
                        float(p.cost_power), data.costs)


class VelocityDeadbandCriticParams(WeightedCriticParams):
    """``VelocityDeadbandCritic``: integrated shortfall below ``deadband_velocities``
    ``[vx, vy, wz]`` (robots that cannot move slower than a threshold)."""

    cost_weight: float = Field(35.0, ge=0.0)
    deadband_velocities: tuple[float, float, float] = (0.0, 0.0, 0.0)


@register_critic("VelocityDeadbandCritic")
class VelocityDeadbandCritic(_VelocityCritic):
    """Penalise speeds inside the drive's deadband."""

    params_model = VelocityDeadbandCriticParams
    params: VelocityDeadbandCriticParams

    def score(self, data: CriticData) -> None:
        p = self.params
        if not self._active(data):
            return
        band = np.abs(np.asarray(p.deadband_velocities, dtype=np.float64))
        deadband_critic(data.controls, data.state[3:], self.model.is_holonomic, band,
                        data.model_dt * p.cost_weight, float(p.cost_power), data.costs)
