"""Collision monitor (approach): slows down in proportion to the time to contact."""

import numpy as np
import pytest

from navstack.control.collision_monitor import ApproachMonitor, ApproachParams
from navstack.core.msgs import Twist2D
from navstack.core.polygon import Footprint

BODY = Footprint.from_radius(0.2).polygon


def test_clear_path_keeps_the_command() -> None:
    mon = ApproachMonitor(BODY)
    pts = np.array([[0.0, 1.0], [-1.0, 0.0]])  # beside and behind
    assert mon.filter(Twist2D(0.5, 0.0, 0.0), pts) == Twist2D(0.5, 0.0, 0.0)
    assert mon.last_ratio == 1.0


def test_obstacle_ahead_scales_by_time_to_contact() -> None:
    mon = ApproachMonitor(BODY, ApproachParams(time_before_collision=1.2,
                                               simulation_time_step=0.1))
    pts = np.array([[0.6, 0.0]])  # contact after driving ~0.4 m: t = 0.8 s at 0.5 m/s
    t = mon.collision_time(Twist2D(0.5, 0.0, 0.0), pts)
    assert t == pytest.approx(0.8)
    out = mon.filter(Twist2D(0.5, 0.0, 0.0), pts)
    assert out.vx == pytest.approx(0.5 * (0.8 - 0.1) / 1.2)  # stops one step short


def test_touching_obstacle_stops_and_turning_away_is_allowed() -> None:
    mon = ApproachMonitor(BODY)
    pts = np.array([[0.21, 0.0]])  # inside the body after the first 0.1 s step
    assert mon.filter(Twist2D(0.3, 0.0, 0.0), pts).vx == 0.0
    assert mon.filter(Twist2D(-0.2, 0.0, 0.0), pts) == Twist2D(-0.2, 0.0, 0.0)


def test_arc_motion_is_simulated_exactly() -> None:
    mon = ApproachMonitor(BODY, ApproachParams(time_before_collision=2.0))
    # (1, 1) lies on the 1 m radius left arc: reached at a quarter turn, t = pi/2,
    # less the body's ~0.2 m (0.2 rad of arc at 1 rad/s)
    pts = np.array([[1.0, 1.0]])
    assert mon.collision_time(Twist2D(0.5, 0.0, 0.0), pts) is None
    t = mon.collision_time(Twist2D(1.0, 0.0, 1.0), pts)
    assert t == pytest.approx(1.4)
