"""The gripper servo driver on gpiozero's mock PWM pins: the course's exact duty sequence
and timing, the "OK" reply, and clear errors for a bad pin or duty."""

from __future__ import annotations

import itertools
import math
import time

import pytest

from navstack.core.errors import ConfigError
from navstack.drivers.gpio_servo import GpioServo, ServoError, ServoParams

pytest.importorskip("gpiozero")


def _servo(**kw: object) -> GpioServo:
    servo = GpioServo(ServoParams(pin_factory="mock", **kw))
    servo.open()
    return servo


def _close_ramp_timing(servo: GpioServo) -> list[float]:
    """Close from open on the mock pin; the sequence must be exact; returns each step's
    deviation [s] from its slot (k - 1) x 0.1 s, and the reply's from 2.0 s, last."""
    servo.command(20, 2.0)
    pin = servo.factory.pin(20)
    t0 = time.monotonic()
    assert servo.command(20, 7.0) == "OK"
    elapsed = time.monotonic() - t0
    # a mock pin records each change with the time since the previous one
    times = list(itertools.accumulate(s.timestamp for s in pin.states))
    values = [s.state for s in pin.states]
    assert [round(v * 100, 4) for v in values[-20:]] == [round(2.0 + 0.25 * k, 4)
                                                         for k in range(1, 21)]
    assert values[-21] == pytest.approx(0.02)  # started open
    first = times[-20]
    return [t - first - 0.1 * k for k, t in enumerate(times[-20:])] + [elapsed - 2.0]


def test_close_ramp_is_the_course_sequence_with_its_timing() -> None:
    servo = _servo()
    assert servo.factory.pin(20).frequency == 50
    # real time on a shared machine: a run in which the OS deschedules the process for
    # more than 10 ms is repeated (up to 3 runs); the duty sequence is checked every run
    for _ in range(3):
        errors = _close_ramp_timing(servo)
        if max(abs(e) for e in errors[:-1]) <= 0.010 and abs(errors[-1]) <= 0.03:
            break
    assert max(abs(e) for e in errors[:-1]) <= 0.010, errors
    assert abs(errors[-1]) <= 0.03  # the reply once the servo is there (after 2.0 s)
    # opening releases at once, one write
    t0 = time.monotonic()
    assert servo.command(20, 2.0) == "OK"
    assert time.monotonic() - t0 < 0.05
    assert servo.factory.pin(20).states[-1].state == pytest.approx(0.02)


def test_ramp_steps_from_any_duty() -> None:
    servo = _servo()
    assert servo.ramp_steps(7.0) == [2.0 + 0.25 * k for k in range(1, 21)]
    assert servo.ramp_steps(2.6) == [2.25, 2.5, 2.6]
    assert servo.ramp_steps(1.0) == [1.0]


def test_bad_pin_and_duty_are_clear_errors() -> None:
    servo = _servo(step_period=0.0)
    with pytest.raises(ServoError, match=r"pin 21 is not the servo's pin \(BCM 20\)"):
        servo.command(21, 7.0)
    with pytest.raises(ServoError, match=r"duty 15.0 % is outside the servo's range 0.0..12.5 %"):
        servo.command(20, 15.0)
    with pytest.raises(ServoError, match="duty nan"):
        servo.command(20, math.nan)
    with pytest.raises(ServoError, match="duty -1"):
        servo.command(20, -1)
    with pytest.raises(ConfigError, match=r"pin: .*less than or equal to 53"):
        ServoParams.from_mapping({"pin": 99})
    with pytest.raises(ConfigError, match=r"close_duty 20.0 % is outside min_duty..max_duty"):
        ServoParams.from_mapping({"close_duty": 20.0})
    with pytest.raises(ServoError, match="GPIO45 does not exist on this board"):
        GpioServo(ServoParams(pin=45, pin_factory="mock")).open()


def test_close_returns_to_open_and_releases() -> None:
    servo = _servo(step_period=0.0)
    servo.command(20, 7.0)
    pin = servo.factory.pin(20)
    servo.close()
    assert not servo.is_open
    assert pin.states[-1].state in (0.02, False, 0)  # open duty, then released
