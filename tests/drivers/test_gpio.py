"""GPIO digital output with gpiozero's MockFactory: the pin follows, safe value on close,
clear errors; the bus node drives it."""

from __future__ import annotations

import pytest
from gpiozero.pins.mock import MockFactory

from navstack.core.errors import ConfigError
from navstack.core.msgs import Bool
from navstack.drivers.gpio import DigitalOutput, GpioParams, GpioUnavailable
from navstack.nodes.gpio_output import DigitalOutputNode
from navstack.runtime.node import Runtime


def test_digital_output_drives_the_mock_pin() -> None:
    factory = MockFactory()
    out = DigitalOutput(GpioParams(pin=20), factory)
    out.open()
    pin = factory.pin(20)
    assert pin.state is False
    out.set(True)
    assert pin.state is True and out.value is True
    out.set(False)
    assert pin.state is False and out.writes == 2
    out.set(True)
    out.close()  # back to the safe value
    assert pin.state is False and not out.is_open


def test_active_low_relay_and_safe_value() -> None:
    factory = MockFactory()
    out = DigitalOutput(GpioParams(pin=5, active_high=False, initial_value=False,
                                   safe_value=False), factory)
    out.open()
    assert factory.pin(5).state is True  # inactive = high for an active-low relay
    out.set(True)
    assert factory.pin(5).state is False
    out.close()
    assert factory.pin(5).state is True


def test_errors_name_the_pin_and_the_fix() -> None:
    factory = MockFactory()
    a = DigitalOutput(GpioParams(pin=7), factory)
    a.open()
    b = DigitalOutput(GpioParams(pin=7), factory)
    with pytest.raises(GpioUnavailable, match="GPIO7: cannot open"):
        b.open()
    with pytest.raises(GpioUnavailable, match="GPIO8 is not open"):
        DigitalOutput(GpioParams(pin=8), factory).set(True)
    with pytest.raises(GpioUnavailable, match="unknown pin_factory 'fake'"):
        DigitalOutput(GpioParams(pin=8, pin_factory="fake"))
    with pytest.raises(ConfigError, match="pin"):
        GpioParams.from_mapping({"pin": 99})
    a.close()


def test_node_follows_the_topic_and_releases_on_deactivate() -> None:
    factory = MockFactory()
    rt = Runtime()
    node = DigitalOutputNode(rt, GpioParams(pin=20, pin_factory="mock"), "/led/green",
                             pin_factory=factory)
    states: list[bool] = []
    rt.bus.subscribe("/led/green/state", Bool, lambda m: states.append(m.data))
    pub = rt.bus.publisher("/led/green", Bool)
    rt.bring_up()
    pub.publish(Bool(True))
    rt.scheduler.run_for(0.1)
    assert factory.pin(20).state is True
    pub.publish(Bool(False))
    rt.scheduler.run_for(0.1)
    pub.publish(Bool(True))
    rt.scheduler.run_for(0.1)
    node.deactivate()
    rt.scheduler.run_for(0.1)
    assert factory.pin(20).state is False
    assert states == [False, True, False, True, False]
