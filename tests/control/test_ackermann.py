"""cmd_vel -> Ackermann wheel angles (the golf cart's steering conversion)."""

from __future__ import annotations

import math

import pytest

from navstack.control.ackermann import ackermann_steering
from navstack.core.errors import ConfigError

L, W = 2.4, 1.0  # the golf cart's wheel_base and wheel_separation


def test_left_turn_matches_the_ackermann_geometry() -> None:
    s = ackermann_steering(1.0, 0.2, L, W)  # R = 5 m
    assert s.left == pytest.approx(math.atan(2.4 / 4.5), abs=1e-12)
    assert s.right == pytest.approx(math.atan(2.4 / 5.5), abs=1e-12)
    assert s.center == pytest.approx(math.atan(2.4 / 5.0), abs=1e-12)
    assert s.left > s.center > s.right > 0.0 and s.feasible and s.speed == 1.0


def test_right_turn_and_reverse_mirror_the_left_turn() -> None:
    left = ackermann_steering(1.0, 0.2, L, W)
    right = ackermann_steering(1.0, -0.2, L, W)
    assert (right.left, right.right) == pytest.approx((-left.right, -left.left), abs=1e-12)
    # reversing while yawing left (vx < 0, wz > 0) needs the wheels turned right
    back = ackermann_steering(-1.0, 0.2, L, W)
    assert back.center == pytest.approx(-left.center, abs=1e-12) and back.speed == -1.0
    assert math.tan(back.center) * back.speed / L == pytest.approx(0.2, rel=1e-12)


def test_straight_and_clamped_commands() -> None:
    straight = ackermann_steering(2.0, 0.0, L, W)
    assert (straight.left, straight.right, straight.center) == (0.0, 0.0, 0.0)
    tight = ackermann_steering(1.0, 1.0, L, W)  # R = 1 m: tighter than the cart can turn
    assert not tight.feasible
    assert tight.left == pytest.approx(0.74, abs=1e-12)  # the inner wheel at its limit
    r = L / math.tan(0.74) + W / 2
    assert tight.right == pytest.approx(math.atan(L / (r + W / 2)), abs=1e-12)
    assert max(abs(tight.left), abs(tight.right), abs(tight.center)) <= 0.74 + 1e-12


def test_turning_on_the_spot_is_refused_not_guessed() -> None:
    s = ackermann_steering(0.0, 0.5, L, W)
    assert not s.feasible and (s.left, s.right, s.center, s.speed) == (0.0, 0.0, 0.0, 0.0)


def test_bad_geometry_names_the_parameter() -> None:
    with pytest.raises(ConfigError, match=r"wheel_base: must be positive, got 0\.0"):
        ackermann_steering(1.0, 0.1, 0.0, W)
    with pytest.raises(ConfigError, match="max_steering_angle"):
        ackermann_steering(1.0, 0.1, L, W, max_steering_angle=2.0)
