"""Oscillation detection: fires on a left-right-left command stream that goes nowhere,
not on a slalom that makes progress, and not on a real navigation run in the simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.oscillation import OscillationDetector, OscillationParams
from navstack.core.msgs import PoseStamped, Twist
from navstack.interfaces.api import Navigator, TaskResult
from navstack.interfaces.stack import NavStack

DT = 0.05  # 20 Hz, the controller frequency


def _feed(det: OscillationDetector, cmds: np.ndarray, xy: np.ndarray) -> list[float]:
    fired = []
    for i, ((v, w), (x, y)) in enumerate(zip(cmds, xy, strict=True)):
        if det.update(i * DT, float(v), float(w), float(x), float(y)) is not None:
            fired.append(i * DT)
    return fired


def test_fires_on_turning_left_and_right_on_the_spot() -> None:
    t = np.arange(0, 10, DT)
    w = 0.6 * np.sign(np.sin(2 * math.pi * 0.5 * t))  # flips every second
    cmds = np.column_stack([np.zeros_like(t), w])
    xy = np.zeros((len(t), 2)) + 0.01 * np.sin(t)[:, None]
    det = OscillationDetector()
    fired = _feed(det, cmds, xy)
    assert fired and fired[0] <= 6.0  # within one window of the start
    report = det.update(10.0, 0.0, -0.6, 0.0, 0.0)
    assert report is not None and report.angular_flips >= 4
    assert report.reason.startswith("oscillating: ")
    assert "sign flips within 6 s while moving 0.0" in report.reason


def test_fires_on_back_and_forth_shuffling() -> None:
    t = np.arange(0, 10, DT)
    v = 0.2 * np.sign(np.sin(2 * math.pi * 0.4 * t))
    x = np.cumsum(v) * DT
    assert np.ptp(x) < 0.5
    fired = _feed(OscillationDetector(), np.column_stack([v, np.zeros_like(t)]),
                  np.column_stack([x, np.zeros_like(t)]))
    assert fired


def test_silent_on_a_slalom_that_makes_progress_and_on_small_wobble() -> None:
    t = np.arange(0, 20, DT)
    w = 0.6 * np.sign(np.sin(2 * math.pi * 0.5 * t))
    v = np.full_like(t, 0.4)
    xy = np.column_stack([0.4 * t, 0.2 * np.sin(t)])
    assert _feed(OscillationDetector(), np.column_stack([v, w]), xy) == []
    wobble = 0.03 * np.sign(np.sin(2 * math.pi * t))  # inside the deadband
    assert _feed(OscillationDetector(), np.column_stack([np.zeros_like(t), wobble]),
                 np.zeros((len(t), 2))) == []


def test_time_going_back_resets() -> None:
    det = OscillationDetector(OscillationParams(window=2.0, min_flips=2))
    for i in range(40):
        det.update(i * DT, 0.0, 0.5 if i % 10 < 5 else -0.5, 0.0, 0.0)
    assert det.update(0.0, 0.0, 0.5, 0.0, 0.0) is None  # a new run


def test_silent_on_a_real_navigation_run() -> None:
    """Two office legs in the simulator with DWB (out of the start room and through two
    doors): every command the base received, with the true position, goes through the
    detector; it never fires."""
    stack = NavStack("office", seed=3)
    nav = Navigator(stack)
    det = OscillationDetector()
    fired: list[str] = []
    commands = 0

    def on_cmd(msg: Twist) -> None:
        nonlocal commands
        commands += 1
        x, y, _ = stack.sim.sim.pose.as_array()
        report = det.update(stack.now, msg.linear.x, msg.angular.z, x, y)
        if report is not None:
            fired.append(f"{stack.now:.1f} s: {report.reason}")

    stack.runtime.bus.subscribe("/cmd_vel", Twist, on_cmd)
    for name in ("Goal_1", "Goal_2"):
        goal = PoseStamped.from_pose2d(stack.world.waypoints[name], "map")
        assert nav.goToPose(goal), nav.last_error
        while not nav.isTaskComplete():
            pass
        assert nav.getResult() == TaskResult.SUCCEEDED, name
        det.reset()
    assert commands > 500
    assert fired == []


@pytest.mark.parametrize("bad", [{"window": 0.0}, {"min_flips": 0}, {"deadband": -1.0}])
def test_bad_params_name_the_key(bad: dict[str, float]) -> None:
    key = next(iter(bad))
    with pytest.raises(Exception, match=key):
        OscillationParams.from_mapping(bad)
