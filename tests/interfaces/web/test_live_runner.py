"""EStopGate on a bare bus with the twist mux (exact command sequences at the base) and
LiveRunner threading, pacing and error reporting."""

from __future__ import annotations

import threading
import time

import pytest

from navstack.control.twist_mux import twist_mux_params
from navstack.core.errors import ConfigError
from navstack.core.msgs import Twist, Vector3
from navstack.interfaces.live_runner import EStopGate, LiveRunner, LiveRunnerParams, RunnerError
from navstack.interfaces.stack import NavStack
from navstack.nodes.estop import EStopClient, EStopReleaseRefused
from navstack.nodes.twist_mux import TwistMuxNode
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime


def _cmd(vx: float, wz: float = 0.0) -> Twist:
    return Twist(Vector3(vx, 0.0, 0.0), Vector3(0.0, 0.0, wz))


MUX = {"topics": [{"name": "navigation", "topic": "/nav_vel", "timeout": 0.5, "priority": 10},
                  {"name": "teleop", "topic": "/joy_vel", "timeout": 0.5, "priority": 100}],
       "locks": [{"name": "e_stop_lock", "topic": "/emergency_stop", "timeout": 0.0,
                  "priority": 255}]}


@pytest.mark.parametrize("base_first", [True, False])
def test_estop_gate_latches_the_mux_lock_and_zeroes_the_base_at_the_same_instant(
        base_first: bool) -> None:
    rt = Runtime()
    seen: list[tuple[float, float, float]] = []

    def base() -> None:
        rt.bus.subscribe("/cmd_vel", Twist,
                         lambda m: seen.append((rt.now, m.linear.x, m.angular.z)), QoS(depth=1))

    if base_first:
        base()
    TwistMuxNode(rt, twist_mux_params(MUX))
    gate = EStopGate(rt)
    if not base_first:
        base()
    rt.bring_up()
    nav = rt.bus.publisher("/nav_vel", Twist)
    teleop = rt.bus.publisher("/joy_vel", Twist)
    nav.publish(_cmd(0.4))
    rt.scheduler.run_until(0.05)
    assert seen == [(0.0, 0.4, 0.0)]
    assert gate.latch("test") == 0.05
    rt.scheduler.call_at(0.1, lambda: nav.publish(_cmd(0.3, 0.2)))
    rt.scheduler.call_at(0.2, lambda: teleop.publish(_cmd(-0.2)))
    rt.scheduler.run_until(0.25)
    # the last command the base holds at every instant is zero
    last: dict[float, tuple[float, float]] = {}
    for t, vx, wz in seen:
        last[t] = (vx, wz)
    assert last == {0.0: (0.4, 0.0), 0.05: (0.0, 0.0), 0.1: (0.0, 0.0), 0.2: (0.0, 0.0)}
    # zeros the base got while latched: the mux's and the gate's at the latch, and the
    # mux's answers to the masked inputs at 0.1 and 0.2 s
    assert gate.overrides == 4 and gate.latched and gate.latched_at == 0.05
    assert gate.latch("again") == 0.05  # idempotent: keeps the first latch time
    assert gate.release() == 0.25
    rt.scheduler.run_until(0.75)  # teleop (priority 100, sent at 0.2 s) has timed out
    nav.publish(_cmd(0.25))
    rt.scheduler.run_until(0.8)
    assert seen[-1] == (0.75, 0.25, 0.0) and gate.overrides == 4
    assert gate.state() == {"latched": False, "latched_at": 0.05, "released_at": 0.25,
                            "reason": "", "holder": "", "overrides": 4,
                            "refused_releases": 0}
    other = EStopClient(rt, "telegram:7")
    other.latch("from the chat")
    rt.scheduler.run_until(0.85)
    assert gate.latched and gate.state()["holder"] == "telegram:7"
    with pytest.raises(EStopReleaseRefused, match="held by 'telegram:7'"):
        gate.release()
    assert gate.state()["refused_releases"] == 1


def test_runner_paces_runs_commands_in_its_thread_and_stops() -> None:
    stack = NavStack("office", seed=1)
    runner = LiveRunner(stack, real_time_factor=2.0)
    with pytest.raises(RunnerError, match=r"^the simulation is not running yet; call "
                                          r"LiveRunner.start\(\) first$"):
        runner.submit(lambda s: s.now)
    assert runner.call(lambda s: threading.current_thread()) is threading.current_thread()
    wall0, sim0 = time.monotonic(), stack.now
    runner.start()
    with pytest.raises(RunnerError, match="already started"):
        runner.start()
    time.sleep(1.0)
    name = runner.submit(lambda s: threading.current_thread().name).result(5)
    assert name == "navstack-sim"
    sim = runner.call(lambda s: s.now)
    wall = time.monotonic() - wall0
    # never ahead of 2x real time (plus the step in progress); behind only under load
    assert sim - sim0 <= 2.0 * wall + runner.params.step + 1e-9
    assert sim - sim0 >= 0.5
    failing = runner.submit(lambda s: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        failing.result(5)
    assert runner.running  # a failing command does not stop the simulation
    runner.stop()
    assert not runner.running and runner.wait(0)
    with pytest.raises(RunnerError, match=r"^the simulation was stopped$"):
        runner.submit(lambda s: s.now)


def test_runner_reports_a_crash_of_the_stack() -> None:
    stack = NavStack("office", seed=1)
    runner = LiveRunner(stack, real_time_factor=None)
    runner.start()

    def explode() -> None:
        raise RuntimeError("boom in a node")

    runner.call(lambda s: s.runtime.scheduler.call_soon(explode))
    assert runner.wait(10)
    assert isinstance(runner.error, RuntimeError) and not runner.running
    with pytest.raises(RunnerError, match=r"^the simulation stopped with an error: boom in a "
                                          r"node$"):
        runner.submit(lambda s: s.now)


def test_runner_params_are_validated() -> None:
    with pytest.raises(ConfigError, match=r"live_runner\.real_time_factor"):
        LiveRunnerParams.from_mapping({"real_time_factor": 0.0}, key_path="live_runner")
    with pytest.raises(ConfigError, match=r"step"):
        LiveRunnerParams.from_mapping({"step": 2.0})
    assert LiveRunnerParams().step == 0.05  # one cycle of controller_frequency 20 Hz
