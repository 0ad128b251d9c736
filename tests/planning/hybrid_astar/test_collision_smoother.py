"""Conservative footprint cell sets, the possibly-inscribed cost, and the smoother."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.costmap.inflation_kernel import cost_lut
from navstack.planning.hybrid_astar.collision import (
    HEADING_SLACK,
    HEADING_STEP,
    POSE_SLACK,
    SAMPLE_STEP,
    SUBCELLS,
    FootprintCells,
    cheb_to_polygon,
    pose_check,
    possible_collision_cost,
    set_index,
)
from navstack.planning.hybrid_astar.motion import build_motion_table
from navstack.planning.hybrid_astar.smoother import (
    _descend,
    _solve,
    curvatures,
    segments,
)
from tests.planning.hybrid_astar.helpers import INFLATION, RES, ROBOT, costmap


def test_cell_sets_cover_every_pose_they_stand_for() -> None:
    """Any pose within the slack of a sub-cell centre and bin overlaps only set cells."""
    bins = 72
    cells = FootprintCells(ROBOT.polygon, RES, bins)
    assert len(cells.starts) == 2 * bins * SUBCELLS**2 + 1
    poly = ROBOT.polygon / RES
    rng = np.random.default_rng(2)
    for b, sx, sy in ((0, 0, 0), (7, 3, 1), (18, 2, 2), (41, 0, 3), (63, 3, 3)):
        i = set_index(b, sx, sy)
        have = {(int(x), int(y)) for x, y in cells.offsets(i)}
        cx, cy = (sx + 0.5) / SUBCELLS - 0.5, (sy + 0.5) / SUBCELLS - 0.5
        for _ in range(40):
            dx, dy = rng.uniform(-POSE_SLACK, POSE_SLACK, 2) + np.array([cx, cy])
            th = (b + rng.uniform(-HEADING_SLACK, HEADING_SLACK)) * 2 * math.pi / bins
            c, s = math.cos(th), math.sin(th)
            placed = np.column_stack((dx + c * poly[:, 0] - s * poly[:, 1],
                                      dy + s * poly[:, 0] + c * poly[:, 1]))
            for oy in range(-8, 9):
                for ox in range(-8, 9):
                    if cheb_to_polygon(float(ox), float(oy), placed) < 0.5:  # cell overlapped
                        assert (ox, oy) in have, (b, sx, sy, ox, oy)
    assert cells.reach == pytest.approx(float(np.max(np.hypot(cells.off_x, cells.off_y))))


def test_pose_check_reads_the_set_of_the_poses_sub_cell() -> None:
    """A lethal cell only one sub-cell's set holds: poses in that sub-cell collide."""
    cells = FootprintCells(ROBOT.polygon, RES, 72)
    b = 0
    near, far = set_index(b, 0, 0), set_index(b, SUBCELLS - 1, SUBCELLS - 1)

    def offsets(i: int) -> set[tuple[int, int]]:
        return {(int(x), int(y)) for x, y in cells.offsets(i)}

    only_far = offsets(far) - offsets(near)
    assert only_far  # the sub-cells' sets differ
    ox, oy = max(only_far)
    data = np.zeros((40, 40), dtype=np.uint8)
    data[20 + oy, 20 + ox] = 254
    args = (cells.off_x, cells.off_y, cells.starts, cells.border, 0, True)
    assert pose_check(data, 20.05, 20.05, b, *args) == 0
    assert pose_check(data, 20.95, 20.95, b, *args) == -1


def test_skipping_the_inscribed_core_gives_the_same_verdicts() -> None:
    """Skipping the offsets the centre's INSCRIBED cost already covers changes no check,
    near the map's edge included (a core cell off the map is still a collision)."""
    lut = cost_lut(5, RES, ROBOT.inscribed_radius, INFLATION[1])
    covered = int(np.nonzero(lut[:-1] >= 253)[0].max())
    assert covered == 4  # (0.2 m / 0.1 m)^2
    full = FootprintCells(ROBOT.polygon, RES, 72)
    trimmed = FootprintCells(ROBOT.polygon, RES, 72, covered_d2=covered)
    read = sum(trimmed.starts[2 * i + 1] - trimmed.starts[2 * i] for i in range(72 * 16))
    assert read < 0.9 * len(full.off_x)  # offsets read away from the edge
    assert trimmed.reach == full.reach
    rng = np.random.default_rng(5)
    occupied = rng.random((60, 60)) < 0.03  # scattered single-cell obstacles
    data = costmap(occupied).data
    verdicts = []
    for _ in range(4000):
        x, y = rng.uniform(0.0, 60.0, 2)
        b = int(rng.integers(72))
        args = (data, x, y, b)
        a = pose_check(*args, full.off_x, full.off_y, full.starts, full.border, 0, True)
        t = pose_check(*args, trimmed.off_x, trimmed.off_y, trimmed.starts, trimmed.border, 0,
                       True)
        assert a == t, (x, y, b)
        verdicts.append(a)
    assert 0.1 < np.mean(np.array(verdicts) < 0) < 0.9  # both outcomes were exercised


def test_chebyshev_distance_to_a_square() -> None:
    square = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    assert cheb_to_polygon(0.3, -0.2, square) == 0.0
    assert cheb_to_polygon(3.0, 0.5, square) == pytest.approx(2.0)
    assert cheb_to_polygon(3.0, 4.0, square) == pytest.approx(3.0)  # corner: max(2, 3)


def test_possible_collision_cost_is_the_inflation_cost_at_the_reach() -> None:
    lut = cost_lut(11, 0.05, 0.2, 5.0)
    assert possible_collision_cost(7.3, 0.05, 0.2, 0.55, 5.0) == int(lut[53])  # floor(7.3^2)
    assert possible_collision_cost(12.0, 0.05, 0.2, 0.55, 5.0) == 0  # beyond the inflation
    # an offset (8, 1) away: a lethal cell there costs the centre lut[65], not less
    assert possible_collision_cost(math.hypot(8, 1), 0.05, 0.2, 0.55, 5.0) == int(lut[65])


def test_motion_primitives_follow_nav2_geometry() -> None:
    # R = 10 cells, 72 bins: asin(sqrt2 / 20) * 2 = 8.1 deg -> 2 bins of 5 deg
    table = build_motion_table(10.0, 72, reeds_shepp=True, interpolate=False)
    assert table.increments == 2
    assert table.dbin.tolist() == [0, 2, -2, 0, -2, 2]
    a = 2 * 2 * math.pi / 72
    assert table.dx[1, 0] == pytest.approx(10 * math.sin(a))
    assert table.dy[1, 0] == pytest.approx(10 * (1 - math.cos(a)))
    assert table.chord >= math.sqrt(2.0)
    assert table.travel[1] == pytest.approx(10 * a)  # arc length of the turn
    assert table.reverse.tolist() == [False, False, False, True, True, True]
    # every collision sample is at most SAMPLE_STEP cells and HEADING_STEP bins from the
    # previous one: the slack the cell sets are built for
    for p in range(table.size):
        k = table.n_samples[p]
        pts = np.vstack(([0.0, 0.0], table.samples[p, 0, :k, :2]))
        assert np.hypot(*np.diff(pts, axis=0).T).max() <= SAMPLE_STEP + 1e-9
        assert abs(table.dbin[p]) / k <= HEADING_STEP + 1e-9  # evenly spaced on the arc
        assert np.allclose(table.samples[p, 0, k - 1, :2], [table.dx[p, 0], table.dy[p, 0]])


def test_direct_smoothing_equals_the_converged_descent() -> None:
    rng = np.random.default_rng(0)
    raw = np.cumsum(rng.normal(size=(60, 2)), axis=0)
    fixed = np.zeros(60, dtype=np.bool_)
    fixed[[0, 1, 17, 58, 59]] = True
    direct = _solve(raw, fixed, 0.2, 0.3, 3)
    descent = _descend(raw, fixed, 0.2, 0.3, 1e-10, 1000, 3, 0.05)
    assert np.abs(direct - descent).max() < 1e-8
    assert np.array_equal(direct[fixed], raw[fixed])
    # smoothing lowers the smoothness term the descent minimises (squared 2nd differences)
    def roughness(xy: np.ndarray) -> float:
        return float(np.sum(np.diff(xy, n=2, axis=0) ** 2))

    assert roughness(direct) < 0.5 * roughness(raw)


def test_curvature_of_a_circle_and_directional_segments() -> None:
    t = np.linspace(0.0, math.pi, 30)
    arc = np.column_stack((2.5 * np.cos(t), 2.5 * np.sin(t)))
    k = curvatures(arc, math.pi / 2, math.pi / 2)
    assert np.allclose(k, 1 / 2.5)  # inside and at both (tangent) ends
    direction = np.array([1, 1, 1, -1, -1, 1, 1], dtype=np.int8)
    assert segments(direction) == [(0, 2), (2, 4), (4, 6)]
