"""Kinematic models against closed-form arcs, limits, steering and input validation."""

from __future__ import annotations

import itertools
import math

import pytest

from navstack.core.errors import InvalidMessage, SimulationError
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import Pose2D, Twist2D
from navstack.sim.kinematics import (
    Ackermann,
    DiffDrive,
    KinematicsParams,
    Omni,
    RobotState,
    integrate_pose,
    make_model,
)

UNLIMITED = 1e9


def run(model, state: RobotState, cmd: Twist2D, dt: float, n: int) -> list[RobotState]:
    out = [state]
    for _ in range(n):
        state = model.step(state, cmd, dt)
        out.append(state)
    return out


def circle_pose(p0: RobotState, vx: float, vy: float, wz: float, t: float) -> tuple[float, ...]:
    """Exact pose after a constant body twist: the body origin circles the ICR."""
    c, s = math.cos(p0.yaw), math.sin(p0.yaw)
    # ICR in the body frame is (-vy/w, vx/w); world centre:
    cx = p0.x + c * (-vy / wz) - s * (vx / wz)
    cy = p0.y + s * (-vy / wz) + c * (vx / wz)
    yaw = p0.yaw + wz * t
    c1, s1 = math.cos(yaw), math.sin(yaw)
    # the body origin relative to the ICR in the body frame is (vy/w, -vx/w)
    return (cx + c1 * (vy / wz) - s1 * (-vx / wz), cy + s1 * (vy / wz) + c1 * (-vx / wz),
            normalize_angle(yaw))


def test_diff_drive_matches_closed_form_circle() -> None:
    v, w = 0.5, 0.25  # radius 2 m
    model = DiffDrive(1.0, -1.0, 1.0, UNLIMITED, UNLIMITED)
    s0 = RobotState(1.0, 2.0, 0.3, v, 0.0, w)
    states = run(model, s0, Twist2D(v, 0.0, w), 0.01, 1000)
    cx, cy = 1.0 - 2.0 * math.sin(0.3), 2.0 + 2.0 * math.cos(0.3)
    for s in states:
        assert math.hypot(s.x - cx, s.y - cy) == pytest.approx(2.0, abs=1e-9)
    x, y, yaw = circle_pose(s0, v, 0.0, w, 10.0)
    end = states[-1]
    assert (end.x, end.y) == pytest.approx((x, y), abs=1e-9)
    assert end.yaw == pytest.approx(yaw, abs=1e-9)
    assert end.vy == 0.0
    # one big step lands on the same arc as 1000 small ones
    big = model.step(s0, Twist2D(v, 0.0, w), 10.0)
    assert (big.x, big.y, big.yaw) == pytest.approx((end.x, end.y, end.yaw), abs=1e-9)


def test_straight_line_limit_is_continuous() -> None:
    x, y, yaw = integrate_pose(0.0, 0.0, 0.5, 2.0, 0.0, 0.0, 3.0)
    assert (x, y, yaw) == pytest.approx((6.0 * math.cos(0.5), 6.0 * math.sin(0.5), 0.5),
                                        abs=1e-15)
    xs, ys, _ = integrate_pose(0.0, 0.0, 0.5, 2.0, 0.0, 1e-12, 3.0)
    xa, ya, _ = integrate_pose(0.0, 0.0, 0.5, 2.0, 0.0, 1e-7, 3.0)
    assert (xs, ys) == pytest.approx((x, y), abs=1e-11)
    assert (xa, ya) == pytest.approx((x, y), abs=1e-5)


def test_omni_matches_closed_form_circle() -> None:
    vx, vy, w = 0.3, 0.2, 0.5
    model = Omni(1.0, -1.0, 1.0, 1.0, UNLIMITED, UNLIMITED, UNLIMITED)
    s0 = RobotState(-1.0, 0.5, -2.0, vx, vy, w)
    states = run(model, s0, Twist2D(vx, vy, w), 0.005, 2000)
    radius = math.hypot(vx, vy) / w
    c, s = math.cos(-2.0), math.sin(-2.0)
    cx, cy = -1.0 + c * (-vy / w) - s * (vx / w), 0.5 + s * (-vy / w) + c * (vx / w)
    for st in states:
        assert math.hypot(st.x - cx, st.y - cy) == pytest.approx(radius, abs=1e-9)
    x, y, yaw = circle_pose(s0, vx, vy, w, 10.0)
    assert (states[-1].x, states[-1].y, states[-1].yaw) == pytest.approx((x, y, yaw), abs=1e-9)


def test_ackermann_settles_on_bicycle_circle() -> None:
    L = 2.4
    model = Ackermann(L, 0.74, 0.6, 2.5, -0.35, 1.0)
    cmd = Twist2D(1.0, 0.0, 0.3)
    settled = run(model, RobotState(), cmd, 0.01, 300)[-1]  # steering + speed settle < 1.1 s
    delta = math.atan(L * 0.3 / 1.0)
    assert settled.steering_angle == pytest.approx(delta, abs=1e-12)
    assert settled.vx == pytest.approx(1.0, abs=1e-12)
    assert settled.wz == pytest.approx(0.3, abs=1e-12)
    radius = L / math.tan(delta)
    assert radius == pytest.approx(1.0 / 0.3, abs=1e-12)
    states = run(model, settled, cmd, 0.01, 1000)
    x, y, yaw = circle_pose(settled, 1.0, 0.0, 0.3, 10.0)
    assert (states[-1].x, states[-1].y, states[-1].yaw) == pytest.approx((x, y, yaw), abs=1e-9)
    c, s = math.cos(settled.yaw), math.sin(settled.yaw)
    cx, cy = settled.x - s * radius, settled.y + c * radius
    for st in states:
        assert math.hypot(st.x - cx, st.y - cy) == pytest.approx(radius, abs=1e-9)


def test_ackermann_steering_clamp_and_rate_limit() -> None:
    L, max_steer, rate = 2.4, 0.74, 0.6
    model = Ackermann(L, max_steer, rate, 2.5, -0.35, 1.0)
    assert model.min_turning_radius == pytest.approx(L / math.tan(max_steer))
    cmd = Twist2D(1.0, 0.0, 1.0)  # wants atan(2.4) = 1.18 rad > max
    states = run(model, RobotState(vx=1.0), cmd, 0.01, 300)
    for a, b in itertools.pairwise(states):
        assert abs(b.steering_angle - a.steering_angle) <= rate * 0.01 + 1e-15
        assert abs(b.steering_angle) <= max_steer
    assert states[50].steering_angle == pytest.approx(0.3, abs=1e-12)  # 0.5 s at 0.6 rad/s
    end = states[-1]
    assert end.steering_angle == max_steer
    assert end.vx / end.wz == pytest.approx(L / math.tan(max_steer), abs=1e-12)


def test_ackermann_holds_steering_when_stopped_and_reverses_with_curvature() -> None:
    model = Ackermann(2.4, 0.74, 0.6, 2.5, -0.35, 1.0)
    held = model.step(RobotState(vx=0.0, steering_angle=0.2), Twist2D(0.0, 0.0, 1.0), 0.1)
    assert held.steering_angle == 0.2
    assert held.wz == 0.0 and held.vx == 0.0
    # reversing keeps the commanded yaw rate (curvature wz/vx) once settled
    rev = run(model, RobotState(), Twist2D(-0.3, 0.0, 0.1), 0.01, 300)[-1]
    assert rev.vx == pytest.approx(-0.3, abs=1e-12)
    assert rev.wz == pytest.approx(0.1, abs=1e-12)
    assert rev.steering_angle == pytest.approx(math.atan(2.4 * 0.1 / -0.3), abs=1e-12)
    # reverse speed limit
    assert run(model, RobotState(), Twist2D(-2.0, 0.0, 0.0), 0.01, 200)[-1].vx == -0.35


def test_diff_drive_velocity_and_acceleration_limits() -> None:
    model = DiffDrive(0.26, -0.1, 1.82, 2.5, 3.2)
    states = run(model, RobotState(), Twist2D(5.0, 3.0, -9.0), 0.01, 100)
    for i, s in enumerate(states):
        assert s.vx == pytest.approx(min(0.025 * i, 0.26), abs=1e-12)
        assert s.wz == pytest.approx(-min(0.032 * i, 1.82), abs=1e-12)
        assert s.vy == 0.0
    back = run(model, states[-1], Twist2D(-5.0, 0.0, 0.0), 0.01, 100)
    assert back[-1].vx == -0.1
    steps = [abs(b.vx - a.vx) for a, b in itertools.pairwise(back)]
    assert max(steps) <= 0.025 + 1e-12
    assert model.clamp(Twist2D(1.0, 1.0, 3.0)) == Twist2D(0.26, 0.0, 1.82)


def test_omni_limits_each_axis() -> None:
    model = Omni(0.5, -0.5, 0.4, 1.5, 1.0, 2.0, 3.0)
    states = run(model, RobotState(), Twist2D(1.0, -1.0, 2.0), 0.05, 40)
    for i, s in enumerate(states):
        assert s.vx == pytest.approx(min(0.05 * i, 0.5), abs=1e-12)
        assert s.vy == pytest.approx(-min(0.1 * i, 0.4), abs=1e-12)
        assert s.wz == pytest.approx(min(0.15 * i, 1.5), abs=1e-12)


@pytest.mark.parametrize("cmd", [Twist2D(math.nan, 0.0, 0.0), Twist2D(0.0, 0.0, math.inf),
                                 Twist2D(0.0, -math.inf, 0.0)])
def test_non_finite_command_raises_invalid_message(cmd: Twist2D) -> None:
    for model in (DiffDrive(1, -1, 1, 1, 1), Omni(1, -1, 1, 1, 1, 1, 1),
                  Ackermann(1.0, 0.5, 1.0, 1.0, -1.0, 1.0)):
        with pytest.raises(InvalidMessage) as err:
            model.step(RobotState(), cmd, 0.1)
        assert str(err.value) == (
            f"velocity command must be finite, got vx={cmd.vx}, vy={cmd.vy}, wz={cmd.wz}; "
            "reject NaN/inf commands before they reach the robot model")


def test_bad_state_and_dt() -> None:
    model = DiffDrive(1, -1, 1, 1, 1)
    with pytest.raises(InvalidMessage, match="robot state must be finite"):
        model.step(RobotState(x=math.nan), Twist2D(), 0.1)
    with pytest.raises(SimulationError, match=r"dt must be finite and >= 0, got -0\.1"):
        model.step(RobotState(), Twist2D(), -0.1)
    s = RobotState(1.0, 2.0, 3.0, 0.1)
    assert model.step(s, Twist2D(1.0, 0.0, 1.0), 0.0) is s
    with pytest.raises(SimulationError, match=r"min_vx \(1.0\) must be <= max_vx \(0.5\)"):
        DiffDrive(0.5, 1.0, 1.0, 1.0, 1.0)


def test_make_model_from_params() -> None:
    dd = make_model(KinematicsParams(max_vel_x=0.5, max_vel_theta=1.5))
    assert isinstance(dd, DiffDrive) and (dd.max_vx, dd.min_vx, dd.max_wz) == (0.5, -0.5, 1.5)
    om = make_model(KinematicsParams.from_mapping(
        {"type": "Omni", "max_vel_y": 0.3, "acc_lim_y": 1.0, "min_vel_x": -0.1}))
    assert isinstance(om, Omni) and om.holonomic and (om.max_vy, om.min_vx) == (0.3, -0.1)
    ak = make_model(KinematicsParams.from_mapping({"type": "ackermann", "wheelbase": 2.4}))
    assert isinstance(ak, Ackermann) and ak.wheelbase == 2.4 and not ak.holonomic


def test_robot_state_helpers() -> None:
    s = RobotState.at(Pose2D(1.0, 2.0, 4.0))
    assert s.pose == Pose2D(1.0, 2.0, 4.0 - 2.0 * math.pi)
    assert s.twist == Twist2D()
