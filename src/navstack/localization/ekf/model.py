"""State layout, omnidirectional process model, its Jacobian and the Kalman kernels.

The state is robot_localization's 15-vector (Moore & Stouch, "A Generalized Extended
Kalman Filter Implementation for the Robot Operating System", IAS-13, 2014, section III)::

    [x, y, z, roll, pitch, yaw, vx, vy, vz, vroll, vpitch, vyaw, ax, ay, az]

Pose in the world frame (``odom`` or ``map``); velocities and accelerations in the body
frame (``base_link``).  The process model is the omnidirectional kinematic model of
robot_localization's ``Ekf::predict``: body velocity and acceleration rotated into the
world by ``R = Rz(yaw) Ry(pitch) Rx(roll)``::

    p'   = p + R (v dt + a dt^2 / 2)
    rpy' = rpy + E(roll, pitch) w dt      (E maps body rates to Euler-angle rates)
    v'   = v + a dt,   w' = w,   a' = a

The Jacobian here is the exact derivative of that model (robot_localization's hand
derivation drops a sign in d yaw'/d pitch; a test checks ours against finite
differences).  All kernels are ``numba.njit(cache=True)`` and work in place on
preallocated arrays: one predict + correct costs a few microseconds of arithmetic.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "ANGLE_INDICES",
    "AX",
    "AY",
    "AZ",
    "DEFAULT_INITIAL_ESTIMATE_DIAGONAL",
    "DEFAULT_PROCESS_NOISE_DIAGONAL",
    "PITCH",
    "ROLL",
    "STATE_NAMES",
    "STATE_SIZE",
    "TWO_D_INDICES",
    "VPITCH",
    "VROLL",
    "VX",
    "VY",
    "VYAW",
    "VZ",
    "YAW",
    "X",
    "Y",
    "Z",
    "ekf_correct",
    "ekf_predict",
    "process_model",
    "process_model_batch",
    "rotation_rpy",
    "transfer_jacobian",
    "wrap_angle",
]

STATE_SIZE = 15
X, Y, Z, ROLL, PITCH, YAW, VX, VY, VZ, VROLL, VPITCH, VYAW, AX, AY, AZ = range(STATE_SIZE)
STATE_NAMES = ("x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz",
               "vroll", "vpitch", "vyaw", "ax", "ay", "az")
ANGLE_INDICES = (ROLL, PITCH, YAW)
TWO_D_INDICES = (Z, ROLL, PITCH, VZ, VROLL, VPITCH, AZ)
"""Variables ``two_d_mode`` pins to zero (robot_localization's ``forceTwoD``)."""

DEFAULT_PROCESS_NOISE_DIAGONAL = (0.05, 0.05, 0.06, 0.03, 0.03, 0.06, 0.025, 0.025, 0.04,
                                  0.01, 0.01, 0.02, 0.01, 0.01, 0.015)
"""robot_localization's default ``process_noise_covariance`` diagonal (FilterBase::reset)."""
DEFAULT_INITIAL_ESTIMATE_DIAGONAL = (1e-9,) * STATE_SIZE
"""robot_localization's default ``initial_estimate_covariance`` diagonal."""

MIN_MEASUREMENT_VARIANCE = 1e-9
"""Floor on a measured variance (robot_localization ``Ekf::correct``): a zero variance on
a variable whose state variance is also ~0 would make the gain blow up."""


@nb.njit(cache=True)
def wrap_angle(a: float) -> float:
    """Angle in ``(-pi, pi]``."""
    if -math.pi < a <= math.pi:
        return a
    a -= 2.0 * math.pi * math.floor((a + math.pi) / (2.0 * math.pi))
    return math.pi if a <= -math.pi else a


@nb.njit(cache=True)
def rotation_rpy(roll: float, pitch: float, yaw: float) -> NDArray[np.float64]:
    """``Rz(yaw) Ry(pitch) Rx(roll)``: body -> world rotation (3, 3)."""
    sr, cr = math.sin(roll), math.cos(roll)
    sp, cp = math.sin(pitch), math.cos(pitch)
    sy, cy = math.sin(yaw), math.cos(yaw)
    r = np.empty((3, 3))
    r[0, 0] = cy * cp
    r[0, 1] = cy * sp * sr - sy * cr
    r[0, 2] = cy * sp * cr + sy * sr
    r[1, 0] = sy * cp
    r[1, 1] = sy * sp * sr + cy * cr
    r[1, 2] = sy * sp * cr - cy * sr
    r[2, 0] = -sp
    r[2, 1] = cp * sr
    r[2, 2] = cp * cr
    return r


@nb.njit(cache=True)
def process_model(x: NDArray[np.float64], dt: float, out: NDArray[np.float64]) -> None:
    """``out = f(x, dt)`` (``out`` may be ``x``); angles wrapped to (-pi, pi]."""
    roll, pitch, yaw = x[ROLL], x[PITCH], x[YAW]
    r = rotation_rpy(roll, pitch, yaw)
    h = 0.5 * dt * dt
    u0 = x[VX] * dt + x[AX] * h
    u1 = x[VY] * dt + x[AY] * h
    u2 = x[VZ] * dt + x[AZ] * h
    sr, cr = math.sin(roll), math.cos(roll)
    cp = math.cos(pitch)
    tp = math.tan(pitch)
    wr, wp, wy = x[VROLL], x[VPITCH], x[VYAW]
    px = x[X] + r[0, 0] * u0 + r[0, 1] * u1 + r[0, 2] * u2
    py = x[Y] + r[1, 0] * u0 + r[1, 1] * u1 + r[1, 2] * u2
    pz = x[Z] + r[2, 0] * u0 + r[2, 1] * u1 + r[2, 2] * u2
    nroll = roll + dt * (wr + sr * tp * wp + cr * tp * wy)
    npitch = pitch + dt * (cr * wp - sr * wy)
    nyaw = yaw + dt * (sr * wp + cr * wy) / cp
    vx, vy, vz = x[VX] + x[AX] * dt, x[VY] + x[AY] * dt, x[VZ] + x[AZ] * dt
    for i in range(VROLL, STATE_SIZE):
        out[i] = x[i]
    out[X], out[Y], out[Z] = px, py, pz
    out[ROLL], out[PITCH], out[YAW] = wrap_angle(nroll), wrap_angle(npitch), wrap_angle(nyaw)
    out[VX], out[VY], out[VZ] = vx, vy, vz


@nb.njit(cache=True)
def process_model_batch(xs: NDArray[np.float64], dt: float) -> None:
    """Apply :func:`process_model` in place to every row of ``xs`` (n, 15) (UKF sigma
    points)."""
    for k in range(xs.shape[0]):
        process_model(xs[k], dt, xs[k])


@nb.njit(cache=True)
def transfer_jacobian(x: NDArray[np.float64], dt: float, J: NDArray[np.float64]) -> None:
    """``J = df/dx`` (15, 15) of :func:`process_model` at ``x``, written in place."""
    roll, pitch, yaw = x[ROLL], x[PITCH], x[YAW]
    sr, cr = math.sin(roll), math.cos(roll)
    sp, cp = math.sin(pitch), math.cos(pitch)
    sy, cy = math.sin(yaw), math.cos(yaw)
    cpi = 1.0 / cp
    tp = sp * cpi
    h = 0.5 * dt * dt
    u0 = x[VX] * dt + x[AX] * h
    u1 = x[VY] * dt + x[AY] * h
    u2 = x[VZ] * dt + x[AZ] * h
    wp, wy = x[VPITCH], x[VYAW]
    r = rotation_rpy(roll, pitch, yaw)
    J[:, :] = 0.0
    for i in range(STATE_SIZE):
        J[i, i] = 1.0
    for i in range(3):
        for j in range(3):
            J[i, VX + j] = r[i, j] * dt
            J[i, AX + j] = r[i, j] * h
        J[VX + i, AX + i] = dt
    # d(R u)/d roll, pitch, yaw: the derivatives of R's columns (R = Rz Ry Rx)
    J[X, ROLL] = (cy * sp * cr + sy * sr) * u1 + (-cy * sp * sr + sy * cr) * u2
    J[Y, ROLL] = (sy * sp * cr - cy * sr) * u1 + (-sy * sp * sr - cy * cr) * u2
    J[Z, ROLL] = cp * cr * u1 - cp * sr * u2
    J[X, PITCH] = -cy * sp * u0 + cy * cp * sr * u1 + cy * cp * cr * u2
    J[Y, PITCH] = -sy * sp * u0 + sy * cp * sr * u1 + sy * cp * cr * u2
    J[Z, PITCH] = -cp * u0 - sp * sr * u1 - sp * cr * u2
    J[X, YAW] = -sy * cp * u0 + (-sy * sp * sr - cy * cr) * u1 + (-sy * sp * cr + cy * sr) * u2
    J[Y, YAW] = cy * cp * u0 + (cy * sp * sr - sy * cr) * u1 + (cy * sp * cr + sy * sr) * u2
    # Euler-angle kinematics: rpy' = rpy + E(roll, pitch) w dt
    J[ROLL, ROLL] = 1.0 + dt * (cr * tp * wp - sr * tp * wy)
    J[ROLL, PITCH] = dt * (sr * wp + cr * wy) * cpi * cpi
    J[ROLL, VROLL] = dt
    J[ROLL, VPITCH] = dt * sr * tp
    J[ROLL, VYAW] = dt * cr * tp
    J[PITCH, ROLL] = dt * (-sr * wp - cr * wy)
    J[PITCH, VPITCH] = dt * cr
    J[PITCH, VYAW] = -dt * sr
    J[YAW, ROLL] = dt * (cr * wp - sr * wy) * cpi
    J[YAW, PITCH] = dt * (sr * wp + cr * wy) * tp * cpi
    J[YAW, VPITCH] = dt * sr * cpi
    J[YAW, VYAW] = dt * cr * cpi


@nb.njit(cache=True)
def ekf_predict(x: NDArray[np.float64], P: NDArray[np.float64], Q: NDArray[np.float64],
                dt: float, dynamic_noise: bool, J: NDArray[np.float64]) -> None:
    """EKF time update in place: ``x = f(x)``, ``P = J P J^T + dt Q``.

    ``dynamic_noise`` scales the pose block of ``Q`` by ``|twist|^2`` first
    (robot_localization ``dynamic_process_noise_covariance``: a robot at rest gains no
    pose uncertainty).  ``J`` is a (15, 15) work array (left holding the Jacobian)."""
    transfer_jacobian(x, dt, J)
    scale = 0.0
    if dynamic_noise:
        for i in range(VX, VYAW + 1):
            scale += x[i] * x[i]
    process_model(x, dt, x)
    P[:, :] = J @ P @ J.T
    for i in range(STATE_SIZE):
        for j in range(STATE_SIZE):
            q = Q[i, j]
            if dynamic_noise and i < VX and j < VX:
                q *= scale
            P[i, j] += dt * q
    for i in range(STATE_SIZE):  # keep P exactly symmetric
        for j in range(i + 1, STATE_SIZE):
            m = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = m
            P[j, i] = m


@nb.njit(cache=True)
def ekf_correct(x: NDArray[np.float64], P: NDArray[np.float64], z: NDArray[np.float64],
                R: NDArray[np.float64], idx: NDArray[np.int64],
                threshold: float) -> float:
    """EKF measurement update of the variables ``idx`` in place.

    ``z`` (15,) and ``R`` (15, 15) are full-size; only rows/columns ``idx`` are read
    (H selects state variables, as robot_localization's update vectors do).  Negative
    measured variances are made positive and tiny ones floored at 1e-9 (as
    ``Ekf::correct``); angle innovations are wrapped.  Returns the squared Mahalanobis
    distance of the innovation; if it is ``>= threshold^2`` (robot_localization's
    ``*_rejection_threshold`` in standard deviations) nothing is changed and the caller
    sees a value ``>= threshold^2``.  The covariance uses the Joseph form
    ``(I - KH) P (I - KH)^T + K R K^T`` (stays symmetric positive semi-definite)."""
    m = idx.shape[0]
    S = np.empty((m, m))
    Rs = np.empty((m, m))
    PHt = np.empty((STATE_SIZE, m))
    nu = np.empty(m)
    for a in range(m):
        ia = idx[a]
        for b in range(m):
            Rs[a, b] = R[ia, idx[b]]
        d = abs(Rs[a, a])
        Rs[a, a] = d if d >= MIN_MEASUREMENT_VARIANCE else MIN_MEASUREMENT_VARIANCE
        for i in range(STATE_SIZE):
            PHt[i, a] = P[i, ia]
        v = z[ia] - x[ia]
        if ROLL <= ia <= YAW:
            v = wrap_angle(v)
        nu[a] = v
    for a in range(m):
        for b in range(m):
            S[a, b] = PHt[idx[a], b] + Rs[a, b]
    Sinv = np.linalg.inv(S)
    w = Sinv @ nu
    d2 = 0.0
    for a in range(m):
        d2 += nu[a] * w[a]
    if not d2 < threshold * threshold:
        return d2
    K = PHt @ Sinv
    for i in range(STATE_SIZE):
        acc = 0.0
        for a in range(m):
            acc += K[i, a] * nu[a]
        x[i] += acc
    IKH = np.eye(STATE_SIZE)
    for a in range(m):
        ia = idx[a]
        for i in range(STATE_SIZE):
            IKH[i, ia] -= K[i, a]
    P[:, :] = IKH @ P @ IKH.T + K @ Rs @ K.T
    for i in range(STATE_SIZE):
        for j in range(i + 1, STATE_SIZE):
            mm = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = mm
            P[j, i] = mm
    x[ROLL] = wrap_angle(x[ROLL])
    x[PITCH] = wrap_angle(x[PITCH])
    x[YAW] = wrap_angle(x[YAW])
    return d2
