"""MPPI rollout kernel: noised controls -> velocities -> poses, plus the control cost.

Nav2's ``Optimizer::generateNoisedTrajectories`` in one ``numba.njit`` pass:

* **noised controls** ``v = u + eps`` (``NoiseGenerator::setNoisedControls``);
* **motion model** (``MotionModel::predict``): the velocity of step 0 is the robot's;
  the velocity of step ``t >= 1`` is control ``t - 1`` clamped to what the velocity of
  step ``t - 1`` reaches in ``model_dt`` (``clampVelocityByAccel``: ``ax_max``/``ax_min``
  act on the speed magnitude, ``az_max`` symmetrically).  The clamped controls are
  written back - they are what the softmax averages; the last control, which drives no
  step, stays raw as in Nav2;
* **integration** (``integrateStateVelocities``): ``yaw_t = yaw_{t-1} + wz_t dt`` and
  ``x_t = x_{t-1} + (vx_t cos yaw_{t-1} - vy_t sin yaw_{t-1}) dt`` (the previous pose's
  heading, Nav2's rolled cosine).  The heading's cosine/sine advance by a rotation of
  ``wz dt`` whose cos/sin are Taylor polynomials (error < 3e-10 for ``|wz dt| <= 0.5``,
  libm beyond);
* the **control cost** of the information-theoretic update, ``gamma / std^2 *
  sum_t u_t (v_t - u_t)`` per channel (Williams et al., "Information Theoretic MPC for
  Model-Based Reinforcement Learning", ICRA 2017, sec. III; Nav2
  ``updateControlSequence``), which initialises each sample's cost;
* each trajectory's travelled length (for the furthest-reached path point).

Arrays are laid out ``(channel, time, sample)`` so the inner loop runs over samples with
unit stride and vectorises; positions are integrated relative to the robot in float32
and stored as absolute float32 coordinates (Nav2 uses float throughout).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

D_DT, D_AX_MAX, D_AX_MIN, D_AY_MAX, D_AY_MIN, D_AZ_MAX = 0, 1, 2, 3, 4, 5
D_GAMMA_VX, D_GAMMA_VY, D_GAMMA_WZ = 6, 7, 8
D_SIZE = 9
"""Layout of the ``dyn`` parameter vector."""

FloatArray = NDArray[np.float64]
Float32Array = NDArray[np.float32]


@numba.njit(cache=True, fastmath=True)
def rollout(cs: FloatArray, noise: Float32Array, state: FloatArray, dyn: FloatArray,
            holonomic: bool, controls: Float32Array, traj: Float32Array, costs: FloatArray,
            arc: FloatArray) -> None:
    """Roll out every sample.

    ``cs`` (3, T) control sequence rows vx, vy, wz; ``noise`` and ``controls``
    (3, T, B); ``state`` (6,) robot x, y, yaw, vx, vy, wz; ``dyn`` (``D_SIZE``,);
    outputs ``traj`` (3, T, B) x, y, yaw, ``costs`` (B,) the control cost, ``arc`` (B,)
    the travelled length.
    """
    n_steps, batch = noise.shape[1], noise.shape[2]
    f32 = np.float32
    dt = f32(dyn[D_DT])
    dvx_max, dvx_min = f32(dyn[D_DT] * dyn[D_AX_MAX]), f32(dyn[D_DT] * dyn[D_AX_MIN])
    dvy_max, dvy_min = f32(dyn[D_DT] * dyn[D_AY_MAX]), f32(dyn[D_DT] * dyn[D_AY_MIN])
    dwz = f32(dyn[D_DT] * dyn[D_AZ_MAX])
    g_vx, g_vy, g_wz = f32(dyn[D_GAMMA_VX]), f32(dyn[D_GAMMA_VY]), f32(dyn[D_GAMMA_WZ])
    x0, y0, yaw0 = f32(state[0]), f32(state[1]), f32(state[2])
    vx = np.full(batch, f32(state[3]))
    vy = np.full(batch, f32(state[4] if holonomic else 0.0))
    wz = np.full(batch, f32(state[5]))
    rx = np.zeros(batch, dtype=np.float32)
    ry = np.zeros(batch, dtype=np.float32)
    ryaw = np.zeros(batch, dtype=np.float32)
    c = np.full(batch, f32(math.cos(state[2])))
    s = np.full(batch, f32(math.sin(state[2])))
    gamma = np.zeros(batch, dtype=np.float32)
    length = np.zeros(batch, dtype=np.float32)
    c2, c4, c6, c8 = f32(0.5), f32(1.0 / 24.0), f32(1.0 / 720.0), f32(1.0 / 40320.0)
    s3, s5, s7, s9 = f32(1.0 / 6.0), f32(1.0 / 120.0), f32(1.0 / 5040.0), f32(1.0 / 362880.0)
    one = f32(1.0)
    for t in range(n_steps):
        if t > 0:
            # control t-1 becomes the velocity of step t
            u_vx, u_wz = f32(cs[0, t - 1]), f32(cs[2, t - 1])
            for i in range(batch):
                p = vx[i]
                pos = p >= 0.0
                lo = p + dvx_min if pos else p - dvx_max
                hi = p + dvx_max if pos else p - dvx_min
                v = min(max(u_vx + noise[0, t - 1, i], lo), hi)
                w = min(max(u_wz + noise[2, t - 1, i], wz[i] - dwz), wz[i] + dwz)
                vx[i] = v
                wz[i] = w
                controls[0, t - 1, i] = v
                controls[2, t - 1, i] = w
                gamma[i] += g_vx * u_vx * (v - u_vx) + g_wz * u_wz * (w - u_wz)
            if holonomic:
                u_vy = f32(cs[1, t - 1])
                for i in range(batch):
                    p = vy[i]
                    pos = p >= 0.0
                    lo = p + dvy_min if pos else p - dvy_max
                    hi = p + dvy_max if pos else p - dvy_min
                    v = min(max(u_vy + noise[1, t - 1, i], lo), hi)
                    vy[i] = v
                    controls[1, t - 1, i] = v
                    gamma[i] += g_vy * u_vy * (v - u_vy)
                    length[i] += dt * math.sqrt(vx[i] * vx[i] + v * v)
            else:
                for i in range(batch):
                    length[i] += dt * abs(vx[i])
        turn = f32(0.0)
        for i in range(batch):
            ci, si = c[i], s[i]
            rx[i] += (vx[i] * ci - vy[i] * si) * dt
            ry[i] += (vx[i] * si + vy[i] * ci) * dt
            a = wz[i] * dt
            ryaw[i] += a
            turn += one if abs(a) > 0.5 else f32(0.0)  # a count: vectorises, max() does not
            a2 = a * a
            ca = one - a2 * (c2 - a2 * (c4 - a2 * (c6 - a2 * c8)))
            sa = a * (one - a2 * (s3 - a2 * (s5 - a2 * (s7 - a2 * s9))))
            c[i] = ci * ca - si * sa
            s[i] = si * ca + ci * sa
            traj[0, t, i] = x0 + rx[i]
            traj[1, t, i] = y0 + ry[i]
            traj[2, t, i] = yaw0 + ryaw[i]
        if turn > 0.0:  # rare: a heading step beyond the polynomial's range
            for i in range(batch):
                c[i] = math.cos(ryaw[i] + state[2])
                s[i] = math.sin(ryaw[i] + state[2])
    # the last control drives no step: Nav2 keeps it raw
    last = n_steps - 1
    u_vx, u_wz, u_vy = f32(cs[0, last]), f32(cs[2, last]), f32(cs[1, last])
    for i in range(batch):
        v = u_vx + noise[0, last, i]
        w = u_wz + noise[2, last, i]
        controls[0, last, i] = v
        controls[2, last, i] = w
        gamma[i] += g_vx * u_vx * (v - u_vx) + g_wz * u_wz * (w - u_wz)
    if holonomic:
        for i in range(batch):
            v = u_vy + noise[1, last, i]
            controls[1, last, i] = v
            gamma[i] += g_vy * u_vy * (v - u_vy)
    for i in range(batch):
        costs[i] = gamma[i]
        arc[i] = length[i]
