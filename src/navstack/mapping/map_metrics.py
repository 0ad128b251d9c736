"""Scores for SLAM output: map agreement with the true world, and trajectory errors.

* :func:`occupancy_iou` compares an estimated occupancy grid with the true one on their
  *observable wall surface* (defined there), with a cell tolerance, and reports IoU,
  precision, recall and how much of the true free space the estimate covers.
* :func:`absolute_trajectory_error`: RMS position error after the least-squares SE(2)
  alignment (Horn 1987 / Umeyama 1991, restricted to 2-D rotation + translation).
* :func:`relative_pose_error`: the relative-motion metric of Kümmerle et al., "On
  measuring the accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009.

All inputs are plain numpy arrays or :class:`~navstack.core.msgs.OccupancyGrid`
messages; nothing here touches a bus or a file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import binary_dilation

from navstack.core.errors import NavstackError
from navstack.core.geometry import se2_between
from navstack.core.map_files import DEFAULT_FREE_THRESH, DEFAULT_OCCUPIED_THRESH
from navstack.core.msgs import OccupancyGrid

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
_UNKNOWN, _FREE, _OCCUPIED = 0, 1, 2
_EPS_CELLS = 1e-6  # world coordinates this close to a cell border count as on it


class MapComparisonError(NavstackError, ValueError):
    """Two maps or trajectories cannot be compared as given."""


@dataclass(frozen=True, slots=True)
class MapScore:
    """Result of :func:`occupancy_iou` (cell counts on the common grid)."""

    iou: float
    precision: float
    recall: float
    completeness: float
    true_positives: int
    """Estimate surface cells within the tolerance of a truth surface cell."""
    false_positives: int
    """Estimate surface cells farther than the tolerance from every truth surface cell."""
    false_negatives: int
    """Truth surface cells with no estimate surface cell within the tolerance."""
    estimate_cells: int
    truth_cells: int
    resolution: float
    tolerance_cells: int


@dataclass(frozen=True, slots=True)
class AbsoluteTrajectoryError:
    """Position error [m] of each pose after alignment; ``alignment`` is the SE(2)
    transform (x, y, theta) applied to the estimate (zeros when not aligned)."""

    rms_m: float
    mean_m: float
    max_m: float
    poses: int
    alignment: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class RelativePoseError:
    """Kümmerle et al. 2009 relative error statistics (population std, ddof 0)."""

    trans_mean_m: float
    trans_std_m: float
    rot_mean_deg: float
    rot_std_deg: float
    pairs: int


# --- maps ------------------------------------------------------------------------------
def _classify(grid: OccupancyGrid, occupied_thresh: float,
              free_thresh: float) -> NDArray[np.int8]:
    """UNKNOWN / FREE / OCCUPIED per cell, map_saver thresholds on 0..100 values."""
    v = np.asarray(grid.data).astype(np.int16)
    out = np.full(v.shape, _UNKNOWN, dtype=np.int8)
    known = (v >= 0) & (v <= 100)
    out[known & (v <= round(100 * free_thresh))] = _FREE
    out[known & (v >= round(100 * occupied_thresh))] = _OCCUPIED
    return out


def _grid_extent(grid: OccupancyGrid, name: str) -> tuple[float, float, float, float]:
    o = grid.info.origin.to_pose2d()
    if abs(o.theta) > 1e-9:
        raise MapComparisonError(f"{name} map origin has yaw {o.theta:.6g} rad; only "
                                 "axis-aligned grids (origin yaw 0) can be compared -- rotate "
                                 "the map image and set yaw 0")
    data = np.asarray(grid.data)
    if data.ndim != 2 or data.size == 0 or not grid.info.resolution > 0.0:
        raise MapComparisonError(f"{name} map is empty (data shape {data.shape}, resolution "
                                 f"{grid.info.resolution}); pass a non-empty grid")
    res = grid.info.resolution
    return o.x, o.y, o.x + data.shape[1] * res, o.y + data.shape[0] * res


def _hit_cells(points: ArrayLike, anchor: tuple[float, float], col0: int, row0: int,
               shape: tuple[int, int], resolution: float, dilate: int) -> NDArray[np.bool_]:
    """Cells of the common lattice within ``dilate`` cells of one of ``points``."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    cols = np.floor((pts[:, 0] - anchor[0]) / resolution).astype(np.int64) - col0
    rows = np.floor((pts[:, 1] - anchor[1]) / resolution).astype(np.int64) - row0
    inside = (cols >= 0) & (cols < shape[1]) & (rows >= 0) & (rows < shape[0])
    hit = np.zeros(shape, dtype=bool)
    hit[rows[inside], cols[inside]] = True
    return binary_dilation(hit, np.ones((2 * dilate + 1,) * 2, dtype=bool))


def _resample(classes: NDArray[np.int8], grid: OccupancyGrid, anchor: tuple[float, float],
              col0: int, row0: int, shape: tuple[int, int], res: float) -> NDArray[np.int8]:
    """Splat source cells onto the common grid: lattice cells ``[anchor + i*res, ...)``,
    common cell (0, 0) at lattice index (row0, col0).

    A common cell takes the highest class of the source cells overlapping it (occupied >
    free > unknown), so thin walls survive down-sampling.
    """
    out = np.full(shape, _UNKNOWN, dtype=np.int8)
    o = grid.info.origin.to_pose2d()
    src_res = grid.info.resolution
    for cls in (_FREE, _OCCUPIED):
        rows, cols = np.nonzero(classes == cls)
        if rows.size == 0:
            continue
        spans = []
        for idx, org, first in ((cols, o.x - anchor[0], col0), (rows, o.y - anchor[1], row0)):
            lo = np.floor((org + idx * src_res) / res + _EPS_CELLS).astype(np.int64) - first
            hi = np.ceil((org + (idx + 1) * src_res) / res - _EPS_CELLS).astype(np.int64) \
                - 1 - first
            spans.append((lo, np.maximum(hi - lo + 1, 1)))
        (cx, nx), (cy, ny) = spans
        for i in range(int(nx.max())):  # loops over the few offsets of one source cell
            for j in range(int(ny.max())):
                m = (i < nx) & (j < ny)
                out[cy[m] + j, cx[m] + i] = cls
    return out


def _has_4_neighbour(mask: BoolArray) -> BoolArray:
    """True where at least one 4-neighbour (inside the grid) is true."""
    out = np.zeros_like(mask)
    out[1:, :] |= mask[:-1, :]
    out[:-1, :] |= mask[1:, :]
    out[:, 1:] |= mask[:, :-1]
    out[:, :-1] |= mask[:, 1:]
    return out


def occupancy_iou(estimated: OccupancyGrid, truth: OccupancyGrid, resolution: float = 0.05,
                  tolerance_cells: int = 1, *,
                  occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
                  free_thresh: float = DEFAULT_FREE_THRESH,
                  observed_points: ArrayLike | None = None) -> MapScore:
    """Agreement of an estimated map with the true one on the observable wall surface.

    Both grids (any origins and resolutions, origin yaw 0) are resampled onto a common
    axis-aligned grid covering both, with ``resolution`` cells on the truth's lattice
    (cell borders at ``truth origin + i * resolution``); a common cell is occupied if any
    source cell overlapping it is, else free if any is, else unknown.  Cell values use
    map_saver thresholds: ``v >= rint(100 * occupied_thresh)`` occupied, ``0 <= v <=
    rint(100 * free_thresh)`` free, else unknown.

    A laser sees only the surface of a wall, and a true-world raster has walls of some
    thickness, so both maps are reduced to their observable surface:

    * truth surface T: occupied truth cells with a 4-neighbour that is free in the truth
      *and known* (free or occupied) in the estimate -- wall faces next to space the
      estimate has observed;
    * estimate surface E: occupied estimate cells with a 4-neighbour free in the estimate.

    With ``observed_points`` (``(N, 2)`` laser returns drawn at the *true* poses of the
    route, in the truth's frame) T keeps only the wall cells within ``max(1,
    tolerance_cells)`` cells of a return: the walls the route's laser actually hit.  A
    wall face next to observed free space can still be one no beam reached -- grazed at
    a shallow angle, or beyond the laser's range at the end of a beam that found
    nothing -- and no map, however exact its poses, has it.

    With ``d`` the Chebyshev distance in cells and ``k = tolerance_cells``:
    TP = #{e in E: d(e, T) <= k}, FP = #E - TP, FN = #{t in T: d(t, E) > k};
    ``iou = TP / (TP + FP + FN)``, ``precision = TP / #E`` (0 if E is empty), ``recall =
    (#T - FN) / #T``.  With ``k = 0`` this is the plain IoU of the two surfaces, and a
    map compared with itself scores 1.  ``completeness`` = fraction of free truth cells
    that are known in the estimate (count only the reachable space in the truth, or it
    cannot reach 1).

    Raises :class:`MapComparisonError` for rotated or empty grids and when T is empty
    (the estimate observed no true wall: the maps do not overlap, check the frames).
    """
    if not resolution > 0.0:
        raise MapComparisonError(f"resolution must be positive, got {resolution}")
    if tolerance_cells < 0:
        raise MapComparisonError(f"tolerance_cells must be >= 0, got {tolerance_cells}")
    ext_e = _grid_extent(estimated, "estimated")
    ext_t = _grid_extent(truth, "truth")
    ax, ay = ext_t[0], ext_t[1]
    col0 = math.floor((min(ext_e[0], ext_t[0]) - ax) / resolution + _EPS_CELLS)
    row0 = math.floor((min(ext_e[1], ext_t[1]) - ay) / resolution + _EPS_CELLS)
    col1 = math.ceil((max(ext_e[2], ext_t[2]) - ax) / resolution - _EPS_CELLS)
    row1 = math.ceil((max(ext_e[3], ext_t[3]) - ay) / resolution - _EPS_CELLS)
    shape = (row1 - row0, col1 - col0)
    est = _resample(_classify(estimated, occupied_thresh, free_thresh), estimated, (ax, ay),
                    col0, row0, shape, resolution)
    tru = _resample(_classify(truth, occupied_thresh, free_thresh), truth, (ax, ay), col0,
                    row0, shape, resolution)
    free_t = tru == _FREE
    known_e = est != _UNKNOWN
    truth_surface = (tru == _OCCUPIED) & _has_4_neighbour(free_t & known_e)
    if observed_points is not None:
        truth_surface &= _hit_cells(observed_points, (ax, ay), col0, row0, shape, resolution,
                                    max(1, tolerance_cells))
    est_surface = (est == _OCCUPIED) & _has_4_neighbour(est == _FREE)
    n_truth = int(truth_surface.sum())
    if n_truth == 0:
        raise MapComparisonError(
            "no true wall borders space the estimate observed (empty truth surface); the "
            "maps do not overlap -- check that both are in the same frame and origin")
    n_est = int(est_surface.sum())
    if tolerance_cells > 0:
        box = np.ones((2 * tolerance_cells + 1,) * 2, dtype=bool)
        near_truth = binary_dilation(truth_surface, box)
        near_est = binary_dilation(est_surface, box)
    else:
        near_truth, near_est = truth_surface, est_surface
    tp = int((est_surface & near_truth).sum())
    fn = n_truth - int((truth_surface & near_est).sum())
    fp = n_est - tp
    n_free = int(free_t.sum())
    return MapScore(
        iou=tp / (tp + fp + fn) if tp + fp + fn else 0.0,
        precision=tp / n_est if n_est else 0.0,
        recall=(n_truth - fn) / n_truth,
        completeness=int((free_t & known_e).sum()) / n_free if n_free else 0.0,
        true_positives=tp, false_positives=fp, false_negatives=fn, estimate_cells=n_est,
        truth_cells=n_truth, resolution=float(resolution), tolerance_cells=int(tolerance_cells))


# --- trajectories ----------------------------------------------------------------------
def _trajectories(estimate: ArrayLike, truth: ArrayLike,
                  what: str) -> tuple[FloatArray, FloatArray]:
    est = np.asarray(estimate, dtype=np.float64)
    ref = np.asarray(truth, dtype=np.float64)
    if est.ndim != 2 or est.shape[1] != 3 or est.shape != ref.shape or est.shape[0] == 0:
        raise MapComparisonError(f"{what} needs two (N, 3) arrays of (x, y, theta) poses with "
                                 f"the same N >= 1, got shapes {est.shape} and {ref.shape}; "
                                 "associate the poses by time first")
    if not (np.isfinite(est).all() and np.isfinite(ref).all()):
        raise MapComparisonError(f"{what}: poses contain NaN or inf")
    return est, ref


def align_se2(source_xy: ArrayLike, target_xy: ArrayLike) -> tuple[float, float, float]:
    """SE(2) transform ``(x, y, theta)`` minimising ``sum |R p_i + t - q_i|^2``.

    Closed form (Horn 1987 / Umeyama 1991 without scale): with centred points ``a_i``,
    ``b_i``, ``theta = atan2(sum a_i x b_i, sum a_i . b_i)`` and ``t = mean(q) -
    R mean(p)``.
    """
    p = np.asarray(source_xy, dtype=np.float64).reshape(-1, 2)
    q = np.asarray(target_xy, dtype=np.float64).reshape(-1, 2)
    mp, mq = p.mean(axis=0), q.mean(axis=0)
    a, b = p - mp, q - mq
    theta = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])),
                       float(np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])))
    c, s = math.cos(theta), math.sin(theta)
    return (float(mq[0] - (c * mp[0] - s * mp[1])), float(mq[1] - (s * mp[0] + c * mp[1])),
            theta)


def absolute_trajectory_error(estimate: ArrayLike, truth: ArrayLike,
                              align: bool = True) -> AbsoluteTrajectoryError:
    """Translational error of each estimated pose against the true pose with the same
    index, after the least-squares SE(2) alignment of the estimate when ``align``
    (:func:`align_se2`; no scale, a 2-D SLAM map has metric scale)."""
    est, ref = _trajectories(estimate, truth, "absolute_trajectory_error")
    transform = align_se2(est[:, :2], ref[:, :2]) if align else (0.0, 0.0, 0.0)
    c, s = math.cos(transform[2]), math.sin(transform[2])
    x = c * est[:, 0] - s * est[:, 1] + transform[0]
    y = s * est[:, 0] + c * est[:, 1] + transform[1]
    err = np.hypot(x - ref[:, 0], y - ref[:, 1])
    return AbsoluteTrajectoryError(rms_m=float(np.sqrt(np.mean(err * err))),
                                   mean_m=float(err.mean()), max_m=float(err.max()),
                                   poses=int(err.size), alignment=transform)


def relative_pose_error(estimate: ArrayLike, reference: ArrayLike,
                        pairs: ArrayLike | None = None) -> RelativePoseError:
    """Kümmerle et al. (2009) relative pose error.

    For each pair (i, j) -- by default the consecutive pairs (k, k+1) --
    ``delta_est = est_i^-1 * est_j``, ``delta_ref = ref_i^-1 * ref_j`` and the error is
    ``delta_ref^-1 * delta_est``.  Reports the mean and population standard deviation of
    its translation norm [m] and of its absolute rotation [deg], as in the paper's
    tables.  No global alignment is needed: relative motions are frame independent.
    """
    est, ref = _trajectories(estimate, reference, "relative_pose_error")
    n = est.shape[0]
    if pairs is None:
        if n < 2:
            raise MapComparisonError("relative_pose_error needs at least 2 poses for the "
                                     "default consecutive pairs")
        idx = np.stack((np.arange(n - 1), np.arange(1, n)), axis=1)
    else:
        idx = np.asarray(pairs)
        if (idx.ndim != 2 or idx.shape[1] != 2 or idx.shape[0] == 0
                or not np.issubdtype(idx.dtype, np.integer)):
            raise MapComparisonError(f"pairs must be a non-empty (M, 2) integer array of pose "
                                     f"indices, got shape {idx.shape} dtype {idx.dtype}")
        if idx.min() < 0 or idx.max() >= n:
            raise MapComparisonError(f"pairs index poses {int(idx.min())}..{int(idx.max())} "
                                     f"but the trajectories have {n} poses (0..{n - 1})")
    delta_est = se2_between(est[idx[:, 0]], est[idx[:, 1]])
    delta_ref = se2_between(ref[idx[:, 0]], ref[idx[:, 1]])
    err = se2_between(delta_ref, delta_est)
    trans = np.hypot(err[:, 0], err[:, 1])
    rot = np.degrees(np.abs(err[:, 2]))
    return RelativePoseError(trans_mean_m=float(trans.mean()), trans_std_m=float(trans.std()),
                             rot_mean_deg=float(rot.mean()), rot_std_deg=float(rot.std()),
                             pairs=int(trans.size))


# --- global consistency ----------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class LoopRelationError:
    """Relative pose error over the *loop relations* of :func:`loop_relations` (pairs of
    scans close in space but far apart along the path): ``trans_mean_m`` / ``rot_mean_deg``
    as in :class:`RelativePoseError`, plus the worst pair and the pair count."""

    trans_mean_m: float
    trans_max_m: float
    rot_mean_deg: float
    pairs: int


@dataclass(frozen=True, slots=True)
class TrajectoryScores:
    """Everything :func:`trajectory_scores` measures of one estimated trajectory.

    ``rpe`` maps a separation ``d`` (in poses) to the relative pose error over the pairs
    ``(k, k + d)`` (separations longer than the trajectory are left out); ``loops`` is
    ``None`` when the reference never comes back to a place it left."""

    ate: AbsoluteTrajectoryError
    rpe: dict[int, RelativePoseError]
    loops: LoopRelationError | None


#: separations [poses] of :func:`trajectory_scores`' RPE: consecutive, 10 and 100 nodes
RPE_SEPARATIONS = (1, 10, 100)


def loop_relations(reference: ArrayLike, max_distance: float = 1.0,
                   min_path: float = 10.0) -> NDArray[np.int64]:
    """Pairs ``(i, j)``, ``i < j``, of reference poses less than ``max_distance`` [m] apart
    whose reference path between them is at least ``min_path`` [m] long: the places the
    robot came back to.  Their relative pose error is what a consecutive-pair metric cannot
    see -- a corridor mapped twice side by side has small consecutive errors and a loop
    relation error of the offset between the two copies.  Returns ``(M, 2)`` (M may be 0)."""
    ref = np.asarray(reference, dtype=np.float64)
    if ref.ndim != 2 or ref.shape[1] < 2 or ref.shape[0] == 0:
        raise MapComparisonError(f"loop_relations needs an (N, 3) reference, got shape "
                                 f"{ref.shape}")
    if not (max_distance > 0.0 and min_path >= 0.0):
        raise MapComparisonError(f"max_distance must be > 0 and min_path >= 0, got "
                                 f"{max_distance} and {min_path}")
    from scipy.spatial import cKDTree

    pairs = cKDTree(ref[:, :2]).query_pairs(max_distance, output_type="ndarray")
    if pairs.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = np.sort(pairs.astype(np.int64), axis=1)
    along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(ref[:, :2], axis=0).T))))
    far = along[pairs[:, 1]] - along[pairs[:, 0]] >= min_path
    out = pairs[far]
    return out[np.lexsort((out[:, 1], out[:, 0]))]


def loop_relation_error(estimate: ArrayLike, reference: ArrayLike, max_distance: float = 1.0,
                        min_path: float = 10.0) -> LoopRelationError | None:
    """Relative pose error (:func:`relative_pose_error`'s definition) over the
    :func:`loop_relations` of the reference; ``None`` when there are none."""
    est, ref = _trajectories(estimate, reference, "loop_relation_error")
    pairs = loop_relations(ref, max_distance, min_path)
    if pairs.shape[0] == 0:
        return None
    err = se2_between(se2_between(ref[pairs[:, 0]], ref[pairs[:, 1]]),
                      se2_between(est[pairs[:, 0]], est[pairs[:, 1]]))
    trans = np.hypot(err[:, 0], err[:, 1])
    return LoopRelationError(trans_mean_m=float(trans.mean()), trans_max_m=float(trans.max()),
                             rot_mean_deg=float(np.degrees(np.abs(err[:, 2])).mean()),
                             pairs=int(trans.size))


def trajectory_scores(estimate: ArrayLike, reference: ArrayLike,
                      separations: tuple[int, ...] = RPE_SEPARATIONS,
                      loop_distance: float = 1.0, loop_min_path: float = 10.0
                      ) -> TrajectoryScores:
    """Global and local error of a trajectory against its reference: aligned ATE
    (:func:`absolute_trajectory_error`), RPE at each separation that fits, and the loop
    relation error (:func:`loop_relation_error`)."""
    est, ref = _trajectories(estimate, reference, "trajectory_scores")
    n = est.shape[0]
    rpe = {}
    for d in separations:
        if d < 1:
            raise MapComparisonError(f"RPE separations must be >= 1 pose, got {d}")
        if d < n:
            k = np.arange(n - d)
            rpe[d] = relative_pose_error(est, ref, np.stack((k, k + d), axis=1))
    return TrajectoryScores(ate=absolute_trajectory_error(est, ref), rpe=rpe,
                            loops=loop_relation_error(est, ref, loop_distance, loop_min_path))
