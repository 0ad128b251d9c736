"""The simulated golf cart's Uno on the simulator's vehicle model: its speed PID and its
stepper are transparent -- the cart driven through them moves as the in-process robot
does under the same commands (the premise of the hardware-in-the-loop comparison)."""

from __future__ import annotations

import math

import pytest

from navstack.core.msgs import Twist2D
from navstack.drivers.golf_cart import STEPS_PER_RAD, decode_cart_command, encode_cart_command
from navstack.sim.kinematics import Ackermann, RobotState
from navstack.sim.vehicles.firmware import CartUno, SpeedPid

WHEELBASE = 2.4


def _commands(t: float) -> tuple[float, float]:
    """Ramp to 2 m/s while weaving, brake to 0.5 m/s, then reverse slowly."""
    if t < 6.0:
        vx = min(2.0, 0.1 + 0.4 * t)
    elif t < 9.0:
        vx = 0.5
    else:
        vx = -0.3
    return vx, 0.3 * math.sin(t)


def test_uno_on_the_vehicle_model_drives_like_the_model_itself() -> None:
    plant = Ackermann(WHEELBASE, 0.74, 0.6, 2.5, -0.35, 1.0)
    uno = CartUno(WHEELBASE, 0.6 * STEPS_PER_RAD)
    ref = hil = RobotState()
    dt = 0.02
    worst_v = worst_xy = 0.0
    for k in range(600):
        t = k * dt
        vx, wz = _commands(t)
        steer = math.atan(WHEELBASE * wz / vx)
        uno.receive(decode_cart_command(encode_cart_command(vx, steer)), t)
        hil = plant.step(hil, uno.step(t, dt, hil.vx), dt)
        ref = plant.step(ref, Twist2D(vx, 0.0, wz), dt)
        worst_v = max(worst_v, abs(hil.vx - ref.vx))
        worst_xy = max(worst_xy, math.hypot(hil.x - ref.x, hil.y - ref.y))
    assert ref.vx == pytest.approx(-0.3) and hil.vx == pytest.approx(-0.3, abs=0.003)
    assert worst_v < 0.005  # no overshoot after the 1 m/s^2 ramp, none after braking
    assert worst_xy < 0.03  # 12 s, ~15 m: whole 0.002 rad steps (truncated), float32 km/h


def test_pid_holds_its_integral_during_a_ramp_and_trims_the_steady_state() -> None:
    pid = SpeedPid()
    # 1 s of a ramp the motor cannot follow: error 1.5 m/s, outside the band
    for _ in range(50):
        pid.update(2.0, 0.5, 0.02)
    assert pid.integral == 0.0
    # close to the setpoint the integral works (a drive 2 % slow on its throttle)
    v = 1.95
    for _ in range(15000):  # 300 s: Ki is small, the feed-forward does the work
        u = pid.update(2.0, v, 0.02)
        v = 0.98 * u * 0.25
    assert v == pytest.approx(2.0, abs=0.005)
    assert pid.update(0.0, 1.0, 0.02) == 0.0 and pid.integral == 0.0
