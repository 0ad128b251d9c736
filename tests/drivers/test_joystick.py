"""Joystick readers: the Linux joystick API's js_event records through a real pipe (no
joystick on this machine and no /dev/uinput to make one), the pygame backend's mapping
through a stand-in module (pygame is an optional extra), errors that name the fix."""

from __future__ import annotations

import os
from types import SimpleNamespace

import pytest

from navstack.drivers.joystick import (
    JS_EVENT,
    JS_EVENT_AXIS,
    JS_EVENT_BUTTON,
    JS_EVENT_INIT,
    JoystickError,
    LinuxJoystick,
    PygameJoystick,
    scale_axis,
)


def ev(kind: int, number: int, value: int, t: int = 0) -> bytes:
    return JS_EVENT.pack(t, value, kind, number)


def test_axis_scaling_follows_ros_joy() -> None:
    assert scale_axis(-1.0, 0.05) == 1.0  # stick forward (raw negative) -> +1
    assert scale_axis(1.0, 0.05) == -1.0
    assert scale_axis(0.04, 0.05) == 0.0  # dead zone
    assert scale_axis(-0.525, 0.05) == pytest.approx(0.5)  # rescaled past the dead zone


def test_linux_joystick_reads_js_events_from_a_pipe() -> None:
    r, w = os.pipe()
    pad = LinuxJoystick("pipe", fd=r)
    try:
        assert pad.poll(0.0) is None  # nothing yet
        # the initial state the driver sends on open, then a stick push and a button
        os.write(w, ev(JS_EVENT_AXIS | JS_EVENT_INIT, 0, 0) + ev(JS_EVENT_AXIS | JS_EVENT_INIT,
                                                                 1, 0)
                 + ev(JS_EVENT_BUTTON | JS_EVENT_INIT, 0, 0))
        first = pad.poll(1.0)
        assert first is not None and first.axes == (0.0, 0.0) and first.buttons == (0,)
        os.write(w, ev(JS_EVENT_AXIS, 1, -32767) + ev(JS_EVENT_BUTTON, 0, 1)
                 + ev(JS_EVENT_AXIS, 0, 16384)[:5])  # a record cut in half
        msg = pad.poll(2.0)
        assert msg is not None
        assert msg.header.stamp == 2.0 and msg.header.frame_id == "joy"
        assert msg.axes == (0.0, 1.0) and msg.buttons == (1,)
        os.write(w, ev(JS_EVENT_AXIS, 0, 16384)[5:] + ev(JS_EVENT_BUTTON, 3, 1))
        msg = pad.poll(3.0)
        assert msg is not None and msg.axes[0] == pytest.approx(-(0.5 - 0.05) / 0.95, abs=1e-4)
        assert msg.buttons == (1, 0, 0, 1)
    finally:
        pad.close()
        os.close(w)


def test_missing_device_names_the_fix() -> None:
    with pytest.raises(JoystickError, match=r"cannot open joystick /dev/input/js9: .*"
                                            r"\(plug the pad in or pass --device\)"):
        LinuxJoystick("/dev/input/js9")
    with pytest.raises(JoystickError, match=r"deadzone must be in \[0, 1\)"):
        LinuxJoystick("x", deadzone=1.0, fd=0)


class FakePad:
    def __init__(self) -> None:
        self.axes = [0.0, -1.0]
        self.buttons = [1, 0]

    def init(self) -> None: ...

    def quit(self) -> None: ...

    def get_name(self) -> str:
        return "Fake Pad"

    def get_numaxes(self) -> int:
        return len(self.axes)

    def get_axis(self, i: int) -> float:
        return self.axes[i]

    def get_numbuttons(self) -> int:
        return len(self.buttons)

    def get_button(self, i: int) -> int:
        return self.buttons[i]


def fake_pygame(count: int, pad: FakePad) -> SimpleNamespace:
    return SimpleNamespace(
        display=SimpleNamespace(init=lambda: None),
        event=SimpleNamespace(pump=lambda: None),
        joystick=SimpleNamespace(init=lambda: None, get_count=lambda: count,
                                 Joystick=lambda i: pad))


def test_pygame_backend_maps_sdl_state_and_reports_changes_only() -> None:
    pad = FakePad()
    js = PygameJoystick(0, pygame_module=fake_pygame(1, pad))
    assert js.name == "Fake Pad"
    msg = js.poll(0.5)
    assert msg is not None and msg.axes == (0.0, 1.0) and msg.buttons == (1, 0)
    assert js.poll(0.6) is None  # unchanged
    pad.buttons[0] = 0
    msg = js.poll(0.7)
    assert msg is not None and msg.buttons == (0, 0)
    with pytest.raises(JoystickError, match=r"no joystick 0: SDL sees 0"):
        PygameJoystick(0, pygame_module=fake_pygame(0, pad))
