"""The rover's PI chase law: intermediate goals, anti-windup within 2 m, the ~0.88 m stop."""

from __future__ import annotations

import math

import pytest

from navstack.control.gps_chase import ROVER_STOP_DEGREES, GpsChaseParams, GpsChasePI


def test_stop_radius_is_the_rovers_threshold() -> None:
    metres = ROVER_STOP_DEGREES * 111_000
    assert metres == pytest.approx(GpsChaseParams().stop_radius, abs=0.01)


def test_far_goal_gives_a_capped_intermediate_goal_facing_it() -> None:
    pi = GpsChasePI(GpsChaseParams(kp=1.0, ki=0.0, max_step=8.0))
    step = pi.step((30.0, 40.0), (0.0, 0.0), 1.0)
    assert not step.done
    assert step.distance == pytest.approx(50.0)
    assert (step.x, step.y) == pytest.approx((4.8, 6.4))  # 8 m along the error
    assert step.yaw == pytest.approx(math.atan2(40.0, 30.0))


def test_integral_accumulates_far_and_resets_within_two_metres() -> None:
    pi = GpsChasePI(GpsChaseParams(kp=0.1, ki=0.1, windup_radius=2.0, max_step=100.0,
                                   max_integral=100.0))
    for _ in range(3):
        step = pi.step((10.0, 0.0), (0.0, 0.0), 0.5)
    assert pi.integral == pytest.approx((15.0, 0.0))
    # output = kp e + ki I = 1.0 + 1.5 along x
    assert step.x == pytest.approx(2.5) and step.y == pytest.approx(0.0)
    near = pi.step((10.0, 0.0), (8.5, 0.0), 0.5)  # 1.5 m: anti-windup reset
    assert pi.integral == (0.0, 0.0)
    assert near.x == pytest.approx(8.5 + 0.15) and not near.done


def test_integral_contribution_is_capped() -> None:
    pi = GpsChasePI(GpsChaseParams(kp=0.0001, ki=0.5, max_integral=2.0))
    for _ in range(100):
        pi.step((0.0, 50.0), (0.0, 0.0), 1.0)
    assert math.hypot(*pi.integral) == pytest.approx(4.0)  # ki |I| = 2 m


def test_integral_resets_once_the_rover_is_past_the_goal() -> None:
    pi = GpsChasePI(GpsChaseParams(kp=1.0, ki=0.02, max_integral=2.0))
    for k in range(5):  # approach from the west: the integral points east
        pi.step((20.0, 0.0), (2.0 * k, 0.0), 2.0)
    assert pi.integral[0] > 0.0
    step = pi.step((20.0, 0.0), (24.0, 0.5), 2.0)  # overshot by 4 m
    assert pi.integral == (0.0, 0.0)
    assert step.x == pytest.approx(20.0) and step.y == pytest.approx(0.0)


def test_integral_steers_against_a_steady_offset() -> None:
    # the goal estimate sits to the left while the rover keeps being pushed right: the
    # integral turns the intermediate goal further left than the proportional term alone
    pi = GpsChasePI(GpsChaseParams(kp=0.2, ki=0.05, max_step=50.0, max_integral=50.0))
    plain = GpsChasePI(GpsChaseParams(kp=0.2, ki=0.0, max_step=50.0))
    for k in range(10):
        pos = (float(k), -0.5 * k)
        a = pi.step((20.0, 5.0), pos, 1.0)
        b = plain.step((20.0, 5.0), pos, 1.0)
    assert a.y > b.y


def test_stops_within_the_radius_and_resets() -> None:
    pi = GpsChasePI()
    pi.step((10.0, 0.0), (0.0, 0.0), 1.0)
    done = pi.step((10.0, 0.0), (9.2, 0.3), 1.0)
    assert done.done and done.distance == pytest.approx(math.hypot(0.8, 0.3))
    assert (done.x, done.y) == (9.2, 0.3) and pi.integral == (0.0, 0.0)
    assert not pi.step((10.0, 0.0), (9.0, 0.0), 1.0).done  # 1.0 m > 0.88 m


def test_min_step_keeps_the_intermediate_goal_ahead() -> None:
    pi = GpsChasePI(GpsChaseParams(kp=0.2, ki=0.0, min_step=1.0, windup_radius=0.0))
    step = pi.step((2.0, 0.0), (0.0, 0.0), 1.0)  # kp e = 0.4 m < 1 m
    assert step.x == pytest.approx(1.0)


@pytest.mark.parametrize("dt", [-1.0, math.nan, math.inf])
def test_bad_time_step_is_refused(dt: float) -> None:
    with pytest.raises(ValueError, match="dt must be a finite time step"):
        GpsChasePI().step((1.0, 1.0), (0.0, 0.0), dt)
