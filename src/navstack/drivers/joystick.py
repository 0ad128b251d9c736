"""Joystick readers: a game pad -> ``sensor_msgs/Joy`` (ROS ``joy`` / ``joy_linux`` semantics).

Two backends give the same :class:`~navstack.core.msgs.Joy`:

* :class:`LinuxJoystick` -- the Linux joystick API (``/dev/input/jsN``), what ROS's
  ``joy_linux`` node reads, no extra dependency.  The device delivers 8-byte
  ``struct js_event`` records (``u32 time [ms]``, ``s16 value``, ``u8 type``, ``u8
  number``; type 1 button, 2 axis, bit 0x80 for the initial state sent on open).
* :class:`PygameJoystick` -- SDL through pygame (the ``joystick`` extra:
  ``pip install navstack[joystick]``), for pads the kernel exposes only through evdev or
  on other systems.

Axes follow ROS ``joy``: in [-1, 1], pushed forward / left is **positive** (the raw value is
negated, as joy_linux and SDL report forward as negative), with a ``deadzone`` (joy's
default 0.05) and rescaling so the output still reaches +-1.  Buttons are 0/1.  A reader
keeps the latest state; :meth:`poll` returns a new ``Joy`` when an event changed it, so a
node can publish at the device's pace or at ``autorepeat_rate`` (joy's parameter).
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import struct
from dataclasses import dataclass, field
from typing import Any, Protocol

from navstack.core.errors import NavstackError
from navstack.core.msgs import Header, Joy

__all__ = ["JS_EVENT", "JoystickError", "JoystickReader", "LinuxJoystick", "PygameJoystick",
           "open_joystick", "scale_axis"]

JS_EVENT = struct.Struct("<IhBB")
"""``struct js_event`` (linux/joystick.h): time [ms], value, type, number."""
JS_EVENT_BUTTON = 0x01
JS_EVENT_AXIS = 0x02
JS_EVENT_INIT = 0x80


class JoystickError(NavstackError):
    """A joystick that cannot be opened or read; the message names the device and the fix."""


def scale_axis(raw: float, deadzone: float) -> float:
    """ROS ``joy`` axis: ``raw`` in [-1, 1] (forward negative) -> [-1, 1], forward positive,
    0 inside ``deadzone``, rescaled so the edge of the dead zone maps to 0 and full
    deflection to +-1."""
    v = max(-1.0, min(1.0, -raw))
    if abs(v) <= deadzone:
        return 0.0
    return (abs(v) - deadzone) / (1.0 - deadzone) * (1.0 if v > 0.0 else -1.0)


class JoystickReader(Protocol):
    """What :class:`~navstack.nodes.teleop.TeleopNode`'s feeder needs from a backend."""

    name: str

    def poll(self, now: float) -> Joy | None: ...

    def close(self) -> None: ...


@dataclass
class _State:
    axes: list[float] = field(default_factory=list)
    buttons: list[int] = field(default_factory=list)

    def set_axis(self, i: int, v: float) -> None:
        if i >= len(self.axes):
            self.axes.extend([0.0] * (i + 1 - len(self.axes)))
        self.axes[i] = v

    def set_button(self, i: int, v: int) -> None:
        if i >= len(self.buttons):
            self.buttons.extend([0] * (i + 1 - len(self.buttons)))
        self.buttons[i] = v

    def joy(self, now: float, frame: str) -> Joy:
        return Joy(Header(now, frame), tuple(self.axes), tuple(self.buttons))


class LinuxJoystick:
    """``/dev/input/jsN`` reader (non-blocking).  ``fd`` may be any readable file
    descriptor that delivers ``struct js_event`` records (a pipe in tests)."""

    def __init__(self, path: str = "/dev/input/js0", *, deadzone: float = 0.05,
                 fd: int | None = None, frame_id: str = "joy") -> None:
        if not 0.0 <= deadzone < 1.0:
            raise JoystickError(f"deadzone must be in [0, 1), got {deadzone}")
        self.name = path
        self.deadzone = deadzone
        self.frame_id = frame_id
        self.state = _State()
        self._buf = b""
        if fd is None:
            try:
                fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
            except OSError as exc:
                hint = ("plug the pad in or pass --device" if exc.errno == errno.ENOENT else
                        "add yourself to the 'input' group" if exc.errno == errno.EACCES else
                        "check the device")
                raise JoystickError(f"cannot open joystick {path}: {exc.strerror} "
                                    f"({hint})") from None
        else:
            os.set_blocking(fd, False)
        self.fd = fd

    def _read(self) -> bytes:
        try:
            return os.read(self.fd, 64 * JS_EVENT.size)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise JoystickError(f"joystick {self.name} stopped: {exc.strerror} "
                                "(unplugged?)") from None

    def feed(self, data: bytes) -> bool:
        """Apply raw ``js_event`` bytes (a partial record waits for the rest); True if
        the state changed."""
        self._buf += data
        changed = False
        n = len(self._buf) // JS_EVENT.size
        for k in range(n):
            _t, value, kind, number = JS_EVENT.unpack_from(self._buf, k * JS_EVENT.size)
            kind &= ~JS_EVENT_INIT
            if kind == JS_EVENT_AXIS:
                self.state.set_axis(number, scale_axis(value / 32767.0, self.deadzone))
                changed = True
            elif kind == JS_EVENT_BUTTON:
                self.state.set_button(number, 1 if value else 0)
                changed = True
        self._buf = self._buf[n * JS_EVENT.size:]
        return changed

    def poll(self, now: float) -> Joy | None:
        """Read what the device has; a ``Joy`` if anything changed, else ``None``."""
        changed = False
        while True:
            ready, _, _ = select.select([self.fd], [], [], 0.0)
            if not ready:
                break
            data = self._read()
            if not data:
                break
            changed |= self.feed(data)
        return self.state.joy(now, self.frame_id) if changed else None

    def close(self) -> None:
        with contextlib.suppress(OSError):
            os.close(self.fd)


class PygameJoystick:
    """A pad through SDL (pygame); ``index`` picks among the connected pads."""

    def __init__(self, index: int = 0, *, deadzone: float = 0.05, frame_id: str = "joy",
                 pygame_module: Any = None) -> None:
        if pygame_module is None:
            try:
                import pygame as pygame_module  # type: ignore[no-redef]
            except ImportError:
                raise JoystickError("the pygame joystick backend needs pygame: pip install "
                                    "'navstack[joystick]' (or use the Linux device with "
                                    "--device /dev/input/js0)") from None
        self.pg = pygame_module
        self.pg.display.init()  # SDL's event loop (SDL_VIDEODRIVER=dummy runs headless)
        self.pg.joystick.init()
        count = self.pg.joystick.get_count()
        if not 0 <= index < count:
            raise JoystickError(f"no joystick {index}: SDL sees {count} (plug the pad in, "
                                "or pick another --index)")
        self.pad = self.pg.joystick.Joystick(index)
        self.pad.init()
        self.name = str(self.pad.get_name())
        self.deadzone = deadzone
        self.frame_id = frame_id
        self._last: tuple[tuple[float, ...], tuple[int, ...]] | None = None

    def poll(self, now: float) -> Joy | None:
        self.pg.event.pump()
        axes = tuple(scale_axis(float(self.pad.get_axis(i)), self.deadzone)
                     for i in range(self.pad.get_numaxes()))
        buttons = tuple(int(bool(self.pad.get_button(i)))
                        for i in range(self.pad.get_numbuttons()))
        if (axes, buttons) == self._last:
            return None
        self._last = (axes, buttons)
        return Joy(Header(now, self.frame_id), axes, buttons)

    def close(self) -> None:
        self.pad.quit()


def open_joystick(device: str | None = None, index: int = 0,
                  deadzone: float = 0.05) -> JoystickReader:
    """``device`` (a ``/dev/input/jsN`` path) opens the Linux reader; without one, the
    pygame backend if pygame is installed, else ``/dev/input/js0``."""
    if device is not None:
        return LinuxJoystick(device, deadzone=deadzone)
    try:
        import pygame  # noqa: F401
    except ImportError:
        return LinuxJoystick("/dev/input/js0", deadzone=deadzone)
    return PygameJoystick(index, deadzone=deadzone)
