"""Path helpers: length, orientations, Nav2-style simple smoothing kept collision free."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import Costmap2D
from navstack.planning import (
    NavfnParams,
    NavfnPlanner,
    SimpleSmootherParams,
    make_path,
    orientations,
    path_length,
    smooth_path,
)


def _samples_cost(xy: np.ndarray, cm: Costmap2D) -> np.ndarray:
    """Costs of points sampled every 1 cm along the polyline."""
    pts = [xy[0]]
    for a, b in itertools.pairwise(xy):
        n = max(1, math.ceil(np.hypot(*(b - a)) / 0.01))
        t = np.linspace(0.0, 1.0, n + 1)[1:, None]
        pts.extend(a + t * (b - a))
    mx, my, inside = cm.world_to_map_array(np.array(pts))
    assert inside.all()
    return cm.data[my, mx]


def test_length_and_orientations() -> None:
    xy = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 4.0], [3.0, 6.0]])
    assert path_length(xy) == pytest.approx(7.0)
    th = orientations(xy, goal_theta=1.0)
    np.testing.assert_allclose(th, [math.atan2(4, 3), math.atan2(4, 3), math.pi / 2, 1.0])
    assert orientations(xy, 1.0, final_approach=True)[-1] == pytest.approx(math.pi / 2)
    path = make_path(xy, 1.0, "odom")
    assert path.header.frame_id == "odom" and len(path.poses) == 4
    assert path.length() == pytest.approx(7.0)


def test_smoothing_shortens_a_zigzag_and_keeps_the_ends() -> None:
    cm = Costmap2D.from_array(np.zeros((40, 40), dtype=np.uint8), 0.1)
    xy = np.array([[0.5 + 0.2 * i, 1.5 + (0.2 if i % 2 else 0.0)] for i in range(15)])
    out = smooth_path(xy, cm)
    assert path_length(out) < 0.8 * path_length(xy)
    np.testing.assert_array_equal(out[[0, -1]], xy[[0, -1]])
    # lateral wiggle shrinks to a fraction of its original 0.2 m amplitude
    assert np.ptp(out[3:-3, 1]) < 0.1
    plain = smooth_path(xy, cm, SimpleSmootherParams(do_refinement=False))
    assert path_length(out) <= path_length(plain) + 1e-12


def test_smoothing_never_enters_inscribed_or_lethal_cells() -> None:
    data = np.zeros((60, 60), dtype=np.uint8)
    data[:40, 28:32] = 254  # wall, inflated by two cells of inscribed cost
    data[:42, 26:28] = data[:42, 32:34] = data[40:42, 26:34] = 253
    cm = Costmap2D.from_array(data, 0.05)
    start, goal = Pose2D(*cm.map_to_world(20, 5)), Pose2D(*cm.map_to_world(40, 5))
    raw = NavfnPlanner(NavfnParams(use_astar=True)).plan(start, goal, cm).as_array()[:, :2]
    assert (_samples_cost(raw, cm) < 253).all()
    params = SimpleSmootherParams(w_smooth=0.45, w_data=0.05)
    out = smooth_path(raw, cm, params)
    assert (_samples_cost(out, cm) < 253).all()
    assert path_length(out) < path_length(raw)
    # the same smoothing without the obstacles cuts through the inflated corner
    free = Costmap2D.from_array(np.zeros_like(data), 0.05)
    assert (_samples_cost(smooth_path(raw, free, params), cm) >= 253).any()
