"""Keyboard teleop with teleop_twist_keyboard's bindings, repeat and timeout."""

from __future__ import annotations

import pytest

from navstack.control.teleop_keyboard import KeyboardTeleop, KeyboardTeleopParams
from navstack.core.msgs import Twist2D


def test_bindings_speeds_and_limits() -> None:
    t = KeyboardTeleop(KeyboardTeleopParams(speed=0.4, turn=1.0, speed_limit=0.5))
    assert t.key("i", 0.0) == Twist2D(0.4, 0.0, 0.0)
    assert t.key("u", 0.1) == Twist2D(0.4, 0.0, 1.0)
    assert t.key("l", 0.2) == Twist2D(0.0, 0.0, -1.0)
    assert t.key(",", 0.3) == Twist2D(-0.4, 0.0, 0.0)
    assert t.key("m", 0.4) == Twist2D(-0.4, 0.0, -1.0)
    out = t.key("q", 0.5)  # +10 % both, linear clamped at 0.5
    assert out.vx == pytest.approx(-0.44) and out.wz == pytest.approx(-1.1)
    t.key("q", 0.6)
    t.key("w", 0.65)  # linear only: 0.484 * 1.1 clamps at the limit
    assert t.speed == 0.5 and t.turn == pytest.approx(1.21)
    assert t.key("c", 0.7).wz == pytest.approx(-1.21 * 0.9)
    assert t.key("k", 0.8) == Twist2D()  # any other key stops
    assert t.key(" ", 0.9) == Twist2D()


def test_repeat_while_held_and_one_zero_after_the_timeout() -> None:
    t = KeyboardTeleop(KeyboardTeleopParams(repeat_rate=10.0, key_timeout=0.5))
    assert t.tick(0.0) is None  # idle: nothing
    assert t.key("i", 1.0) == Twist2D(0.5, 0.0, 0.0)
    assert t.tick(1.05) is None  # within the repeat period
    assert t.tick(1.1) == Twist2D(0.5, 0.0, 0.0)
    assert t.tick(1.5) == Twist2D(0.5, 0.0, 0.0)
    assert t.tick(1.51) == Twist2D()  # no key for 0.5 s: one zero
    assert t.tick(1.7) is None  # then quiet (twist_mux falls back to navigation)
