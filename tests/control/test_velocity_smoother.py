"""Velocity smoother (Nav2 velocity_smoother): limits, deadband regression, timeout."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from navstack.control.velocity_smoother import VelocitySmoother, VelocitySmootherParams
from navstack.core.errors import ConfigError
from navstack.core.msgs import Twist2D

F = 20.0
LIMITS = VelocitySmootherParams(smoothing_frequency=F, max_velocity=(0.5, 0.3, 1.5),
                                min_velocity=(-0.3, -0.3, -1.5), max_accel=(1.0, 0.5, 2.0),
                                max_decel=(-1.5, -0.5, -3.0))

speeds = st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.floats(-4.0, 4.0))


@settings(max_examples=200, deadline=None)
@given(commands=st.lists(speeds, min_size=1, max_size=40), scale=st.booleans(),
       closed=st.booleans(), odom=st.lists(speeds, min_size=40, max_size=40))
def test_per_cycle_change_never_exceeds_limit_over_frequency(
        commands: list[tuple[float, float, float]], scale: bool, closed: bool,
        odom: list[tuple[float, float, float]]) -> None:
    p = LIMITS.updated(scale_velocities=scale,
                       feedback="CLOSED_LOOP" if closed else "OPEN_LOOP")
    sm = VelocitySmoother(p)
    prev = Twist2D()
    for k, cmd in enumerate(commands):
        t = k / F
        sm.command(Twist2D(*cmd), t)
        if closed:
            sm.odometry(Twist2D(*odom[k]), t)
            prev = sm.odom.twist() or prev
        out = sm.cycle(t)
        assert out is not None
        for i, (a, b) in enumerate(zip((prev.vx, prev.vy, prev.wz), (out.vx, out.vy, out.wz),
                                       strict=True)):
            # the bound is the larger of accel and |decel| per axis, over the frequency
            bound = max(p.max_accel[i], -p.max_decel[i]) / F
            assert abs(b - a) <= bound + 1e-12
            if not closed:  # open loop: the output also stays inside the velocity limits
                assert p.min_velocity[i] - 1e-12 <= b <= p.max_velocity[i] + 1e-12
        prev = out


def test_accelerates_and_decelerates_at_the_axis_limits() -> None:
    sm = VelocitySmoother(LIMITS)
    sm.command(Twist2D(0.5, 0.0, 0.0), 0.0)
    vx = [sm.cycle(k / F).vx for k in range(12)]  # type: ignore[union-attr]
    assert vx == pytest.approx([0.05 * (k + 1) for k in range(10)] + [0.5, 0.5])
    sm.command(Twist2D(0.0, 0.0, 0.0), 0.6)
    down = [sm.cycle(0.6 + k / F).vx for k in range(5)]  # type: ignore[union-attr]
    assert down == pytest.approx([0.425, 0.35, 0.275, 0.2, 0.125])  # max_decel 1.5 m/s^2


def test_scale_velocities_keeps_the_direction() -> None:
    sm = VelocitySmoother(LIMITS.updated(scale_velocities=True))
    sm.command(Twist2D(0.5, 0.0, 1.0), 0.0)
    out = sm.cycle(0.0)
    assert out is not None
    assert out.vx == pytest.approx(0.05) and out.wz == pytest.approx(0.1)  # vx limits both


def test_deadband_does_not_stick_at_zero() -> None:
    """Regression: Nav2 applied the deadband before storing the open-loop state, so a
    first step inside the deadband was stored as zero and the output never left zero."""
    p = LIMITS.updated(max_accel=(0.5, 0.5, 2.0), deadband_velocity=(0.1, 0.0, 0.0))
    sm = VelocitySmoother(p)
    sm.command(Twist2D(0.3, 0.0, 0.0), 0.0)
    out = [sm.cycle(k / F).vx for k in range(20)]  # type: ignore[union-attr]
    # 0.025 m/s per cycle: the first three outputs are inside the 0.1 deadband
    assert out[:3] == [0.0, 0.0, 0.0]
    assert out[3] == pytest.approx(0.1) and out[11] == pytest.approx(0.3)
    assert out[-1] == pytest.approx(0.3)


def test_velocity_timeout_ramps_down_and_gives_one_zero() -> None:
    sm = VelocitySmoother(LIMITS.updated(velocity_timeout=0.5))
    sm.command(Twist2D(0.3, 0.0, 0.0), 0.0)
    outputs = [(k / F, sm.cycle(k / F)) for k in range(40)]
    published = [(t, o.vx) for t, o in outputs if o is not None]
    zeros = [t for t, vx in published if vx == 0.0]
    assert len(zeros) == 1  # exactly one zero after the timeout, then silence
    after = [vx for t, vx in published if t > 0.5]
    assert after == pytest.approx([0.225, 0.15, 0.075, 0.0])  # decelerating at 1.5 m/s^2
    assert published[-1][0] == zeros[0] and outputs[-1][1] is None
    sm.command(Twist2D(0.1, 0.0, 0.0), 2.0)  # a new command restarts publishing
    assert sm.cycle(2.0) == Twist2D(0.05, 0.0, 0.0)


def test_closed_loop_starts_from_the_averaged_odometry() -> None:
    sm = VelocitySmoother(LIMITS.updated(feedback="CLOSED_LOOP", odom_duration=0.1))
    for k, v in enumerate((0.1, 0.2, 0.3)):
        sm.odometry(Twist2D(v, 0.0, 0.0), 0.06 * k)  # 0.0 dropped: older than 0.1 s
    assert sm.odom.twist() == Twist2D(0.25, 0.0, 0.0)
    sm.command(Twist2D(0.5, 0.0, 0.0), 0.12)
    out = sm.cycle(0.12)
    assert out is not None and out.vx == pytest.approx(0.30)


def test_non_finite_commands_are_refused() -> None:
    sm = VelocitySmoother(LIMITS)
    assert not sm.command(Twist2D(math.nan, 0.0, 0.0), 0.0)
    assert sm.cycle(0.0) is None and sm.rejected == 1


@pytest.mark.parametrize(("changes", "message"), [
    ({"max_accel": (-1.0, 0.0, 1.0)}, r"max_accel vx must be >= 0"),
    ({"max_decel": (1.0, 0.0, -1.0)}, r"max_decel vx must be <= 0: a deceleration is negative"),
    ({"min_velocity": (0.6, 0.0, -1.0)}, r"min_velocity vx 0.6 exceeds max_velocity 0.5"),
    ({"feedback": "CLOSED"}, r"feedback: Input should be 'OPEN_LOOP' or 'CLOSED_LOOP'"),
])
def test_bad_parameters_are_config_errors(changes: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        VelocitySmootherParams.from_mapping({**LIMITS.model_dump(), **changes},
                                            key_path="velocity_smoother")
