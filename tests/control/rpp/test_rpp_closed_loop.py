"""RPP in closed loop with an exact unicycle: straight line, circle, reversing, cusp, and
cost-regulated slow-down next to an obstacle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.control.rpp import RegulatedPurePursuitController
from navstack.core.msgs import Path, Pose2D
from navstack.core.polygon import Footprint
from navstack.costmap.costmap_2d import Costmap2D

from .loop import circle_path, drive, straight_path

CAR = {"use_rotate_to_heading": False, "min_turning_radius": 1.0}


def test_follows_a_straight_path() -> None:
    trace = drive(RegulatedPurePursuitController(), straight_path(10.0), Pose2D(0.0, 0.3, 0.0),
                  25.0, stop_within=0.25)
    x, y = trace.poses[:, 0], trace.poses[:, 1]
    steady = x > 3.0
    assert steady.sum() > 50
    assert np.abs(y[steady]).max() < 0.1  # cross-track error
    assert np.abs(y[steady]).max() < 0.01  # in fact it converges onto the line
    assert x[-1] > 9.75
    assert trace.cmds[steady & (x < 9.0), 0] == pytest.approx(0.5)  # desired_linear_vel


@pytest.mark.parametrize("params", [{}, CAR], ids=["diff-drive", "car-like"])
def test_follows_a_circle_of_radius_two(params: dict[str, object]) -> None:
    ctrl = RegulatedPurePursuitController(params)
    trace = drive(ctrl, circle_path(2.0, 1.2), Pose2D(0.0, -0.15, 0.1), 28.0)
    r = np.hypot(trace.poses[:, 0], trace.poses[:, 1] - 2.0)
    steady = np.arange(len(r)) > 60  # after the first 3 s
    assert np.abs(r[steady] - 2.0).max() < 0.1
    assert np.abs(r[-100:] - 2.0).max() < 0.01
    v, w = trace.cmds[steady].T
    assert v[:200] == pytest.approx(0.5)  # radius 2 > regulated_linear_scaling_min_radius
    assert np.abs(w / v).max() <= 1.0 + 1e-12 if params else True  # car: |curvature| <= 1


def test_reverses_along_a_path_behind_the_robot() -> None:
    path = straight_path(3.0, heading=math.pi, theta=0.0)  # robot faces +x, path runs to -x
    ctrl = RegulatedPurePursuitController({"allow_reversing": True,
                                           "use_rotate_to_heading": False})
    trace = drive(ctrl, path, Pose2D(0.0, 0.1, 0.0), 15.0, stop_within=0.05)
    x, y, th = trace.poses.T
    assert np.all(trace.cmds[:, 0] < 0.0)  # backward all the way
    assert math.hypot(x[-1] + 3.0, y[-1]) < 0.06
    assert np.abs(y[x < -1.0]).max() < 0.02
    assert np.abs(th[x < -1.0]).max() < 0.1  # still facing +x


def test_reverses_at_a_cusp() -> None:
    a = np.arange(0.0, 2.0001, 0.05)
    forward = np.column_stack((a, 0.0 * a, 0.0 * a))
    b = np.arange(0.05, math.sqrt(2.0) + 1e-9, 0.05)
    back = np.column_stack((2.0 - b / math.sqrt(2.0), b / math.sqrt(2.0),
                            np.full_like(b, -math.pi / 4)))
    path = Path.from_array(np.vstack((forward, back)), frame_id="map")
    end = back[-1, :2]
    ctrl = RegulatedPurePursuitController({"allow_reversing": True,
                                           "use_rotate_to_heading": False})
    trace = drive(ctrl, path, Pose2D(0.0, 0.0, 0.0), 20.0, stop_within=0.05)
    v = trace.cmds[:, 0]
    turn = int(np.argmax(v < 0.0))
    assert np.all(v[:turn] > 0.0) and np.all(v[turn:] < 0.0)  # one change of direction
    assert trace.poses[turn, 0] > 1.9  # at the cusp
    assert math.hypot(*(trace.poses[-1, :2] - end)) < 0.05


def _inflated_corridor(r_ins: float = 0.2, k: float = 3.0) -> Costmap2D:
    """12 m x 4 m; a lethal box x in [4, 5], y in [0.35, 1.0] inflated with Nav2's formula
    (252 exp(-k (d - r_ins)) out to 0.8 m, 253 within r_ins)."""
    cm = Costmap2D(240, 80, 0.05, -1.0, -2.0)
    cx = cm.origin_x + (np.arange(cm.size_x) + 0.5) * cm.resolution
    cy = cm.origin_y + (np.arange(cm.size_y) + 0.5) * cm.resolution
    dx = np.maximum(np.maximum(4.0 - cx, cx - 5.0), 0.0)[None, :]
    dy = np.maximum(np.maximum(0.35 - cy, cy - 1.0), 0.0)[:, None]
    d = np.hypot(dx, dy)
    cost = np.where(d <= 0.8, np.floor(252.0 * np.exp(-k * (d - r_ins))), 0.0)
    cost = np.where(d <= r_ins, 253, cost)
    cost = np.where(d == 0.0, 254, cost)
    cm.data[:] = cost.astype(np.uint8)
    return cm


def test_slows_down_next_to_an_obstacle_by_the_nav2_formula() -> None:
    cm = _inflated_corridor()
    ctrl = RegulatedPurePursuitController({"regulated_linear_scaling_min_speed": 0.05},
                                          footprint=Footprint.from_radius(0.2))
    trace = drive(ctrl, straight_path(10.0), Pose2D(0.0, 0.0, 0.0), 30.0, costmap=cm)
    x = np.concatenate(([0.0], trace.poses[:-1, 0]))  # pose at which each command was made
    v = trace.cmds[:, 0]
    c = trace.costs.astype(float)
    mid = (x > 1.0) & (x < 8.5)
    d = (3.0 * 0.2 - np.log(np.where(c > 0, c, 1.0)) + math.log(253.0)) / 3.0
    expected = np.where((c > 0) & (d < 0.6), 0.5 * d / 0.6, 0.5)
    np.testing.assert_allclose(v[mid], np.maximum(expected[mid], 0.05), rtol=1e-12)
    near = mid & (x > 4.0) & (x < 5.0)
    assert v[near].max() < 0.3  # cell cost 173 there: 0.5 * 0.327 / 0.6 = 0.27 m/s
    assert v[mid & (x > 6.0)] == pytest.approx(0.5)  # back to full speed past it
    assert np.abs(trace.poses[:, 1]).max() < 1e-9  # still exactly on the path
