"""The gripper servo driver on gpiozero's mock PWM pins: the course's exact duty sequence
and timing, the "OK" reply, and clear errors for a bad pin or duty."""

from __future__ import annotations

import math

import pytest

from navstack.core.errors import ConfigError
from navstack.drivers.gpio_servo import GpioServo, ServoError, ServoParams

pytest.importorskip("gpiozero")


def _servo(**kw: object) -> GpioServo:
    servo = GpioServo(ServoParams(pin_factory="mock", **kw))
    servo.open()
    return servo


class FakeClock:
    """A clock that advances only by sleeping (the ramp's schedule without OS jitter)."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        self.t += max(dt, 1e-6)


def test_close_ramp_is_the_course_sequence_with_its_timing() -> None:
    clock = FakeClock()
    servo = GpioServo(ServoParams(pin_factory="mock"), sleep=clock.sleep, clock=clock)
    servo.open()
    pin = servo.factory.pin(20)
    assert pin.frequency == 50
    t0 = clock()
    assert servo.command(20, 7.0) == "OK"
    # the mock pin holds the duties written, the driver the time it wrote each
    values = [round(s.state * 100, 4) for s in pin.states]
    assert values[-21:] == [2.0] + [round(2.0 + 0.25 * k, 4) for k in range(1, 21)]
    steps = servo.writes[-20:]
    assert [d for _, d in steps] == [2.0 + 0.25 * k for k in range(1, 21)]
    for k, (t, _) in enumerate(steps):  # step k+1 at k x 0.1 s, within the 3 ms poll
        assert t - t0 == pytest.approx(0.1 * k, abs=0.003)
    assert clock() - t0 == pytest.approx(2.0, abs=0.003)  # "OK" one period after the last
    # opening releases at once, one write
    before = clock()
    assert servo.command(20, 2.0) == "OK"
    assert clock() - before < 0.01
    assert pin.states[-1].state == pytest.approx(0.02)


def test_close_ramp_on_the_mock_pin_in_real_time() -> None:
    # the real-time deadlines (within 10 ms) are `navstack bench gripper`'s: a loaded
    # machine deschedules the process; here what load cannot change -- the exact
    # sequence on the mock pin, no step before its slot, the reply not before 2.0 s
    from navstack.benchmarks.gripper import ramp_once

    servo = _servo()
    exact, errors, reply = ramp_once(servo)
    assert exact
    assert min(errors) >= -0.003 and reply >= -0.003


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
