"""The vehicles' controller firmware, simulated: commands in, actuator outputs out.

Pure and clocked by the caller (the stack's simulated time).  Each firmware stops the
vehicle on its own when commands stop arriving (``watchdog`` seconds, 0.5 s as the
navigation mux's timeout), which is what a vehicle must do when its link dies.

* :class:`RoverVcu` -- applies the decoded twist as is (skid steer: the VCU turns it
  into track speeds; the simulator's diff-drive model is that base).
* :class:`CartUno` -- the golf cart's Arduino Uno.  Speed: a PID on |speed| with
  output limits 0..21 (the Arduino's ``SetOutputLimits(0, 21)``) and a feed-forward of
  the setpoint; the output is the throttle of the cart's motor controller, which asks
  the motor for ``throttle * 0.25`` m/s (21 = 5.25 m/s, the cart's top speed), in the
  direction the setpoint's sign selects (the forward/reverse switch).  The gains are
  low (Kp 0.3, Ki 0.1 per m/s): the feed-forward does the work.
  The PID closes its loop on the drive's own speed (the motor controller's encoder;
  in simulation the true speed), and holds its integral during the acceleration-limited
  ramps (integral separation), so on the simulator's vehicle model it is transparent:
  the cart accelerates at the model's limit and settles on the setpoint, exactly as
  the in-process run's robot does (the hardware-in-the-loop comparison's premise).
  Steering: the stepper drives the wheels toward the commanded whole step count at a
  finite rate.  That rate is the simulator's Ackermann steering slew
  (``max_steering_rate``; 0.6 rad/s = 299 steps/s for the cart), so the Uno hands the
  vehicle model the angle its stepper is heading for and the model moves the wheels:
  one slew, not two.  (A second rate limit in the firmware made the model trail the
  stepper by one actuation tick, and a stepper that banked steps while it stood jumped
  up to a second's worth of steps at once: the cart through the wire steered 0.03 rad
  off the in-process run within 0.2 s of its first command.)
* :class:`CartMega` -- the sensor Arduino: wheel pulses from the distance the wheel
  turned, the pulse-period speed, and the IMU "raw" values a real MPU9250 would give
  before the calibration ``A (raw - b)`` (see :mod:`navstack.drivers.cart_sensors`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Twist2D
from navstack.drivers.cart_sensors import (
    PULSE_DISTANCE,
    CartSensorSample,
    WheelPulseSpeed,
    encode_sensor_line,
)
from navstack.drivers.golf_cart import STEPS_PER_RAD, CartCommand
from navstack.drivers.rover_vcu import VcuCommand

__all__ = ["CartMega", "CartUno", "RoverVcu", "SpeedPid"]

THROTTLE_MAX = 21.0
MPS_PER_THROTTLE = 0.25


@dataclass
class RoverVcu:
    """The rover's VCU: the last command, zero after ``watchdog`` seconds without one."""

    watchdog: float = 0.5
    command: VcuCommand | None = None
    received_at: float = -math.inf

    def receive(self, cmd: VcuCommand, now: float) -> None:
        self.command, self.received_at = cmd, now

    def output(self, now: float) -> Twist2D:
        if self.command is None or now - self.received_at > self.watchdog:
            return Twist2D()
        return Twist2D(self.command.linear_x, 0.0, self.command.angular_z)


@dataclass
class SpeedPid:
    """Arduino-PID-style controller: ``u = ff + Kp e + Ki int(e)``, clamped to
    [0, ``out_max``].

    Anti-windup twice over: the integral is frozen while the output is at a limit
    (conditional integration) and while the error is larger than ``integral_band``
    (integral separation) -- the motor's acceleration limit, not the PID, sets the pace
    of a speed change, and integrating the error of that ramp would overshoot the
    setpoint once the cart gets there.  The integral only trims the steady state
    (the drive's gain away from the nominal 0.25 m/s per throttle unit).
    """

    kp: float = 0.3
    """Throttle units per m/s of error."""
    ki: float = 0.1
    out_max: float = THROTTLE_MAX
    integral_band: float = 0.1
    """|error| [m/s] above which the integral holds."""
    integral: float = 0.0

    def update(self, setpoint: float, measured: float, dt: float) -> float:
        """Throttle for the speed ``setpoint`` >= 0 [m/s]; ``measured`` is the speed in
        the setpoint's direction (negative while the cart still rolls the other way)."""
        error = setpoint - measured
        ff = setpoint / MPS_PER_THROTTLE
        trial = ff + self.kp * error + self.ki * (self.integral + error * dt)
        if 0.0 < trial < self.out_max and abs(error) < self.integral_band:
            self.integral += error * dt
        if setpoint == 0.0:
            self.integral = 0.0
        return min(max(ff + self.kp * error + self.ki * self.integral, 0.0), self.out_max)


@dataclass
class CartUno:
    """The golf cart's steering/speed Arduino (module docstring)."""

    wheelbase: float
    watchdog: float = 0.5
    pid: SpeedPid = field(default_factory=SpeedPid)
    command: CartCommand | None = None
    received_at: float = -math.inf
    target_steps: int = 0
    """The step count the stepper is driving to: the last live command's (held when
    commands stop -- the stepper finishes its move, the cart stops)."""
    throttle: float = 0.0

    def receive(self, cmd: CartCommand, now: float) -> None:
        self.command, self.received_at = cmd, now

    @property
    def steering(self) -> float:
        """Wheel angle the stepper is heading for [rad, positive left]."""
        return -self.target_steps / STEPS_PER_RAD

    def step(self, now: float, dt: float, measured_speed: float) -> Twist2D:
        """Advance the PID by ``dt``; the motion the cart is asked for (the vehicle
        model's steering slew moves the wheels toward :attr:`steering`).

        ``measured_speed``: the drive's signed speed [m/s] (the motor controller's
        encoder, which the PID closes its loop on)."""
        alive = self.command is not None and now - self.received_at <= self.watchdog
        cmd = self.command if alive else None
        if cmd is not None:
            self.target_steps = cmd.steps
        setpoint = cmd.speed if cmd is not None else 0.0
        along = measured_speed if setpoint >= 0.0 else -measured_speed
        self.throttle = self.pid.update(abs(setpoint), along, dt)
        v = math.copysign(self.throttle * MPS_PER_THROTTLE, setpoint) if setpoint else 0.0
        return Twist2D(v, 0.0, v * math.tan(self.steering) / self.wheelbase)


@dataclass
class CartMega:
    """The cart's sensor Arduino: pulses, pulse-period speed and the IMU line.

    ``accel_a``/``accel_b`` and ``mag_a``/``mag_b`` (matrix A, offset b) are the
    calibration the *driver* applies; the simulated sensor reads ``A^-1 x + b`` so the
    calibrated value is ``x``.
    """

    accel_a: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    accel_b: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    mag_a: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    mag_b: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    distance: float = 0.0
    seq: int = 0
    wheel: WheelPulseSpeed = field(default_factory=WheelPulseSpeed)
    speed: float = 0.0
    pulse_speed: bool = False

    @property
    def pulses(self) -> int:
        return math.floor(self.distance / PULSE_DISTANCE)

    def roll(self, wheel_speed: float, dt: float, now: float) -> float:
        """The wheel turned at ``wheel_speed`` [m/s] for ``dt``; the speed reported.

        ``pulse_speed`` picks the Arduino's pulse-period estimate (4 pulses/rev: coarse
        and late at low speed); otherwise the line carries the simulated wheel
        odometry's speed, so a run through the wire sees the same odometry as a run in
        process (the comparison the hardware-in-the-loop acceptance makes)."""
        self.distance += abs(wheel_speed) * dt
        pulse = self.wheel.update(now, self.pulses)
        self.speed = pulse if self.pulse_speed else abs(wheel_speed)
        return self.speed

    def line(self, now: float, accel: tuple[float, float, float],
             gyro: tuple[float, float, float], mag_ut: tuple[float, float, float]) -> bytes:
        """The line for the true (calibrated) IMU values at ``now``."""
        raw_a = np.linalg.solve(self.accel_a, np.asarray(accel)) + self.accel_b
        raw_m = np.linalg.solve(self.mag_a, np.asarray(mag_ut)) + self.mag_b
        sample = CartSensorSample(self.seq, round(now * 1000.0), self.pulses, self.speed,
                                  (float(raw_a[0]), float(raw_a[1]), float(raw_a[2])), gyro,
                                  (float(raw_m[0]), float(raw_m[1]), float(raw_m[2])))
        self.seq += 1
        return encode_sensor_line(sample)
