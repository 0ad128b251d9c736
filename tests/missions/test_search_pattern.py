"""Search geometry of the rover: the spiral's points and spacing, nearest-first order,
circle points around a gate post, gate crossing points and scan headings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.missions.search_pattern import (
    circle_points,
    gate_points,
    nearest_first,
    scan_headings,
    spiral_points,
)


def test_spiral_matches_the_rover_formula() -> None:
    pts = spiral_points()
    assert pts.shape == (25, 2)
    for r in (0, 1, 7, 24):
        theta = r * math.pi / 4
        assert pts[r] == pytest.approx([(r + 1) * math.cos(theta) / 2,
                                        (r + 1) * math.sin(theta) / 2], abs=1e-12)
    radius = np.hypot(*pts.T)
    assert radius[0] == 0.5 and radius[-1] == 12.5
    # one turn is 8 points; successive turns are 4 m apart along a ray
    assert radius[8] - radius[0] == pytest.approx(4.0)
    shifted = spiral_points(origin=(10.0, -3.0), yaw=math.pi / 2)
    assert shifted[0] == pytest.approx([10.0, -2.5])
    with pytest.raises(ValueError, match="stop"):
        spiral_points(5, 5)


def test_nearest_first_is_a_greedy_chain() -> None:
    pts = np.array([[10.0, 0.0], [1.0, 0.0], [5.0, 0.0], [2.0, 0.0]])
    assert nearest_first(pts, (0.0, 0.0)).tolist() == [[1, 0], [2, 0], [5, 0], [10, 0]]
    assert nearest_first(pts, (11.0, 0.0))[0].tolist() == [10.0, 0.0]


def test_circle_points_start_nearest_the_robot() -> None:
    pts = circle_points((5.0, 5.0), 2.0, robot_xy=(5.0, 0.0))
    assert pts.shape == (4, 2)
    assert pts[0] == pytest.approx([5.0, 3.0])
    assert pts[1] == pytest.approx([7.0, 5.0])  # counter-clockwise
    assert np.hypot(*(pts - 5.0).T) == pytest.approx([2.0] * 4)
    with pytest.raises(ValueError, match="radius"):
        circle_points((0.0, 0.0), 0.0, (1.0, 1.0))


def test_gate_points_cross_from_the_robot_side() -> None:
    pts, heading = gate_points((0.0, -1.0), (0.0, 1.0), robot_xy=(-6.0, 0.5))
    assert pts.tolist() == [[-4.0, 0.0], [0.0, 0.0], [4.0, 0.0]]
    assert heading == pytest.approx(0.0)
    pts, heading = gate_points((0.0, -1.0), (0.0, 1.0), robot_xy=(6.0, 0.0))
    assert pts[0].tolist() == [4.0, 0.0] and heading == pytest.approx(math.pi)
    with pytest.raises(ValueError, match="same place"):
        gate_points((1.0, 1.0), (1.0, 1.0), (0.0, 0.0))


def test_scan_turns_right_20_then_left_40() -> None:
    right, left = scan_headings(0.0)
    assert right == pytest.approx(-math.radians(20)) and left == pytest.approx(math.radians(20))
    right, left = scan_headings(math.pi)
    assert right == pytest.approx(math.pi - math.radians(20))
    assert left == pytest.approx(-math.pi + math.radians(20))
