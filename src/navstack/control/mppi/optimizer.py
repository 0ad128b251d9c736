"""The MPPI optimizer (Nav2 ``mppi::Optimizer``; Williams et al., "Information
Theoretic MPC for Model-Based Reinforcement Learning", ICRA 2017).

One :meth:`Optimizer.evaluate` call is Nav2's ``evalControl``:

1. **prepare** - the initial state is the robot pose and its measured velocity (the
   last command with ``open_loop``); the plan's validity per point is looked up;
2. **optimize**, ``iteration_count`` times:
   a. perturb the control sequence with Gaussian noise and roll every sample out
      through the motion model, acceleration-limited
      (:func:`~navstack.control.mppi.rollout.rollout`), then let every critic add its
      term (:mod:`~navstack.control.mppi.critics`), stopping early if a collision critic
      finds every sample colliding;
   b. add the control-cost term of the information-theoretic update, ``gamma / std^2
      * sum_t u_t (v_t - u_t)`` per channel, where ``u`` is the current sequence and
      ``v`` the sample (Williams et al. 2017, sec. III; Nav2's
      ``updateControlSequence``) - computed inside the rollout kernel;
   c. weight the samples by ``softmax(-(S - min S) / temperature)`` and set the sequence
      to the weighted mean of the sampled controls;
   d. smooth it (Savitzky-Golay) and apply the velocity, acceleration and motion-model
      limits (:mod:`~navstack.control.mppi.control_sequence`);
3. **fallback** - if every sample collides (a collision critic's all-collide flag),
   the sequence and noise are reset and the optimization retried; after
   ``retry_attempt_limit`` retries :class:`OptimizerFailed` is raised;
4. the command is element 0 of the sequence (element 1 when shifting), and the
   sequence is shifted one step for the next cycle if ``shift_control_sequence``.

The ``(3, time_steps, batch_size)`` sample and trajectory buffers are allocated once;
a cycle allocates only per-sample scratch vectors inside the kernels.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from navstack.control.mppi import control_sequence as csq
from navstack.control.mppi.critics import CriticData, RobotShape, load_critics
from navstack.control.mppi.errors import OptimizerFailed
from navstack.control.mppi.models import make_motion_model
from navstack.control.mppi.noise import NoiseGenerator
from navstack.control.mppi.params import MPPIParams
from navstack.control.mppi.rollout import D_GAMMA_VX, D_GAMMA_VY, D_GAMMA_WZ, D_SIZE, rollout
from navstack.costmap.costmap_2d import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)

FloatArray = NDArray[np.float64]


class Optimizer:
    """MPPI sampling, scoring and control-sequence update for one controller."""

    def __init__(self, params: MPPIParams, shape: RobotShape) -> None:
        self.params = p = params
        self.model = make_motion_model(p)
        self.critics = load_critics(p, self.model, shape)
        self.batch_size, self.time_steps = b, t = p.batch_size, p.time_steps
        self.noise = NoiseGenerator(b, t, (p.vx_std, p.vy_std, p.wz_std),
                                    self.model.is_holonomic, p.regenerate_noises, p.seed)
        self.control_sequence = np.zeros((3, t))
        self.control_history = np.zeros((4, 3))
        # (channel, time, sample): the inner loops run over samples with unit stride
        self.controls = np.zeros((3, t, b), dtype=np.float32)
        self.trajectories = np.zeros((3, t, b), dtype=np.float32)
        self.costs = np.zeros(b)
        self.weights = np.full(b, 1.0 / b)
        self.arc = np.zeros(b)
        self.last_command = np.zeros(3)
        self.last_data: CriticData | None = None
        self.optimal_trajectory = np.zeros((t, 3))
        self.limits = (p.vx_min, p.vx_max, p.vy_max, p.wz_max)
        self._accel = p.accel_limits
        self._dyn = np.zeros(D_SIZE)
        self._dyn[:6] = (p.model_dt, *self._accel)
        # control-cost coefficients gamma / std^2 (0 for a channel that is not sampled)
        for slot, std, used in ((D_GAMMA_VX, p.vx_std, True),
                                (D_GAMMA_VY, p.vy_std, self.model.is_holonomic),
                                (D_GAMMA_WZ, p.wz_std, True)):
            self._dyn[slot] = p.gamma / std ** 2 if used and std > 0.0 else 0.0
        self._channels = 0b111 if self.model.is_holonomic else 0b101

    # --- lifecycle ---------------------------------------------------------------------
    def reset(self, reset_speed_limits: bool = False) -> None:
        """Zero the control sequence and history and redraw the noise (``Optimizer::
        reset``); speed limits survive unless ``reset_speed_limits``."""
        self.control_sequence.fill(0.0)
        self.control_history.fill(0.0)
        self.costs.fill(0.0)
        if self.params.open_loop:
            self.last_command.fill(0.0)
        if reset_speed_limits:
            p = self.params
            self.limits = (p.vx_min, p.vx_max, p.vy_max, p.wz_max)
        self.noise.reset()

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2 ``setSpeedLimit``: 0 restores the base limits; otherwise every limit is
        scaled by ``limit / 100`` (percentage) or ``limit / vx_max`` (absolute m/s)."""
        p = self.params
        if limit == 0.0:
            ratio = 1.0
        elif percentage:
            ratio = limit / 100.0
        else:
            ratio = limit / p.vx_max if p.vx_max != 0.0 else 1.0
        self.limits = (p.vx_min * ratio, p.vx_max * ratio, p.vy_max * ratio, p.wz_max * ratio)

    # --- one cycle -----------------------------------------------------------------------
    def evaluate(self, pose: tuple[float, float, float], speed: tuple[float, float, float],
                 path: FloatArray, goal: FloatArray, costmap: Costmap2D) -> FloatArray:
        """The command ``(vx, vy, wz)`` for this cycle (``evalControl``).

        ``pose`` and ``path`` ``(M, 3)`` (pruned plan) are in the costmap frame; ``goal``
        is the full plan's last pose.  Raises :class:`OptimizerFailed` when every sampled
        trajectory collides ``retry_attempt_limit + 1`` times in a row.
        """
        p = self.params
        init = self.last_command if p.open_loop else np.asarray(speed, dtype=np.float64)
        state = np.array([pose[0], pose[1], pose[2], init[0],
                          init[1] if self.model.is_holonomic else 0.0, init[2]])
        track_unknown = costmap.default_value == NO_INFORMATION
        data = CriticData(state, self.controls, self.trajectories, self.arc, self.costs,
                          p.model_dt, self.model, path,
                          self.path_validity(path, costmap, track_unknown),
                          np.asarray(goal, dtype=np.float64),
                          math.hypot(goal[0] - pose[0], goal[1] - pose[1]), costmap,
                          track_unknown)
        self.last_data = data
        attempts = 0
        while True:
            self._optimize(data)
            if not data.fail:
                break
            self.reset()
            attempts += 1
            if attempts > p.retry_attempt_limit:
                raise OptimizerFailed(self.batch_size, data.failed_by, attempts)
        offset = 1 if p.shifts_control_sequence else 0
        command = self.control_sequence[:, offset].copy()
        self.last_command[:] = command
        csq.push_history(self.control_history, command)
        self.optimal_trajectory = self.integrate_sequence(state[:3], self.control_sequence)
        if p.shifts_control_sequence:
            csq.shift(self.control_sequence)
        return command

    def _optimize(self, data: CriticData) -> None:
        """``iteration_count`` rounds of sample -> score -> update; stops early (with
        ``data.fail``) when a collision critic finds every sample colliding."""
        for _ in range(self.params.iteration_count):
            data.fail, data.failed_by = False, ""
            data.furthest_reached_path_point = None
            rollout(self.control_sequence, self.noise.current(), data.state, self._dyn,
                    self.model.is_holonomic, self.controls, self.trajectories, self.costs,
                    self.arc)
            for critic in self.critics:
                critic.score(data)
                if data.fail:
                    return
            self._update_control_sequence()
            self.noise.advance()

    def _update_control_sequence(self) -> None:
        """Softmax-weighted mean of the samples, smoothed and limited.  The control cost
        ``gamma / std^2 * u . (v - u)`` is already in ``costs`` (added by the rollout)."""
        p = self.params
        seq = self.control_sequence
        self.weights = softmax_weights(self.costs, p.temperature)
        csq.weighted_mean(self.controls, self.weights, self._channels, seq)
        csq.savitzky_golay(seq, self.control_history, p.sgf_order)
        vx_min, vx_max, vy_max, wz_max = self.limits
        csq.apply_sequence_limits(seq, self.model, vx_min=vx_min, vx_max=vx_max,
                                  vy_max=vy_max, wz_max=wz_max, dt=p.model_dt,
                                  accel=self._accel)

    # --- helpers -----------------------------------------------------------------------
    @staticmethod
    def path_validity(path: FloatArray, costmap: Costmap2D,
                      track_unknown: bool) -> NDArray[np.bool_]:
        """Path points on the map and not in (inscribed) collision (``findPathCosts``)."""
        if len(path) == 0:
            return np.zeros(0, dtype=np.bool_)
        mx, my, inside = costmap.world_to_map_array(path[:, :2])
        cost = np.full(len(path), NO_INFORMATION, dtype=np.int64)
        cost[inside] = costmap.data[my[inside], mx[inside]]
        valid = inside & (cost != LETHAL_OBSTACLE) & (cost != INSCRIBED_INFLATED_OBSTACLE)
        if not track_unknown:
            valid &= cost != NO_INFORMATION
        return valid

    def integrate_sequence(self, pose: FloatArray, seq: FloatArray) -> FloatArray:
        """Poses ``(T, 3)`` reached by driving ``seq`` from ``pose``
        (``getOptimizedTrajectory``)."""
        dt = self.params.model_dt
        yaw = pose[2] + np.cumsum(seq[2] * dt)
        prev = np.concatenate(([pose[2]], yaw[:-1]))
        c, s = np.cos(prev), np.sin(prev)
        vy = seq[1] if self.model.is_holonomic else 0.0
        x = pose[0] + np.cumsum((seq[0] * c - vy * s) * dt)
        y = pose[1] + np.cumsum((seq[0] * s + vy * c) * dt)
        return np.column_stack((x, y, yaw))


def softmax_weights(costs: FloatArray, temperature: float) -> FloatArray:
    """``exp(-(S - min S) / temperature)`` normalised to sum 1 (MPPI importance
    weights; the minimum shift keeps the exponent <= 0 so nothing overflows)."""
    z = np.exp(-(costs - costs.min()) / temperature)
    total = float(z.sum())
    if not math.isfinite(total) or total <= 0.0:
        z = (costs == costs.min()).astype(np.float64)
        total = float(z.sum())
    z /= total
    return z
