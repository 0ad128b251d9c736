"""The TurtleBot course's gripper servo on a Raspberry Pi GPIO pin, through gpiozero.

The course's servo service (``FIELD-ROBOTS.md``): PWM at 50 Hz on BCM pin 20; a request
``(pin, duty)`` with the duty cycle in percent; *open* is duty 2 %, *close* ramps up in
steps of 0.25 % every 0.1 s to 7 % (20 steps from open: the jaws close gently on the
package), and the service replies ``"OK"`` when the servo is there.  Here:

* :class:`ServoParams` -- pin, frequency, open / close duty, ramp step and period, the
  duty range the servo accepts (``min_duty`` .. ``max_duty``: a duty outside it could
  drive the horn against its stops) and the pin factory;
* :meth:`GpioServo.command` -- the service: a duty above the current one is reached by
  the ramp (step ``k`` of ``n`` is written at ``(k - 1) * step_period`` after the request;
  the reply comes one period after the last step, when the servo has had time to get
  there), a duty at or below it is written at once (opening releases at once), and
  ``"OK"`` is returned.  Steps are timed against the start of the request (a monotonic
  clock), so a slow write does not delay the steps after it;
* bad input -- a pin other than the servo's, a duty outside the range or not finite, a
  pin that does not exist -- raises :class:`ServoError` naming the value and the valid
  range; no GPIO (gpiozero missing, no pin factory) raises :class:`ServoUnavailable`.

Conventions as the other GPIO drivers: BCM numbering; the pin factory is chosen per
device (``"default"``: gpiozero's choice on the board; ``"mock"``: gpiozero's
``MockFactory`` with PWM pins, for tests and machines without GPIO; or a factory object),
never through gpiozero's global ``Device.pin_factory``; :meth:`GpioServo.close` returns
the servo to its safe (open) duty and releases the pin.  The bus side is
:class:`navstack.nodes.gripper.GripperServiceNode`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from pydantic import Field, model_validator

from navstack.core.errors import NavstackError
from navstack.core.params import Params
from navstack.drivers.gpio import GpioUnavailable, gpiozero_device, make_pin_factory

__all__ = ["GpioServo", "ServoError", "ServoParams", "ServoUnavailable"]

SPIN_MARGIN = 0.003
"""Seconds before a step's time at which the ramp stops sleeping and polls the clock."""


class ServoError(NavstackError, ValueError):
    """A servo request or setting that cannot be carried out (pin, duty)."""


ServoUnavailable = GpioUnavailable
"""No GPIO: gpiozero missing, no pin factory for this machine, or the pin is busy (the
GPIO drivers' error, :mod:`navstack.drivers.gpio`)."""


class ServoParams(Params):
    """The gripper servo (TurtleBot course defaults); duty cycles in percent."""

    pin: int = Field(default=20, ge=0, le=53)
    frequency: float = Field(default=50.0, gt=0.0, le=10000.0)
    open_duty: float = 2.0
    close_duty: float = 7.0
    ramp_step: float = Field(default=0.25, gt=0.0)
    step_period: float = Field(default=0.1, ge=0.0)
    min_duty: float = Field(default=0.0, ge=0.0, le=100.0)
    max_duty: float = Field(default=12.5, ge=0.0, le=100.0)
    pin_factory: str = "default"
    """"default" (gpiozero's choice for this board) or "mock" (no hardware)."""

    @model_validator(mode="after")
    def _duties_in_range(self) -> ServoParams:
        if self.min_duty >= self.max_duty:
            raise ValueError(f"min_duty {self.min_duty} must be below max_duty {self.max_duty}")
        for key in ("open_duty", "close_duty"):
            value = getattr(self, key)
            if not self.min_duty <= value <= self.max_duty:
                raise ValueError(f"{key} {value} % is outside min_duty..max_duty "
                                 f"({self.min_duty}..{self.max_duty} %)")
        return self


class GpioServo:
    """A hobby servo on one PWM pin (see module docstring).

    ``sleep`` and ``clock`` are injectable (defaults: :func:`time.sleep` and
    :func:`time.monotonic`) for callers that run the ramp on another clock.
    """

    def __init__(self, params: ServoParams | None = None, pin_factory: Any = None,
                 sleep: Callable[[float], None] = time.sleep,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.params = params or ServoParams()
        self._factory = make_pin_factory(
            pin_factory if pin_factory is not None else self.params.pin_factory, pwm=True)
        self._sleep = sleep
        self._clock = clock
        self._device: Any = None
        self.duty = self.params.open_duty
        self.writes: list[tuple[float, float]] = []
        """``(clock time, duty %)`` of every write, for logs and tests."""

    @property
    def factory(self) -> Any:
        """The gpiozero pin factory in use (``None``: gpiozero's default)."""
        return self._factory

    @property
    def is_open(self) -> bool:
        return self._device is not None

    def open(self) -> None:
        """Claim the pin and start PWM at the open duty."""
        if self._device is not None:
            return
        device, gpio_error = gpiozero_device("PWMOutputDevice")
        p = self.params
        try:
            self._device = device(p.pin, frequency=p.frequency,
                                  initial_value=p.open_duty / 100.0, pin_factory=self._factory)
        except (gpio_error, OSError, RuntimeError, ValueError) as exc:
            name = type(exc).__name__
            if "InvalidPin" in name:
                raise ServoError(f"GPIO{p.pin} does not exist on this board ({exc}); the "
                                 "course's servo is on BCM pin 20") from None
            raise ServoUnavailable(
                f"GPIO{p.pin}: cannot start PWM at {p.frequency} Hz: {name}: {exc}; on a "
                "machine without GPIO use pin_factory: mock") from None
        self.duty = p.open_duty
        self.writes.append((self._clock(), self.duty))

    def _write(self, duty: float) -> None:
        self._device.value = duty / 100.0
        self.duty = duty
        self.writes.append((self._clock(), duty))

    def check(self, pin: int, duty: float) -> None:
        """Raise :class:`ServoError` unless ``(pin, duty)`` is a valid request."""
        p = self.params
        if int(pin) != p.pin or isinstance(pin, bool):
            raise ServoError(f"pin {pin} is not the servo's pin (BCM {p.pin}); send requests "
                             f"for pin {p.pin}")
        if not (isinstance(duty, int | float) and math.isfinite(duty)
                and p.min_duty <= duty <= p.max_duty):
            raise ServoError(f"duty {duty!r} % is outside the servo's range {p.min_duty}.."
                             f"{p.max_duty} % (open {p.open_duty} %, close {p.close_duty} %)")

    def ramp_steps(self, duty: float) -> list[float]:
        """The duties written to reach ``duty`` from the current one: rising in
        ``ramp_step`` increments (the last one exactly ``duty``), or ``[duty]`` at once."""
        p = self.params
        if duty <= self.duty + 1e-9:
            return [duty]
        n = max(1, math.ceil((duty - self.duty) / p.ramp_step - 1e-9))
        return [round(min(duty, self.duty + k * p.ramp_step), 6) for k in range(1, n + 1)]

    def command(self, pin: int, duty: float) -> str:
        """The course's service: move to ``duty`` % (module docstring); returns ``"OK"``."""
        self.check(pin, duty)
        if self._device is None:
            self.open()
        steps = self.ramp_steps(float(duty))
        period = self.params.step_period if len(steps) > 1 else 0.0
        start = self._clock()
        for k, value in enumerate(steps):
            self._wait_until(start + k * period)
            self._write(value)
        if period > 0.0:
            self._wait_until(start + len(steps) * period)
        return "OK"

    def _wait_until(self, deadline: float) -> None:
        """Sleep to ``SPIN_MARGIN`` before ``deadline``, then poll the clock: a plain sleep
        overshoots by a scheduler quantum on a loaded machine (seen: 10 ms)."""
        wait = deadline - self._clock()
        if wait > SPIN_MARGIN:
            self._sleep(wait - SPIN_MARGIN)
        while self._clock() < deadline:
            self._sleep(0.0)

    def open_gripper(self) -> str:
        return self.command(self.params.pin, self.params.open_duty)

    def close_gripper(self) -> str:
        return self.command(self.params.pin, self.params.close_duty)

    def close(self) -> None:
        """Back to the open (safe) duty and release the pin."""
        if self._device is not None:
            self._write(self.params.open_duty)
            self._device.close()
            self._device = None
