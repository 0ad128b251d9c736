"""Path helpers: length, orientations, Nav2-style simple smoothing kept collision free."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navstack.core.msgs import Pose2D
from navstack.costmap.costmap_2d import Costmap2D
from navstack.interfaces.motion_quality import curvature_sign_changes
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
    descent = NavfnPlanner(NavfnParams(use_astar=True, smooth_path=False))  # NavFn's own path
    raw = descent.plan(start, goal, cm).as_array()[:, :2]
    assert (_samples_cost(raw, cm) < 253).all()
    params = SimpleSmootherParams(w_smooth=0.45, w_data=0.05)
    out = smooth_path(raw, cm, params)
    assert (_samples_cost(out, cm) < 253).all()
    assert path_length(out) < path_length(raw)
    # the same smoothing without the obstacles cuts through the inflated corner
    free = Costmap2D.from_array(np.zeros_like(data), 0.05)
    assert (_samples_cost(smooth_path(raw, free, params), cm) >= 253).any()


def test_straighten_replaces_a_wobble_in_free_space_by_one_chord() -> None:
    from navstack.planning.path_utils import straighten

    cm = Costmap2D.from_array(np.zeros((60, 100), dtype=np.uint8), 0.05)
    x = np.linspace(0.5, 4.5, 21)
    xy = np.column_stack((x, 1.5 + 0.05 * np.sin(x * 6.0)))  # +-5 cm ripple
    out = straighten(xy, cm, 0.15)
    assert out.tolist() == [xy[0].tolist(), xy[-1].tolist()]
    bump = xy.copy()
    bump[10, 1] += 0.3  # a 0.3 m detour point: beyond the deviation bound, kept
    out = straighten(bump, cm, 0.15)
    assert bump[10].tolist() in out.tolist()
    assert straighten(bump, cm, 0.4).tolist() == [xy[0].tolist(), xy[-1].tolist()]


def test_straighten_never_crosses_cells_costlier_than_the_chord_ends() -> None:
    """Around a disc of inflated cost (a person on the costmap) the detour's pinch point
    stays a vertex: a chord past it would run through costlier cells."""
    from navstack.planning.path_utils import straighten

    res = 0.05
    yy, xx = np.mgrid[0:60, 0:100]
    d = np.hypot((xx + 0.5) * res - 2.5, (yy + 0.5) * res - 2.2)  # a person at (2.5, 2.2)
    data = np.where(d < 0.3, 254, np.where(d < 0.57, 253,
                                           np.where(d < 1.0, 252 * np.exp(-2.5 * (d - 0.57)),
                                                    0))).astype(np.uint8)
    cm = Costmap2D.from_array(data, res)
    x = np.linspace(0.5, 4.5, 41)
    y = 1.5 - 0.35 * np.exp(-((x - 2.5) / 0.6) ** 2)  # dips to 1.15 under the person
    xy = np.column_stack((x, y))
    out = straighten(xy, cm, 1.0)
    assert len(out) >= 3 and out[0].tolist() == xy[0].tolist()
    assert out[-1].tolist() == xy[-1].tolist()
    assert _samples_cost(out, cm).max() <= int(_samples_cost(xy, cm).max() * 1.15)



def _turns(xy: np.ndarray) -> np.ndarray:
    d = np.diff(xy, axis=0)
    h = np.arctan2(d[:, 1], d[:, 0])
    return np.angle(np.exp(1j * np.diff(h)))


def _leg() -> tuple[np.ndarray, np.ndarray]:
    """Corners of a corridor leg heading west: a detour's return (15 deg right), an
    8 deg kink to the left 0.19 m off the chord past it, a 90 deg right turn into a door;
    and the leg sampled every ~0.1 m."""
    corners = [np.array([9.0, 2.0])]
    h = math.pi
    for length, turn in ((2.0, 0.0), (2.5, -15.0), (3.0, 8.0), (2.3, -90.0)):
        h += math.radians(turn)
        corners.append(corners[-1] + length * np.array([math.cos(h), math.sin(h)]))
    c = np.array(corners)
    xy = np.concatenate([np.linspace(c[i], c[i + 1], 25, endpoint=False)
                         for i in range(len(c) - 1)] + [c[-1:]])
    return c, xy


def test_straighten_drops_a_kink_against_both_corners_around_it() -> None:
    """The kink lies beyond the deviation bound but turns against both corners around it
    by less than either, and the chord past it stays in free space: it goes (two
    curvature sign changes fewer); the corners themselves stay."""
    from navstack.planning.path_utils import straighten

    corners, xy = _leg()
    assert np.sign(_turns(corners)).tolist() == [-1.0, 1.0, -1.0]
    assert curvature_sign_changes(xy) == 2
    cm = Costmap2D.from_array(np.zeros((140, 220), dtype=np.uint8), 0.05)
    out = straighten(xy, cm, 0.05)
    assert curvature_sign_changes(out) == 0
    assert _distance_to_polyline(corners[2], out) > 0.15  # the kink went
    for corner in corners[[1, 3]]:  # the two corners stayed (within the bound)
        assert _distance_to_polyline(corner, out) <= 0.05
    assert out[0].tolist() == xy[0].tolist() and out[-1].tolist() == xy[-1].tolist()


def _line_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance of ``p`` from the infinite line through ``a`` and ``b``."""
    u = (b - a) / np.hypot(*(b - a))
    return float(abs(u[0] * (p[1] - a[1]) - u[1] * (p[0] - a[0])))


def test_straighten_merges_a_kink_into_the_next_corner_when_its_chord_is_blocked() -> None:
    """A box under the chord past the kink: the segment before the kink is carried on
    until it meets the segment after the next corner (kink and corner become one corner,
    the plan's directions before and after kept), clear of the box."""
    from navstack.planning.path_utils import straighten

    corners, xy = _leg()
    data = np.zeros((140, 220), dtype=np.uint8)
    data[46:50, 86:98] = 254  # x 4.3-4.9, y 2.3-2.5: between the kink and its chord
    cm = Costmap2D.from_array(data, 0.05)
    out = straighten(xy, cm, 0.05)
    assert curvature_sign_changes(out) == 0
    assert _distance_to_polyline(corners[2], out) <= 0.05  # still through the kink's place
    assert _distance_to_polyline(corners[1], out) <= 0.05  # the first corner stayed
    assert _line_distance(out[-2], corners[3], corners[4]) < 1e-6  # on the door's line
    assert _samples_cost(out, cm).max() == 0
    assert path_length(out) <= path_length(xy)


def test_straighten_merges_a_kink_into_the_previous_corner() -> None:
    """The leg driven the other way with a second box under the first merge's segment:
    the segment before the previous corner is carried on instead (the door's line kept,
    the kink's leg carried back to meet it), clear of both boxes."""
    from navstack.planning.path_utils import straighten

    corners, xy = _leg()
    data = np.zeros((140, 220), dtype=np.uint8)
    data[46:50, 86:98] = 254  # under the chord past the kink
    data[44:47, 138:142] = 254  # x 6.9-7.1, y 2.2-2.35: under the next corner's merge
    cm = Costmap2D.from_array(data, 0.05)
    back = xy[::-1].copy()
    out = straighten(back, cm, 0.05)
    assert curvature_sign_changes(back) == 2 and curvature_sign_changes(out) == 0
    assert _distance_to_polyline(corners[2], out) <= 0.05
    assert _line_distance(out[1], corners[4], corners[3]) < 1e-6  # on the door's line
    assert _samples_cost(out, cm).max() == 0
    assert out[0].tolist() == back[0].tolist() and out[-1].tolist() == back[-1].tolist()


def test_straighten_keeps_a_kink_the_costmap_requires() -> None:
    """The same leg with boxes under the chord past the kink and under both merges of
    the kink with a corner beside it: every replacement would cross cells costlier than
    its ends, so the kink stays."""
    from navstack.planning.path_utils import straighten

    corners, xy = _leg()
    data = np.zeros((140, 220), dtype=np.uint8)
    data[46:50, 86:98] = 254  # x 4.3-4.9, y 2.3-2.5: between the kink and its chord
    data[59:62, 58:62] = 254  # x 2.9-3.1, y 2.95-3.1: the kink's leg carried on
    cm = Costmap2D.from_array(data, 0.05)
    out = straighten(xy, cm, 0.05)
    assert curvature_sign_changes(out) == 2
    assert _distance_to_polyline(corners[2], out) <= 0.05


def _distance_to_polyline(p: np.ndarray, xy: np.ndarray) -> float:
    a, b = xy[:-1], xy[1:]
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    return float(np.min(np.hypot(*(a + t[:, None] * ab - p).T)))
