"""Map and trajectory metrics against closed-form answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.core.geometry import se2_compose
from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Point, Pose, Quaternion
from navstack.mapping.map_metrics import (
    MapComparisonError,
    absolute_trajectory_error,
    align_se2,
    loop_relation_error,
    loop_relations,
    occupancy_iou,
    relative_pose_error,
    trajectory_scores,
)
from navstack.mapping.occupancy import LogOddsGrid
from navstack.sim.world import World

RES = 0.05


def grid(values: np.ndarray, resolution: float = RES, origin: tuple[float, float] = (0.0, 0.0),
         yaw: float = 0.0) -> OccupancyGrid:
    v = np.asarray(values, dtype=np.int8)
    info = MapMetaData(0.0, resolution, v.shape[1], v.shape[0],
                       Pose(Point(origin[0], origin[1], 0.0), Quaternion.from_yaw(yaw)))
    return OccupancyGrid(Header(0.0, "map"), info, v)


def wall_map(cols: slice, row: int = 10) -> np.ndarray:
    """20 x 20 free map with a one-cell-thick horizontal wall."""
    v = np.zeros((20, 20), np.int8)
    v[row, cols] = 100
    return v


def room_world(thickness: int) -> World:
    """Square room, inner faces at |x|, |y| = 2 m, walls ``thickness`` cells, 6 m map."""
    occ = np.zeros((120, 120), bool)
    lo, hi = 20 - thickness, 100 + thickness
    occ[lo:hi, lo:hi] = True
    occ[20:100, 20:100] = False
    occ[60:64, 30:34] = True  # a pillar
    return World(occ, RES, -3.0, -3.0, name="room")


# --- occupancy_iou -----------------------------------------------------------------------
def test_map_compared_with_itself_scores_one() -> None:
    truth = room_world(3).to_occupancy_grid()
    for tol in (0, 1, 2):
        score = occupancy_iou(truth, truth, tolerance_cells=tol)
        assert (score.iou, score.precision, score.recall, score.completeness) == (1, 1, 1, 1)
        assert score.false_positives == score.false_negatives == 0
    # inner faces of the room (4 x 80), the outer faces (border of the 86 x 86 square)
    # and the 12 border cells of the 4 x 4 pillar
    assert score.truth_cells == score.estimate_cells == 4 * 80 + (4 * 86 - 4) + 12


def test_wall_shifted_three_cells_along_itself_with_tolerance_one() -> None:
    truth = grid(wall_map(slice(5, 15)))
    est = grid(wall_map(slice(8, 18)))
    score = occupancy_iou(est, truth, tolerance_cells=1)
    # est cells 8..15 lie within 1 cell of truth 5..14; truth 5 and 6 have no est near
    assert (score.true_positives, score.false_positives, score.false_negatives) == (8, 2, 2)
    assert score.iou == pytest.approx(2.0 / 3.0, abs=1e-15)
    assert score.precision == pytest.approx(0.8) and score.recall == pytest.approx(0.8)
    plain = occupancy_iou(est, truth, tolerance_cells=0)  # |7 common| / |13 union|
    assert plain.iou == pytest.approx(7.0 / 13.0, abs=1e-15)


def test_wall_shifted_three_cells_across() -> None:
    truth = grid(wall_map(slice(5, 15), row=10))
    est = grid(wall_map(slice(5, 15), row=13))
    score = occupancy_iou(est, truth, tolerance_cells=1)
    assert (score.iou, score.true_positives, score.false_positives, score.false_negatives) \
        == (0.0, 0, 10, 10)
    assert occupancy_iou(est, truth, tolerance_cells=3).iou == 1.0


def test_grids_with_other_resolution_and_origin_are_resampled() -> None:
    truth_v = room_world(2).to_occupancy_grid().data
    truth = grid(truth_v, origin=(-3.0, -3.0))
    fine = grid(np.repeat(np.repeat(truth_v, 2, axis=0), 2, axis=1), 0.025, (-3.0, -3.0))
    score = occupancy_iou(fine, truth)
    assert (score.iou, score.completeness) == (1.0, 1.0)
    padded = np.pad(truth_v, ((4, 0), (7, 0)), constant_values=-1)
    shifted = grid(padded, origin=(-3.0 - 7 * RES, -3.0 - 4 * RES))
    score = occupancy_iou(shifted, truth, tolerance_cells=0)
    assert (score.iou, score.completeness) == (1.0, 1.0)
    # a thin wall survives down-sampling to a coarser common grid
    coarse = occupancy_iou(truth, truth, resolution=0.1)
    assert coarse.iou == 1.0 and coarse.resolution == 0.1


def test_unobserved_walls_do_not_count_and_completeness_is_the_observed_free_fraction() -> None:
    v = np.zeros((20, 20), np.int8)
    v[0, :] = v[-1, :] = v[:, 0] = v[:, -1] = 100
    truth = grid(v)
    est_v = v.copy()
    est_v[10:] = -1  # the estimate never saw the upper half
    score = occupancy_iou(grid(est_v), truth, tolerance_cells=0)
    assert score.completeness == 0.5  # 9 of 18 interior rows
    assert score.iou == 1.0
    assert score.truth_cells == 18 + 2 * 9  # bottom face + lower halves of the sides


def test_walls_no_return_hit_do_not_count_with_observed_points() -> None:
    # a 1 m x 1 m room (cells 0..19) fully observed free by the estimate, but the
    # estimate lacks the right wall (the laser never reached it)
    v = np.zeros((20, 20), np.int8)
    v[0, :] = v[-1, :] = v[:, 0] = v[:, -1] = 100
    est_v = v.copy()
    est_v[1:-1, -1] = 0
    plain = occupancy_iou(grid(est_v), grid(v), tolerance_cells=0)
    assert plain.false_negatives == 18  # the right wall's inner face
    # returns only on the bottom, top and left walls (cell centres)
    xs = (np.arange(1, 19) + 0.5) * RES
    pts = np.vstack([np.column_stack([xs, np.full(18, 0.5 * RES)]),
                     np.column_stack([xs, np.full(18, 19.5 * RES)]),
                     np.column_stack([np.full(18, 0.5 * RES), xs])])
    seen = occupancy_iou(grid(est_v), grid(v), tolerance_cells=0, observed_points=pts)
    # the right wall's face is more than one cell from every return except next to the
    # bottom and top walls' returns at x = 18.5 cells; the estimate's two corner cells
    # beside its missing wall are its surface but no true face (false positives either way)
    assert seen.false_negatives == 2
    assert seen.false_positives == plain.false_positives == 2
    assert seen.truth_cells == plain.truth_cells - 16


def test_slam_style_thin_walls_match_thick_true_walls() -> None:
    world = room_world(3)
    world.occupied[60:64, 30:34] = False  # no pillar: the scan below sees the bare room
    truth = world.to_occupancy_grid()
    g = LogOddsGrid(RES, bounds=(-3.0, -3.0, 3.0, 3.0))
    ang = np.linspace(-math.pi, math.pi, 3600, endpoint=False)
    c, s = np.cos(ang), np.sin(ang)
    with np.errstate(divide="ignore"):
        r = np.minimum(np.abs((2.0 - 0.01 * np.sign(c)) / c),
                       np.abs((2.0 - 0.02 * np.sign(s)) / s)) + 0.01
    ends = np.stack((0.01 + r * c, 0.02 + r * s), axis=1)
    for _ in range(4):
        g.integrate_scan([0.01, 0.02], ends, np.ones(ang.size, bool))
    score = occupancy_iou(g.to_occupancy_grid(), truth, tolerance_cells=0)
    assert (score.iou, score.precision, score.recall) == (1.0, 1.0, 1.0)
    assert score.truth_cells == 4 * 80
    # free truth: the room's 80 x 80 interior plus the unseen space outside the 86 x 86 walls
    assert score.completeness == pytest.approx(6400 / (6400 + 120 * 120 - 86 * 86), abs=1e-15)


def test_map_comparison_errors_name_the_problem() -> None:
    truth = grid(wall_map(slice(5, 15)))
    with pytest.raises(MapComparisonError, match=r"estimated map origin has yaw 0\.1 rad"):
        occupancy_iou(grid(wall_map(slice(5, 15)), yaw=0.1), truth)
    far = grid(wall_map(slice(5, 15)), origin=(100.0, 0.0))
    with pytest.raises(MapComparisonError, match="maps do not overlap"):
        occupancy_iou(far, truth)
    with pytest.raises(MapComparisonError, match="truth map is empty"):
        occupancy_iou(truth, grid(np.zeros((0, 0))))


# --- trajectories ------------------------------------------------------------------------
def spiral(n: int = 50) -> np.ndarray:
    t = np.linspace(0.0, 3.0, n)
    return np.stack((t * np.cos(t), t * np.sin(t), t + 0.3), axis=1)


def test_ate_is_zero_after_alignment_and_the_offset_without() -> None:
    truth = spiral()
    moved = se2_compose(np.array([1.0, -2.0, 0.3]), truth)
    ate = absolute_trajectory_error(moved, truth)
    assert ate.rms_m < 1e-12 and ate.max_m < 1e-12 and ate.poses == 50
    # the alignment is the inverse of the applied transform
    inv = se2_compose(np.array([0.0, 0.0, -0.3]), np.array([-1.0, 2.0, 0.0]))
    np.testing.assert_allclose(ate.alignment, inv, atol=1e-12)
    shifted = truth + np.array([3.0, 4.0, 0.0])
    raw = absolute_trajectory_error(shifted, truth, align=False)
    assert raw.rms_m == pytest.approx(5.0, abs=1e-12)
    assert raw.mean_m == pytest.approx(5.0, abs=1e-12)
    assert raw.max_m == pytest.approx(5.0, abs=1e-12)
    assert raw.alignment == (0.0, 0.0, 0.0)


def test_ate_of_an_alternating_error_survives_alignment() -> None:
    truth = np.stack((np.arange(8.0), np.zeros(8), np.zeros(8)), axis=1)
    # zero mean and mirror-symmetric, so no rotation or shift can reduce it
    wiggle = 0.1 * np.array([1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0])
    est = truth + np.stack((np.zeros(8), wiggle, np.zeros(8)), axis=1)
    ate = absolute_trajectory_error(est, truth)
    assert ate.rms_m == pytest.approx(0.1, abs=1e-12)
    assert ate.max_m == pytest.approx(0.1, abs=1e-12)
    assert align_se2(est[:, :2], truth[:, :2]) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)


def integrate_steps(steps: np.ndarray) -> np.ndarray:
    poses = [np.zeros(3)]
    for step in steps:
        poses.append(se2_compose(poses[-1], step))
    return np.array(poses)


def test_rpe_constant_step_bias_gives_exact_translation_error() -> None:
    n = 40
    ref = integrate_steps(np.tile([0.1, 0.0, math.radians(5.0)], (n, 1)))
    est = integrate_steps(np.tile([0.11, 0.0, math.radians(5.0)], (n, 1)))
    rpe = relative_pose_error(est, ref)
    assert rpe.pairs == n
    assert rpe.trans_mean_m == pytest.approx(0.01, abs=1e-12)
    assert rpe.trans_std_m < 1e-12
    assert rpe.rot_mean_deg < 1e-9


def test_rpe_heading_error_of_one_degree_per_step() -> None:
    n = 30
    ref = integrate_steps(np.tile([0.1, 0.0, 0.0], (n, 1)))
    est = integrate_steps(np.tile([0.1, 0.0, math.radians(1.0)], (n, 1)))
    rpe = relative_pose_error(est, ref)
    assert rpe.rot_mean_deg == pytest.approx(1.0, abs=1e-9)
    assert rpe.rot_std_deg < 1e-9
    assert rpe.trans_mean_m < 1e-12
    two = relative_pose_error(est, ref, pairs=[[0, 2], [5, 7], [10, 12]])
    assert two.pairs == 3 and two.rot_mean_deg == pytest.approx(2.0, abs=1e-9)
    # over two steps the translation error is |(0.1 + 0.1 cos 1deg, 0.1 sin 1deg) - (0.2, 0)|
    expected = math.hypot(0.1 * math.cos(math.radians(1.0)) - 0.1, 0.1 * math.sin(
        math.radians(1.0)))
    assert two.trans_mean_m == pytest.approx(expected, abs=1e-12)


def test_trajectory_errors_name_the_problem() -> None:
    with pytest.raises(MapComparisonError, match=r"shapes \(5, 3\) and \(4, 3\)"):
        absolute_trajectory_error(np.zeros((5, 3)), np.zeros((4, 3)))
    with pytest.raises(MapComparisonError, match=r"pairs index poses 0\.\.9 but the "
                                                 r"trajectories have 5 poses"):
        relative_pose_error(np.zeros((5, 3)), np.zeros((5, 3)), pairs=[[0, 9]])
    with pytest.raises(MapComparisonError, match="at least 2 poses"):
        relative_pose_error(np.zeros((1, 3)), np.zeros((1, 3)))


# --- global consistency ------------------------------------------------------------------
def corridor_twice(offset: float) -> tuple[np.ndarray, np.ndarray]:
    """Down a 20 m corridor and back 0.5 m to the side; the estimate maps the way back
    ``offset`` metres further out (a doubled corridor)."""
    out = np.stack((np.arange(0.0, 20.0, 0.5), np.zeros(40), np.zeros(40)), axis=1)
    back = np.stack((np.arange(19.5, -0.5, -0.5), np.full(40, 0.5), np.full(40, math.pi)),
                    axis=1)
    ref = np.vstack((out, back))
    est = ref.copy()
    est[40:, 1] += offset
    return est, ref


def test_loop_relations_are_revisits_far_along_the_path() -> None:
    _, ref = corridor_twice(0.0)
    pairs = loop_relations(ref, max_distance=1.0, min_path=10.0)
    assert pairs.shape[1] == 2 and len(pairs) > 0
    gap = np.abs(ref[pairs[:, 0], 0] - ref[pairs[:, 1], 0])
    assert np.all(np.hypot(gap, 0.5) < 1.0)
    # scans of one pass less than 1 m apart are less than 10 m apart along the path:
    # every loop joins the way out (i < 40) with the way back (j >= 40)
    assert np.all(pairs[:, 0] < 40) and np.all(pairs[:, 1] >= 40)
    # at the far end the path between the two passes is only ~1 m: not a loop
    assert not np.any(ref[pairs[:, 0], 0] > 17.0)
    assert loop_relations(ref[:40]).shape == (0, 2)


def test_doubled_corridor_shows_in_loop_relations_not_in_consecutive_pairs() -> None:
    est, ref = corridor_twice(0.3)
    scores = trajectory_scores(est, ref)
    # one consecutive pair (39 -> 40) carries the whole offset
    assert scores.rpe[1].trans_mean_m == pytest.approx(0.3 / 79, abs=1e-12)
    assert scores.loops is not None
    assert scores.loops.trans_mean_m == pytest.approx(0.3, abs=1e-12)
    assert scores.loops.trans_max_m == pytest.approx(0.3, abs=1e-12)
    assert scores.loops.rot_mean_deg == pytest.approx(0.0, abs=1e-9)
    assert sorted(scores.rpe) == [1, 10]  # 80 poses: no separation of 100
    # the aligned ATE splits the offset between the two passes
    assert scores.ate.rms_m == pytest.approx(0.15, abs=1e-9)
    exact = trajectory_scores(ref, ref)
    assert exact.loops is not None and exact.loops.trans_mean_m < 1e-12
    assert exact.ate.rms_m < 1e-12


def test_loop_relation_error_is_none_without_revisits_and_inputs_are_checked() -> None:
    line = np.stack((np.arange(30.0), np.zeros(30), np.zeros(30)), axis=1)
    assert loop_relation_error(line, line) is None
    with pytest.raises(MapComparisonError, match="max_distance must be > 0"):
        loop_relations(line, max_distance=0.0)
    with pytest.raises(MapComparisonError, match="separations must be >= 1"):
        trajectory_scores(line, line, separations=(0,))
