"""Wide-window correlative matching by branch and bound on precomputed grids.

W. Hess, D. Kohler, H. Rapp, D. Andor, "Real-Time Loop Closure in 2D LIDAR SLAM", ICRA
2016, section V (Cartographer's ``FastCorrelativeScanMatcher2D``): the likelihood grid of
a map is turned into a stack of *precomputation grids*; level ``d`` holds, at every cell,
the maximum of the likelihood over the ``2^d x 2^d`` cells above and to the right of it.
Summing level ``d`` under the query points bounds the score of all ``2^d x 2^d``
translations of a block at once, so a depth-first search that expands the best block
first and prunes every block whose bound cannot beat the best leaf found so far is exact
-- it returns the optimum of an exhaustive search over the window -- while touching a
tiny part of it.  Windows of metres and the full circle of angles (loop closure after
long drift, a scan whose odometry is missing) cost milliseconds.

Values are stored as ``uint8`` (likelihood * 255, rounded); a level's maximum is taken
over the stored level-0 values, so the bounds stay exact for the quantised score.  The
score is the mean likelihood under the points (0..1, the *response* slam_toolbox
compares with its ``*_minimum_response_*`` parameters), optionally weighted by Karto's
angle and distance penalties (both <= 1, so they only ever lower a leaf below its bound).

Angles are searched on a grid whose step moves the 95th-percentile point by about one
cell (Hess et al. take the farthest point); the winner is meant to be refined by a local
matcher (:mod:`navstack.mapping.scan_matcher`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.mapping.scan_matcher import (
    offset_moments,
    smeared_grid,
    sum_under,
    surface_covariance_matrix,
)

FloatArray = NDArray[np.float64]

__all__ = ["Exclusion", "PrecomputedGrids", "WideMatch", "WideWindow", "angle_step",
           "surface_covariance", "voxel_filter", "wide_match"]


class PrecomputedGrids:
    """The precomputation stack of a likelihood grid (see the module docstring).

    ``origin`` is the world position (in the frame the points were given in) of level-0
    cell (0, 0)'s centre, before padding; ``depth`` levels above level 0 are kept."""

    def __init__(self, points: FloatArray, resolution: float, smear_deviation: float,
                 depth: int = 6, margin: float = 0.0) -> None:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if pts.shape[0] == 0:
            raise ValueError("PrecomputedGrids needs at least one point")
        self.resolution = float(resolution)
        self.depth = int(depth)
        lo = pts.min(axis=0) - margin - 3 * smear_deviation
        hi = pts.max(axis=0) + margin + 3 * smear_deviation
        fine, origin = smeared_grid(pts, resolution, smear_deviation,
                                    (lo[0], lo[1], hi[0], hi[1]))
        self.pad = (1 << self.depth) - 1
        span = 1 << self.depth
        level0 = np.zeros((fine.shape[0] + self.pad + span, fine.shape[1] + self.pad + span),
                          np.uint8)
        level0[self.pad:self.pad + fine.shape[0], self.pad:self.pad + fine.shape[1]] = \
            np.rint(fine * 255.0).astype(np.uint8)
        self.origin = origin
        self.levels = _max_pyramid(level0, self.depth)

    @property
    def nbytes(self) -> int:
        return int(self.levels.nbytes)

    def cells(self, points: FloatArray) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
        """Padded ``(rows, cols)`` of the cells holding ``points`` (..., 2)."""
        idx = np.rint((points - self.origin) / self.resolution).astype(np.int64) + self.pad
        return idx[..., 1].astype(np.int32), idx[..., 0].astype(np.int32)


def _max_pyramid(level0: NDArray[np.uint8], depth: int) -> NDArray[np.uint8]:
    """``(depth + 1, H, W)``: level ``d`` = max of level 0 over ``[r, r + 2^d) x
    [c, c + 2^d)`` (zero beyond the grid), built by doubling: each level is the max of
    the previous one and its copies shifted by half the new block."""
    levels = np.zeros((depth + 1, *level0.shape), np.uint8)
    levels[0] = level0
    for d in range(1, depth + 1):
        half = 1 << (d - 1)
        prev = levels[d - 1]
        cur = prev.copy()
        np.maximum(cur[:-half, :], prev[half:, :], out=cur[:-half, :])
        out = cur.copy()
        np.maximum(out[:, :-half], cur[:, half:], out=out[:, :-half])
        levels[d] = out
    return levels


@dataclass(frozen=True)
class WideWindow:
    """Search window around a pose: ``half_x`` / ``half_y`` [m] (axes of the grid's
    frame), ``half_angle`` [rad] (>= pi: the full circle) and the angular step [rad]
    (0: chosen from the points, module docstring)."""

    half_x: float
    half_y: float
    half_angle: float
    angle_step: float = 0.0


@dataclass(frozen=True)
class Exclusion:
    """Leaves a search may not return: within ``half_across`` [m] of the line through
    ``center`` (x, y) along ``direction`` (unit x, y), within ``half_along`` [m] of
    ``center`` along it, and within ``half_angle`` [rad] of ``angle``.  A square around a
    pose is ``direction=(1, 0)`` with equal halves; a corridor strip a long
    ``half_along``."""

    center: tuple[float, float]
    direction: tuple[float, float]
    half_along: float
    half_across: float
    angle: float
    half_angle: float


@dataclass(frozen=True)
class WideMatch:
    """Best pose found (grid frame), its score (penalised mean likelihood, 0..1) and the
    number of leaves the search evaluated."""

    pose: FloatArray
    score: float
    leaves: int


def voxel_filter(points: FloatArray, size: float) -> FloatArray:
    """One point per ``size`` cell (the first in scan order): near returns are dense and
    would otherwise dominate the score and the cost."""
    if points.shape[0] == 0:
        return points
    keys = np.floor(points / size).astype(np.int64)
    _, first = np.unique(keys[:, 0] * 1_000_003 + keys[:, 1], return_index=True)
    return points[np.sort(first)]


def angle_step(points: FloatArray, resolution: float) -> float:
    """Angular step [rad] that moves the 95th-percentile point by one ``resolution``."""
    r = np.hypot(points[:, 0], points[:, 1])
    k = min(r.size - 1, int(0.95 * r.size))
    reach = float(np.partition(r, k)[k]) if r.size else resolution
    return max(resolution / max(reach, resolution), 1e-3)


def wide_match(grids: PrecomputedGrids, points: FloatArray, center: FloatArray,
               window: WideWindow, *, min_score: float = 0.0,
               angle_penalty: tuple[float, float] = (math.inf, 0.0),
               distance_penalty: tuple[float, float] = (math.inf, 0.0),
               exclusion: Exclusion | None = None) -> WideMatch | None:
    """Best pose of ``points`` (N, 2, robot frame) in the grid's frame within ``window``
    of ``center`` (x, y, theta), or ``None`` if no pose scores at least ``min_score``.

    ``angle_penalty`` / ``distance_penalty`` are Karto's ``(variance, minimum)`` pairs:
    the score is multiplied by ``max(1 - 0.2 d^2 / variance, minimum)`` of the angle and
    distance from ``center`` (``inf`` variance: no penalty)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if pts.shape[0] == 0:
        return None
    center = np.asarray(center, dtype=np.float64)
    res = grids.resolution
    step = window.angle_step or angle_step(pts, res)
    if window.half_angle >= math.pi:
        count = max(1, math.ceil(2 * math.pi / step))
        offsets = np.arange(count, dtype=np.float64) * (2 * math.pi / count) - math.pi
    else:
        n = math.ceil(window.half_angle / step)
        offsets = np.arange(-n, n + 1, dtype=np.float64) * step
    angles = center[2] + offsets
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    world = np.stack((c * pts[:, 0] - s * pts[:, 1] + center[0],
                      s * pts[:, 0] + c * pts[:, 1] + center[1]), axis=-1)
    rows, cols = grids.cells(world)
    var_a, min_a = angle_penalty
    pen: FloatArray = (np.ones(angles.size) if math.isinf(var_a)
                       else np.maximum(1.0 - 0.2 * offsets * offsets / var_a, min_a))
    ex = np.full(8, -1.0)
    if exclusion is not None:
        ex[:] = ((exclusion.center[0] - center[0]) / res, (exclusion.center[1] - center[1]) / res,
                 exclusion.direction[0], exclusion.direction[1], exclusion.half_along / res,
                 exclusion.half_across / res, exclusion.angle - center[2], exclusion.half_angle)
    var_d, min_d = distance_penalty
    half_c = max(0, math.ceil(window.half_x / res))
    half_r = max(0, math.ceil(window.half_y / res))
    floor = min_score * 255.0 * pts.shape[0]
    a, dr, dc, raw, leaves = _search(grids.levels, rows, cols, pen, offsets, half_r, half_c,
                                     res, var_d if math.isfinite(var_d) else -1.0, min_d,
                                     exclusion is not None, ex, floor)
    if a < 0:
        return None
    pose = np.array([center[0] + dc * res, center[1] + dr * res,
                     math.remainder(float(angles[a]), 2 * math.pi)])
    return WideMatch(pose, raw / (255.0 * pts.shape[0]), leaves)


@numba.njit(cache=True)
def _excluded(ex: NDArray[np.float64], offset: float, dr: int, dc: int) -> bool:
    dx = dc - ex[0]
    dy = dr - ex[1]
    along = dx * ex[2] + dy * ex[3]
    across = -dx * ex[3] + dy * ex[2]
    dth = math.atan2(math.sin(offset - ex[6]), math.cos(offset - ex[6]))
    return abs(along) <= ex[4] and abs(across) <= ex[5] and abs(dth) <= ex[7]


@numba.njit(cache=True)
def _search(levels: NDArray[np.uint8], rows: NDArray[np.int32], cols: NDArray[np.int32],
            penalty: NDArray[np.float64], offsets: NDArray[np.float64], half_r: int,
            half_c: int, res: float, dist_var: float, dist_min: float, use_ex: bool,
            ex: NDArray[np.float64], floor: float) -> tuple[int, int, int, float, int]:
    """Depth-first branch and bound; returns (angle index, row and col offsets, raw
    score, leaves evaluated), angle index -1 when nothing reaches ``floor``."""
    depth = levels.shape[0] - 1
    span = 1 << depth
    n_r = (2 * half_r) // span + 1
    n_c = (2 * half_c) // span + 1
    n_a = rows.shape[0]
    top = n_a * n_r * n_c
    scores = np.empty(top)
    for a in range(n_a):
        for i in range(n_r):
            for j in range(n_c):
                s = sum_under(levels[depth], rows[a], cols[a], -half_r + i * span,
                               -half_c + j * span)
                scores[(a * n_r + i) * n_c + j] = s * penalty[a]
    order = np.argsort(-scores)
    best = floor
    best_a = -1
    best_r = 0
    best_c = 0
    leaves = 0
    cap = 4 * (depth + 1) + 4
    st_l = np.empty(cap, np.int64)
    st_a = np.empty(cap, np.int64)
    st_r = np.empty(cap, np.int64)
    st_c = np.empty(cap, np.int64)
    st_s = np.empty(cap)
    ch_s = np.empty(4)
    ch_r = np.empty(4, np.int64)
    ch_c = np.empty(4, np.int64)
    for k in range(top):
        idx = order[k]
        if scores[idx] < best or (best_a >= 0 and scores[idx] == best):
            break
        a0 = idx // (n_r * n_c)
        sp = 0
        st_l[0] = depth
        st_a[0] = a0
        st_r[0] = -half_r + ((idx // n_c) % n_r) * span
        st_c[0] = -half_c + (idx % n_c) * span
        st_s[0] = scores[idx]
        sp = 1
        while sp > 0:
            sp -= 1
            lv = st_l[sp]
            a = st_a[sp]
            r0 = st_r[sp]
            c0 = st_c[sp]
            if st_s[sp] < best or (best_a >= 0 and st_s[sp] == best):
                continue
            if lv == 0:
                leaves += 1
                s = st_s[sp]
                if use_ex and _excluded(ex, offsets[a], r0, c0):
                    continue
                if dist_var > 0.0:
                    d2 = (r0 * r0 + c0 * c0) * res * res
                    pen = 1.0 - 0.2 * d2 / dist_var
                    s *= pen if pen > dist_min else dist_min
                if s > best or (best_a < 0 and s >= best):
                    best = s
                    best_a = a
                    best_r = r0
                    best_c = c0
                continue
            h = 1 << (lv - 1)
            m = 0
            for q in range(4):
                rr = r0 + (q // 2) * h
                cc = c0 + (q % 2) * h
                if rr > half_r or cc > half_c:
                    continue
                ch_r[m] = rr
                ch_c[m] = cc
                ch_s[m] = sum_under(levels[lv - 1], rows[a], cols[a], rr, cc) * penalty[a]
                m += 1
            # push worst first so that the best child is expanded next
            for _ in range(m):
                worst = 0
                for q in range(1, m):
                    if ch_s[q] < ch_s[worst]:
                        worst = q
                if ch_s[worst] >= best:
                    st_l[sp] = lv - 1
                    st_a[sp] = a
                    st_r[sp] = ch_r[worst]
                    st_c[sp] = ch_c[worst]
                    st_s[sp] = ch_s[worst]
                    sp += 1
                ch_s[worst] = np.inf
    return best_a, best_r, best_c, best, leaves


def surface_covariance(grids: PrecomputedGrids, points: FloatArray, pose: FloatArray,
                       half: float, half_angle: float, drop: float = 0.1
                       ) -> tuple[FloatArray, float]:
    """Response-surface covariance of ``points`` at ``pose`` on the level-0 grid (as
    :func:`navstack.mapping.scan_matcher.response_covariance`: every translation within
    ``half`` [m] and angle within ``half_angle`` whose response is within ``drop`` of the
    best counts, weighted by its response) and the response at ``pose``."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    res = grids.resolution
    step = angle_step(pts, res)
    n = max(1, math.ceil(half_angle / step))
    offsets = np.arange(-n, n + 1, dtype=np.float64) * step
    angles = pose[2] + offsets
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    world = np.stack((c * pts[:, 0] - s * pts[:, 1] + pose[0],
                      s * pts[:, 0] + c * pts[:, 1] + pose[1]), axis=-1)
    rows, cols = grids.cells(world)
    half_cells = max(1, math.ceil(half / res))
    drop_abs = drop * 255.0 * pts.shape[0]
    scores = _level_scores(grids.levels[0], rows[n], cols[n], half_cells)
    xy = offset_moments(scores, drop_abs, 1)
    sums = np.array([sum_under(grids.levels[0], rows[a], cols[a], 0, 0)
                     for a in range(offsets.size)])
    cov = surface_covariance_matrix(xy, res, sums, offsets, drop_abs)
    return cov, float(scores[half_cells, half_cells]) / (255.0 * pts.shape[0])


@numba.njit(cache=True)
def _level_scores(level: NDArray[np.uint8], rows: NDArray[np.int32], cols: NDArray[np.int32],
                  half: int) -> NDArray[np.float64]:
    """Scores of the translations ``[-half, half]^2`` cells (rows: y) on ``level``."""
    size = 2 * half + 1
    scores = np.empty((size, size))
    for i in range(size):
        for j in range(size):
            scores[i, j] = sum_under(level, rows, cols, i - half, j - half)
    return scores
