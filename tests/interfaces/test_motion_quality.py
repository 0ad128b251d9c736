"""Issue 18's motion-quality metrics on constructed paths."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.interfaces.motion_quality import (
    curvature_sign_changes,
    length_ratio,
    self_crossings,
    sign_changes_per_10m,
)


def test_a_loop_crosses_itself_a_turn_in_place_does_not() -> None:
    t = np.linspace(0.0, 2.5 * math.pi, 200)
    loop = np.column_stack((t * 0.3 + np.sin(t), np.cos(t)))  # a curl along x
    assert self_crossings(loop) >= 1
    corner = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    assert self_crossings(corner) == 0


def test_length_ratio() -> None:
    plan = np.array([[0.0, 0.0], [4.0, 0.0]])
    driven = np.array([[0.0, 0.0], [2.0, 0.5], [4.0, 0.0]])
    assert length_ratio(driven, plan) == pytest.approx(2 * math.hypot(2.0, 0.5) / 4.0)


def test_curvature_sign_changes_count_zigzags_not_straight_lines() -> None:
    x = np.linspace(0.0, 10.0, 201)
    assert curvature_sign_changes(np.column_stack((x, 0.3 * x))) == 0
    zigzag = np.column_stack((x, 0.05 * np.sign(np.sin(2 * math.pi * x / 1.0))))
    assert curvature_sign_changes(zigzag) >= 10
    s_bend = np.column_stack((x, np.tanh(x - 5.0)))  # left then right: one change
    assert curvature_sign_changes(s_bend) == 1
    assert sign_changes_per_10m(s_bend) == pytest.approx(1.0 * 10.0 / max(10.0, 11.0), 0.2)
