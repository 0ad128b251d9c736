"""The velocity smoother's stop request: an operator's stop is not ramped down."""

from __future__ import annotations

from navstack.control.velocity_smoother import VelocitySmootherParams
from navstack.core.msgs import Bool, Twist, Vector3
from navstack.navigation.velocity_smoother_node import STOP_TOPIC, VelocitySmootherNode
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime


def _fast_smoother() -> tuple[Runtime, list[tuple[float, float]]]:
    rt = Runtime()
    VelocitySmootherNode(rt, VelocitySmootherParams(smoothing_frequency=20.0))
    out: list[tuple[float, float]] = []
    rt.bus.subscribe("/cmd_vel_smoothed", Twist, lambda t: out.append((rt.now, t.linear.x)),
                     QoS(depth=100))
    rt.bring_up()
    cmd = rt.bus.publisher("/cmd_vel_nav", Twist, QoS(depth=1))
    drive = rt.scheduler.create_timer(  # 2 s of 0.5 m/s: the smoother reaches it
        0.05, lambda: cmd.publish(Twist(Vector3(0.5, 0.0, 0.0))), first_at=0.0)
    rt.scheduler.run_until(2.0)
    drive.cancel()
    return rt, out


def test_a_zero_command_is_ramped_but_a_stop_request_is_not() -> None:
    rt, out = _fast_smoother()
    assert out[-1][1] == 0.5
    rt.bus.publisher("/cmd_vel_nav", Twist, QoS(depth=1)).publish(Twist())
    rt.scheduler.run_until(2.06)
    assert 0.0 < out[-1][1] < 0.5  # Nav2's deceleration ramp

    rt, out = _fast_smoother()
    n = len(out)
    rt.bus.publisher(STOP_TOPIC, Bool, QoS(depth=1)).publish(Bool(True))
    rt.bus.publisher("/cmd_vel_nav", Twist, QoS(depth=1)).publish(Twist())
    rt.scheduler.run_until(3.0)
    assert out[n][0] == 2.0 and out[n][1] == 0.0  # zero at once, at the request
    assert all(v == 0.0 for _, v in out[n:])
