"""Penetration depth of a footprint into lethal cells, and the escape rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from navstack.costmap.footprint_penetration import (
    escape_allowed,
    inward_edges,
    penetration_depth,
)

# the Waffle Pi's body: 0.076 m ahead of and 0.205 m behind base_link, 0.153 m each side
BODY = np.array([[0.076, 0.153], [-0.205, 0.153], [-0.205, -0.153], [0.076, -0.153]])


def wall_map(row_top_y: float) -> Costmap2D:
    """4 x 4 m at 0.05 m, origin (-2, -2), lethal everywhere below ``row_top_y``."""
    cm = Costmap2D(80, 80, 0.05, -2.0, -2.0)
    rows = round((row_top_y + 2.0) / 0.05)
    cm.data[:rows, :] = LETHAL_OBSTACLE
    return cm


def test_depth_of_a_wall_edge_inside_the_body() -> None:
    # the wall's top edge at y = -0.10: its last row of cells has centres at -0.125, so the
    # deepest centre is 0.153 - 0.125 = 0.028 inside the body; + half a cell = 0.053
    cm = wall_map(-0.10)
    assert penetration_depth(cm, Pose2D(0.0, 0.0, 0.0), BODY) == pytest.approx(0.053)
    # clear of the wall: 0
    assert penetration_depth(cm, Pose2D(0.0, 0.3, 0.0), BODY) == 0.0
    # unknown cells (255) are not obstacles
    unknown = Costmap2D(80, 80, 0.05, -2.0, -2.0)
    unknown.data[:] = 255
    assert penetration_depth(unknown, (0.0, 0.0, 0.0), BODY) == 0.0


def test_escape_rule_along_away_and_into_a_wall() -> None:
    cm = wall_map(-0.10)
    start = Pose2D(0.0, 0.0, 0.0)
    along = [(-0.05 * k, 0.0, 0.0) for k in range(1, 8)]  # backing up parallel to it
    assert escape_allowed(cm, start, along, BODY) == (True, None)
    away = [(0.0, 0.02 * k, 0.0) for k in range(1, 5)]
    assert escape_allowed(cm, start, away, BODY)[0]
    into = [(0.0, -0.02 * k, 0.0) for k in range(1, 5)]
    ok, hit = escape_allowed(cm, start, into, BODY)
    assert not ok and hit is not None and hit[1] == pytest.approx(-0.02)  # 2 cm deeper
    # turning in place swings a corner deeper into the wall
    turn = [(0.0, 0.0, 0.1 * k) for k in range(1, 5)]
    assert not escape_allowed(cm, start, turn, BODY)[0]
    # from a free pose any contact refuses
    free = Pose2D(0.0, 0.5, 0.0)
    assert not escape_allowed(cm, free, [(0.0, -0.05, 0.0)], BODY)[0]


def test_inward_edges_of_a_clockwise_non_convex_polygon_use_its_hull() -> None:
    notch = np.array([[0.0, 0.0], [0.0, 1.0], [0.5, 0.5], [1.0, 1.0], [1.0, 0.0]])
    points, normals = inward_edges(notch)
    assert len(points) == 4  # the notch vertex is dropped
    centre = np.array([0.5, 0.4])
    inside = ((centre - points) * normals).sum(axis=1)
    assert np.all(inside > 0) and np.allclose(np.hypot(*normals.T), 1.0)
    with pytest.raises(ValueError, match="at least 3"):
        inward_edges(np.zeros((2, 2)))
    assert math.isfinite(penetration_depth(wall_map(0.0), (0.0, 0.0, 0.0), notch))
