"""GPIO outputs through gpiozero: a digital output (LEDs, relays) and the conventions
the gripper servo of the perception issue will follow.

Conventions of a GPIO driver here:

* configured by a :class:`GpioParams` -- BCM pin number, ``active_high``, the value at
  start and the *safe* value it returns to on close / when its node deactivates
  (a relay that powers a motor must drop out when navstack stops);
* the pin factory is chosen per device, never through gpiozero's global
  ``Device.pin_factory``: ``"default"`` (gpiozero picks lgpio / RPi.GPIO / pigpio on a
  Pi), ``"mock"`` (gpiozero's ``MockFactory``: tests, machines without GPIO), or a
  factory object;
* :meth:`open` raises :class:`GpioUnavailable` naming the pin and what to do (install
  ``navstack[hardware]``, run on a board with GPIO, or use ``pin_factory: mock``);
* the driver counts writes and knows its state; the bus side is
  :class:`navstack.nodes.gpio_output.DigitalOutputNode` (``std_msgs/Bool`` in, state out).
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from navstack.core.params import Params
from navstack.drivers.errors import LinkUnavailable

__all__ = ["DigitalOutput", "GpioParams", "GpioUnavailable", "gpiozero_device",
           "make_pin_factory", "missing_gpiozero"]


class GpioUnavailable(LinkUnavailable):
    """No GPIO: gpiozero missing, no pin factory for this machine, or the pin is busy."""


class GpioParams(Params):
    """One output pin (BCM numbering, as gpiozero and the TurtleBot's servo use)."""

    pin: int = Field(ge=0, le=53)
    active_high: bool = True
    initial_value: bool = False
    safe_value: bool = False
    pin_factory: str = "default"
    """"default" (gpiozero's choice for this board) or "mock" (no hardware)."""


def make_pin_factory(name: str | Any, pwm: bool = False) -> Any:
    """A gpiozero pin factory: ``None`` for gpiozero's default, a ``MockFactory`` for
    ``"mock"`` (with PWM-capable mock pins when ``pwm``), or the object given."""
    if not isinstance(name, str):
        return name
    if name == "default":
        return None
    if name == "mock":
        try:
            from gpiozero.pins.mock import MockFactory, MockPWMPin
        except ImportError as exc:
            raise GpioUnavailable(missing_gpiozero(exc)) from None
        return MockFactory(pin_class=MockPWMPin) if pwm else MockFactory()
    raise GpioUnavailable(f"unknown pin_factory {name!r}; use 'default' or 'mock'")


def missing_gpiozero(exc: ImportError) -> str:
    """The error text when gpiozero cannot be imported."""
    return (f"gpiozero is not installed ({exc}); install it with "
            "`pip install navstack[hardware]`")


def gpiozero_device(name: str) -> tuple[Any, type[Exception]]:
    """gpiozero's device class ``name`` and its base error ``GPIOZeroError``; raises
    :class:`GpioUnavailable` when gpiozero is not installed."""
    try:
        import gpiozero
        from gpiozero.exc import GPIOZeroError
    except ImportError as exc:
        raise GpioUnavailable(missing_gpiozero(exc)) from None
    return getattr(gpiozero, name), GPIOZeroError


class DigitalOutput:
    """A digital output pin (LED, relay) -- see module docstring."""

    def __init__(self, params: GpioParams, pin_factory: Any = None) -> None:
        self.params = params
        self._factory = pin_factory if pin_factory is not None else \
            make_pin_factory(params.pin_factory)
        self._device: Any = None
        self.writes = 0

    @property
    def is_open(self) -> bool:
        return self._device is not None

    def open(self) -> None:
        if self._device is not None:
            return
        device, gpio_error = gpiozero_device("DigitalOutputDevice")
        p = self.params
        try:
            self._device = device(p.pin, active_high=p.active_high,
                                  initial_value=p.initial_value, pin_factory=self._factory)
        except (gpio_error, OSError, RuntimeError) as exc:
            raise GpioUnavailable(
                f"GPIO{p.pin}: cannot open as a digital output: {type(exc).__name__}: {exc}; "
                "on a machine without GPIO use pin_factory: mock") from None

    def set(self, value: bool) -> None:
        """Drive the output: ``True`` = active (high when ``active_high``)."""
        if self._device is None:
            raise GpioUnavailable(f"GPIO{self.params.pin} is not open; call open() first")
        self._device.value = bool(value)
        self.writes += 1

    @property
    def value(self) -> bool:
        return bool(self._device.value) if self._device is not None else \
            self.params.safe_value

    def close(self) -> None:
        """Return to the safe value and release the pin."""
        if self._device is not None:
            self._device.value = self.params.safe_value
            self._device.close()
            self._device = None
