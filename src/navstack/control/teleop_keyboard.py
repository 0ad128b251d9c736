"""Keys -> Twist with ``teleop_twist_keyboard``'s bindings (pure; its parameters).

Movement keys (a 3 x 3 block around ``k``)::

    u  i  o        forward-left   forward   forward-right
    j  k  l        turn left      stop      turn right
    m  ,  .        back-right     back      back-left

(``teleop_twist_keyboard`` maps ``.`` to back with +yaw and ``m`` to back with -yaw: a car
reversing.)  ``q``/``z`` scale both speeds by 1.1 / 0.9, ``w``/``x`` the linear one,
``e``/``c`` the angular one; ``speed`` and ``turn`` start at its defaults 0.5 m/s and
1.0 rad/s and are clamped to ``speed_limit`` / ``turn_limit``.  Any other key stops
(``k`` and the space bar by convention).  The command is resent every
``1 / repeat_rate`` s while held, and after ``key_timeout`` s without a key (navstack
default 0.6 s, longer than a terminal's key-repeat delay) the robot stops:
:meth:`KeyboardTeleop.tick` returns the command to publish at time ``now``.
"""

from __future__ import annotations

from pydantic import Field

from navstack.core.msgs import Twist2D
from navstack.core.params import Params

__all__ = ["MOVE_BINDINGS", "SPEED_BINDINGS", "KeyboardTeleop", "KeyboardTeleopParams"]

MOVE_BINDINGS: dict[str, tuple[float, float]] = {
    "i": (1.0, 0.0), "o": (1.0, -1.0), "j": (0.0, 1.0), "l": (0.0, -1.0), "u": (1.0, 1.0),
    ",": (-1.0, 0.0), ".": (-1.0, 1.0), "m": (-1.0, -1.0)}
"""teleop_twist_keyboard's ``moveBindings`` (x, yaw) for a non-holonomic base."""
SPEED_BINDINGS: dict[str, tuple[float, float]] = {
    "q": (1.1, 1.1), "z": (0.9, 0.9), "w": (1.1, 1.0), "x": (0.9, 1.0), "e": (1.0, 1.1),
    "c": (1.0, 0.9)}
"""teleop_twist_keyboard's ``speedBindings`` (linear factor, angular factor)."""


class KeyboardTeleopParams(Params):
    """teleop_twist_keyboard parameters (``speed``, ``turn``, ``speed_limit``,
    ``turn_limit``, ``repeat_rate``, ``key_timeout``)."""

    speed: float = Field(0.5, gt=0.0)
    """[m/s] starting linear speed."""
    turn: float = Field(1.0, gt=0.0)
    """[rad/s] starting angular speed."""
    speed_limit: float = Field(1000.0, gt=0.0)
    turn_limit: float = Field(1000.0, gt=0.0)
    repeat_rate: float = Field(10.0, gt=0.0)
    """[Hz] the held command is resent at this rate (the twist_mux input must not time
    out)."""
    key_timeout: float = Field(0.6, gt=0.0)
    """[s] no key for this long stops the robot (navstack default; the ROS node's 0 means
    never)."""


class KeyboardTeleop:
    """``key(ch, now)`` on every key, ``tick(now)`` on every loop turn; both return the
    Twist to publish now, or ``None``."""

    def __init__(self, params: KeyboardTeleopParams | None = None) -> None:
        self.params = params or KeyboardTeleopParams()
        self.speed = min(self.params.speed, self.params.speed_limit)
        self.turn = min(self.params.turn, self.params.turn_limit)
        self._dir = (0.0, 0.0)
        self._last_key = -1e300
        self._last_sent = -1e300
        self._moving = False

    @property
    def command(self) -> Twist2D:
        return Twist2D(self._dir[0] * self.speed, 0.0, self._dir[1] * self.turn)

    def key(self, ch: str, now: float) -> Twist2D:
        p = self.params
        self._last_key = now
        if ch in MOVE_BINDINGS:
            self._dir = MOVE_BINDINGS[ch]
        elif ch in SPEED_BINDINGS:
            fs, ft = SPEED_BINDINGS[ch]
            self.speed = min(self.speed * fs, p.speed_limit)
            self.turn = min(self.turn * ft, p.turn_limit)
        else:
            self._dir = (0.0, 0.0)
        self._moving = self._dir != (0.0, 0.0)
        self._last_sent = now
        return self.command

    def tick(self, now: float) -> Twist2D | None:
        """The held command again every ``1 / repeat_rate`` s; one zero after
        ``key_timeout`` without a key; else ``None``."""
        if not self._moving:
            return None
        if now - self._last_key > self.params.key_timeout:
            self._dir = (0.0, 0.0)
            self._moving = False
            self._last_sent = now
            return Twist2D()
        if now - self._last_sent >= 1.0 / self.params.repeat_rate - 1e-9:
            self._last_sent = now
            return self.command
        return None
