"""Correlative multi-resolution scan matching (Olson 2009; Karto / slam_toolbox matcher).

E. Olson, "Real-Time Correlative Scan Matching", ICRA 2009: the reference scans are
rasterised into a *likelihood grid* (each reference point smeared with a Gaussian of
``smear_deviation``), and every candidate pose ``(x, y, theta)`` of a search window is
scored by summing the grid under the transformed query points.  The search is exhaustive
but fast because of two resolutions:

* a *bound grid* holds, for every cell, the maximum of the likelihood grid over the
  ``k x k`` cells to its upper right; summing it under the points gives an upper bound of
  the score of all ``k x k`` translations of a block at once (Olson's multi-resolution
  branch and bound, exact: a block is only expanded while its bound beats the best score);
* angles are searched coarse then fine (Karto: ``coarse_search_angle_offset`` /
  ``coarse_angle_resolution``, then ``fine_search_angle_offset`` around the best angle).

The winner is refined to sub-cell accuracy by Gauss-Newton on the bilinearly interpolated
likelihood (Kohlbrecher et al., "A Flexible and Scalable SLAM System with Full 3D Motion
Estimation" (Hector SLAM), 2011), whose Hessian also gives the match covariance.

The *response* is the mean likelihood under the query points (0..1), the number that
slam_toolbox compares with ``link_match_minimum_response_fine``,
``loop_match_minimum_response_coarse`` and ``loop_match_minimum_response_fine``.
Karto's distance/angle penalties (``distance_variance_penalty``, ``angle_variance_penalty``,
``minimum_distance_penalty``, ``minimum_angle_penalty``) weight the search score so that,
among equally good fits, the one nearer the odometry guess wins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["LikelihoodGrid", "MatchResult", "SearchWindow", "ambiguity", "coupled_covariance",
           "match_scan", "offset_moments", "response_covariance", "smeared_grid",
           "surface_covariance_matrix"]


@dataclass(frozen=True)
class SearchWindow:
    """Where and how finely to search around the guess (slam_toolbox parameter names)."""

    dimension: float = 0.5              # correlation_search_space_dimension [m], full width
    coarse_angle_offset: float = 0.349  # coarse_search_angle_offset [rad], half range
    coarse_angle_resolution: float = 0.0349
    fine_angle_resolution: float = 0.00349  # fine_search_angle_offset [rad]
    distance_variance_penalty: float = 0.5
    angle_variance_penalty: float = 1.0
    minimum_distance_penalty: float = 0.5
    minimum_angle_penalty: float = 0.9
    refine: bool = True


@dataclass(frozen=True)
class MatchResult:
    """Best pose found, its response (mean likelihood, 0..1), 3x3 covariance and the
    Gauss-Newton Hessian ``J^T J`` of the fit there (``None`` when not computed)."""

    pose: FloatArray
    response: float
    covariance: FloatArray
    hessian: FloatArray | None = None


# --- likelihood grid ------------------------------------------------------------------
@numba.njit(cache=True)
def _stamp(grid: NDArray[np.float32], cells: NDArray[np.int64], kernel: NDArray[np.float32],
           low: int) -> None:
    """Max-stamp ``kernel`` at every cell ``(row, col)``; kernel index 0 is offset ``low``."""
    h, w = grid.shape
    size = kernel.shape[0]
    for n in range(cells.shape[0]):
        y0 = cells[n, 0] + low
        x0 = cells[n, 1] + low
        for i in range(size):
            y = y0 + i
            if y < 0 or y >= h:
                continue
            for j in range(size):
                x = x0 + j
                if x < 0 or x >= w:
                    continue
                v = kernel[i, j]
                if v > grid[y, x]:
                    grid[y, x] = v


def _smear_kernel(radius: int, resolution: float, sigma: float,
                  block: int) -> tuple[NDArray[np.float32], int]:
    """Smear kernel, widened for a bound grid of ``block x block`` translations.

    The fine grid is ``F(c) = max_p K(c - p)`` with ``K`` a Gaussian of the cell distance.
    The bound grid ``B(c) = max_{0 <= j < block} F(c + j)`` (per axis) equals
    ``max_p Kb(c - p)`` with ``Kb(e) = max_j K(e + j)``: the Gaussian of the distance from
    ``e`` to the interval ``[e, e + block - 1]``'s point nearest 0.  ``block == 1`` gives
    ``K`` itself.  Returns the kernel and the offset of its index 0."""
    offsets = np.arange(-radius - block + 1, radius + 1)
    nearest = np.where(offsets > 0, offsets,
                       np.where(offsets + block - 1 < 0, offsets + block - 1, 0))
    d2 = (nearest[:, None] ** 2 + nearest[None, :] ** 2) * (resolution * resolution)
    kernel = np.exp(-0.5 * d2 / (sigma * sigma)).astype(np.float32)
    return kernel, int(offsets[0])


def _distinct_cells(cells: NDArray[np.int64], height: int, width: int,
                    reach: int) -> NDArray[np.int64]:
    """The distinct cells whose stamp (``reach`` cells wide) can touch the grid: one
    stamp per cell, found with a 1-D ``unique`` (a plain sort, unlike ``axis=0``)."""
    rows = cells[:, 0] + reach
    cols = cells[:, 1] + reach
    span_r, span_c = height + 2 * reach, width + 2 * reach
    keep = (rows >= 0) & (rows < span_r) & (cols >= 0) & (cols < span_c)
    flat = np.unique(rows[keep] * span_c + cols[keep])
    return np.column_stack([flat // span_c - reach, flat % span_c - reach])


def smeared_grid(points: FloatArray, resolution: float, smear_deviation: float,
                 bounds: tuple[float, float, float, float]
                 ) -> tuple[NDArray[np.float32], FloatArray]:
    """The likelihood raster alone (no bound grid): ``(grid, origin)`` with ``grid[row,
    col]`` the max over ``points`` of a Gaussian of ``smear_deviation`` at the cell
    centre ``origin + (col, row) * resolution``, covering ``bounds`` (xmin, ymin, xmax,
    ymax)."""
    xmin, ymin, xmax, ymax = bounds
    origin = np.array([xmin, ymin], dtype=np.float64)
    width = math.ceil((xmax - xmin) / resolution) + 1
    height = math.ceil((ymax - ymin) / resolution) + 1
    grid = np.zeros((height, width), np.float32)
    radius = max(1, math.ceil(3.0 * smear_deviation / resolution))
    idx = np.rint((np.asarray(points, float) - origin) / resolution)
    cells = _distinct_cells(idx[:, ::-1].astype(np.int64), height, width, radius)
    kernel, low = _smear_kernel(radius, resolution, smear_deviation, 1)
    _stamp(grid, cells, kernel, low)
    return grid, origin


class LikelihoodGrid:
    """Smeared reference points on a grid, plus its ``block``-cell bound grid.

    ``origin`` is the world position of cell (0, 0)'s centre; ``grid[row, col]`` covers
    ``origin + (col, row) * resolution``.  Built from points in the world frame."""

    def __init__(self, points: FloatArray, resolution: float, smear_deviation: float,
                 bounds: tuple[float, float, float, float], block: int = 4) -> None:
        self.resolution = float(resolution)
        self.block = int(block)
        xmin, ymin, xmax, ymax = bounds
        self.origin = np.array([xmin, ymin])
        width = math.ceil((xmax - xmin) / resolution) + 1
        height = math.ceil((ymax - ymin) / resolution) + 1
        self.fine = np.zeros((height, width), np.float32)
        self.bound = np.zeros((height, width), np.float32)
        radius = max(1, math.ceil(3.0 * smear_deviation / resolution))
        cells = _distinct_cells(self.cells_of(points), height, width, radius + self.block)
        kernel, low = _smear_kernel(radius, resolution, smear_deviation, 1)
        _stamp(self.fine, cells, kernel, low)
        kernel_b, low_b = _smear_kernel(radius, resolution, smear_deviation, self.block)
        _stamp(self.bound, cells, kernel_b, low_b)

    @classmethod
    def around(cls, reference: FloatArray, query_world: FloatArray, margin: float,
               resolution: float, smear_deviation: float, block: int = 4) -> LikelihoodGrid:
        """A grid covering the query points (at any searched pose) plus ``margin``,
        cropped to where the reference can leave a mark (its extent plus the smear
        kernel and one bound block): outside that every cell is zero anyway, so the
        scores are the same and a small local map costs a small grid."""
        reach = 3.0 * smear_deviation + (block + 1) * resolution
        lo = np.maximum(query_world.min(axis=0) - margin, reference.min(axis=0) - reach)
        hi = np.minimum(query_world.max(axis=0) + margin, reference.max(axis=0) + reach)
        hi = np.maximum(hi, lo + resolution)
        return cls(reference, resolution, smear_deviation, (lo[0], lo[1], hi[0], hi[1]), block)

    def cells_of(self, points: FloatArray) -> NDArray[np.int64]:
        """``(row, col)`` of the cells holding ``points`` (N, 2)."""
        idx = np.rint((np.asarray(points, float) - self.origin) / self.resolution)
        return idx[:, ::-1].astype(np.int64)


# --- search -----------------------------------------------------------------------------
@numba.njit(cache=True)
def sum_under(grid: NDArray[np.float32] | NDArray[np.uint8],
              rows: NDArray[np.int64] | NDArray[np.int32],
              cols: NDArray[np.int64] | NDArray[np.int32], drow: int, dcol: int) -> float:
    """Sum of ``grid`` under the cells (``rows + drow``, ``cols + dcol``) inside it (the
    correlative score of one shift; numba compiles it per grid type -- the likelihood
    grid's float32 here, the fast matcher's uint8 levels)."""
    h, w = grid.shape
    total = 0.0
    for n in range(rows.size):
        r = rows[n] + drow
        c = cols[n] + dcol
        if 0 <= r < h and 0 <= c < w:
            total += grid[r, c]
    return total


@numba.njit(cache=True)
def _bnb_search(fine: NDArray[np.float32], bound: NDArray[np.float32],
                rows: NDArray[np.int64], cols: NDArray[np.int64],
                penalty_angle: NDArray[np.float64], half: int, block: int,
                resolution: float, dist_var_penalty: float, min_dist_penalty: float,
                exclude_angle: int, exclude_row: int, exclude_col: int, exclude_cells: int
                ) -> tuple[int, int, int, float]:
    """Best (angle index, row offset, col offset, penalised score) over the window.

    ``rows``/``cols`` (A, N): cells of the query points for each candidate angle at zero
    translation; offsets range over ``[-half, half]`` cells.  Blocks of ``block x block``
    offsets are bounded with the bound grid, sorted, and expanded best first until the
    bound cannot beat the best penalised fine score (exact branch and bound)."""
    n_angles = rows.shape[0]
    n_points = rows.shape[1]
    starts = np.arange(-half, half + 1, block)
    nb = starts.size
    bounds = np.empty(n_angles * nb * nb)
    for a in range(n_angles):
        for i in range(nb):
            for j in range(nb):
                s = sum_under(bound, rows[a], cols[a], starts[i], starts[j])
                bounds[(a * nb + i) * nb + j] = s * penalty_angle[a]
    order = np.argsort(-bounds)
    best = -1.0
    best_a = 0
    best_r = 0
    best_c = 0
    inv_n = 1.0 / max(n_points, 1)
    for k in range(order.size):
        idx = order[k]
        if bounds[idx] <= best:
            break
        a = idx // (nb * nb)
        i = (idx // nb) % nb
        j = idx % nb
        for dr in range(starts[i], min(starts[i] + block, half + 1)):
            for dc in range(starts[j], min(starts[j] + block, half + 1)):
                if (exclude_cells >= 0 and (exclude_angle < 0 or exclude_angle == a)
                        and abs(dr - exclude_row) <= exclude_cells
                        and abs(dc - exclude_col) <= exclude_cells):
                    continue
                s = sum_under(fine, rows[a], cols[a], dr, dc) * penalty_angle[a]
                d2 = (dr * dr + dc * dc) * resolution * resolution
                pen = 1.0 - 0.2 * d2 / dist_var_penalty
                if pen < min_dist_penalty:
                    pen = min_dist_penalty
                s *= pen
                if s > best:
                    best = s
                    best_a = a
                    best_r = dr
                    best_c = dc
    return best_a, best_r, best_c, best * inv_n


@numba.njit(cache=True)
def _bilinear(grid: NDArray[np.float32], gx: float, gy: float) -> tuple[float, float, float]:
    """Value and gradient (per cell) of the grid at continuous cell coords (col, row)."""
    h, w = grid.shape
    x0 = math.floor(gx)
    y0 = math.floor(gy)
    if x0 < 0 or y0 < 0 or x0 + 1 >= w or y0 + 1 >= h:
        return 0.0, 0.0, 0.0
    fx = gx - x0
    fy = gy - y0
    v00 = grid[y0, x0]
    v01 = grid[y0, x0 + 1]
    v10 = grid[y0 + 1, x0]
    v11 = grid[y0 + 1, x0 + 1]
    value = (v00 * (1 - fx) + v01 * fx) * (1 - fy) + (v10 * (1 - fx) + v11 * fx) * fy
    dx = (v01 - v00) * (1 - fy) + (v11 - v10) * fy
    dy = (v10 - v00) * (1 - fx) + (v11 - v01) * fx
    return value, dx, dy


@numba.njit(cache=True)
def _gauss_newton(grid: NDArray[np.float32], local: NDArray[np.float64], ox: float, oy: float,
                  resolution: float, pose: NDArray[np.float64], max_step: float,
                  iterations: int) -> tuple[NDArray[np.float64], float, NDArray[np.float64]]:
    """Minimise sum (1 - M(T p))^2 over the pose (Hector SLAM), bilinear M.

    Returns the refined pose, the mean likelihood there and the 3x3 Hessian J^T J (in
    metres/radians).  Steps are limited to ``max_step`` metres so that the refinement
    cannot leave the basin the correlative search found."""
    p = pose.copy()
    H = np.zeros((3, 3))
    inv_res = 1.0 / resolution
    mean = 0.0
    for _ in range(iterations):
        c = math.cos(p[2])
        s = math.sin(p[2])
        H[:, :] = 0.0
        g = np.zeros(3)
        total = 0.0
        for n in range(local.shape[0]):
            lx = local[n, 0]
            ly = local[n, 1]
            wx = p[0] + c * lx - s * ly
            wy = p[1] + s * lx + c * ly
            v, dvx, dvy = _bilinear(grid, (wx - ox) * inv_res, (wy - oy) * inv_res)
            total += v
            dvx *= inv_res
            dvy *= inv_res
            # d(world)/d(theta)
            dth = dvx * (-s * lx - c * ly) + dvy * (c * lx - s * ly)
            r = 1.0 - v
            J0 = dvx
            J1 = dvy
            J2 = dth
            g[0] += J0 * r
            g[1] += J1 * r
            g[2] += J2 * r
            H[0, 0] += J0 * J0
            H[0, 1] += J0 * J1
            H[0, 2] += J0 * J2
            H[1, 1] += J1 * J1
            H[1, 2] += J1 * J2
            H[2, 2] += J2 * J2
        H[1, 0] = H[0, 1]
        H[2, 0] = H[0, 2]
        H[2, 1] = H[1, 2]
        mean = total / max(local.shape[0], 1)
        A = H + np.eye(3) * 1e-9
        delta = np.linalg.solve(A, g)
        step = math.hypot(delta[0], delta[1])
        if step > max_step:
            delta[:2] *= max_step / step
        max_turn = max_step / 0.5  # a point 0.5 m out moves at most max_step
        if abs(delta[2]) > max_turn:
            delta[2] = math.copysign(max_turn, delta[2])
        p[0] += delta[0]
        p[1] += delta[1]
        p[2] += delta[2]
        if step < 1e-5 and abs(delta[2]) < 1e-6:
            break
    return p, mean, H


def _cells_at_angles(grid: LikelihoodGrid, local: FloatArray, xy: FloatArray,
                     angles: FloatArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``(A, N)`` rows and columns of the points rotated by each angle, shifted by xy."""
    c = np.cos(angles)[:, None]
    s = np.sin(angles)[:, None]
    wx = c * local[:, 0] - s * local[:, 1] + xy[0]
    wy = s * local[:, 0] + c * local[:, 1] + xy[1]
    cols = np.rint((wx - grid.origin[0]) / grid.resolution).astype(np.int64)
    rows = np.rint((wy - grid.origin[1]) / grid.resolution).astype(np.int64)
    return rows, cols


def _angle_penalty(dtheta: FloatArray, variance: float, minimum: float) -> FloatArray:
    """Karto's angle penalty ``1 - 0.2 * dtheta^2 / angle_variance_penalty``, floored."""
    return np.maximum(1.0 - 0.2 * dtheta * dtheta / variance, minimum)


def _search_angles(grid: LikelihoodGrid, local: FloatArray, guess: FloatArray,
                   angles: FloatArray, half_cells: int, window: SearchWindow,
                   exclude: tuple[float, float, float] | None = None,
                   ) -> tuple[float, float, float, float]:
    """Branch-and-bound translation search over the given absolute angles."""
    rows, cols = _cells_at_angles(grid, local, guess[:2], angles)
    pen = _angle_penalty(angles - guess[2], window.angle_variance_penalty,
                         window.minimum_angle_penalty)
    ex_r = ex_c = 0
    ex_cells = -1
    if exclude is not None:
        ex_c = round((exclude[0] - guess[0]) / grid.resolution)
        ex_r = round((exclude[1] - guess[1]) / grid.resolution)
        ex_cells = math.ceil(exclude[2] / grid.resolution)
    a, dr, dc, score = _bnb_search(grid.fine, grid.bound, rows, cols, pen, half_cells,
                                   grid.block, grid.resolution,
                                   window.distance_variance_penalty,
                                   window.minimum_distance_penalty, -1, ex_r, ex_c, ex_cells)
    x = guess[0] + dc * grid.resolution
    y = guess[1] + dr * grid.resolution
    return x, y, float(angles[a]), score


def match_scan(grid: LikelihoodGrid, local: FloatArray, guess: FloatArray,
               window: SearchWindow) -> MatchResult:
    """Match ``local`` scan points (N, 2, robot frame) against ``grid`` around ``guess``."""
    guess = np.asarray(guess, float)
    res = grid.resolution
    half_cells = max(1, round(0.5 * window.dimension / res))
    n_coarse = round(window.coarse_angle_offset / window.coarse_angle_resolution)
    coarse = guess[2] + window.coarse_angle_resolution * np.arange(-n_coarse, n_coarse + 1)
    x, y, th, score = _search_angles(grid, local, guess, coarse, half_cells, window)
    n_fine = round(window.coarse_angle_resolution / window.fine_angle_resolution)
    fine = (th + window.fine_angle_resolution * np.arange(-n_fine, n_fine + 1)).astype(float)
    local_guess = np.array([x, y, guess[2]])
    x2, y2, th2, score2 = _search_angles(grid, local, local_guess, fine,
                                         max(2, grid.block), window)
    del score
    pose = np.array([x2, y2, th2])
    if window.refine:
        refined, mean, H = _gauss_newton(grid.fine, local, grid.origin[0], grid.origin[1],
                                         res, pose, res, 10)
        if mean >= score2 * 0.98:
            pose = refined
    mean_here, H = _response_and_hessian(grid, local, pose)
    pose[2] = math.atan2(math.sin(pose[2]), math.cos(pose[2]))
    return MatchResult(pose=pose, response=mean_here, covariance=_covariance(H, mean_here, res),
                       hessian=H)


def ambiguity(grid: LikelihoodGrid, local: FloatArray, guess: FloatArray,
              best: FloatArray, window: SearchWindow, exclusion: float) -> float:
    """Score of the best match farther than ``exclusion`` metres from ``best``, divided
    by the score at ``best`` (coarse angles, whole window).  Near 1 means the scan fits
    two places equally well (a corridor, a row of identical rooms): a loop closure there
    would be a guess (the uniqueness test of Olson 2009, section V)."""
    guess = np.asarray(guess, float)
    half_cells = max(1, round(0.5 * window.dimension / grid.resolution))
    n_coarse = round(window.coarse_angle_offset / window.coarse_angle_resolution)
    angles = guess[2] + window.coarse_angle_resolution * np.arange(-n_coarse, n_coarse + 1)
    *_, best_score = _search_angles(grid, local, guess, angles, half_cells, window)
    *_, other = _search_angles(grid, local, guess, angles, half_cells, window,
                               (float(best[0]), float(best[1]), exclusion))
    return float(other / best_score) if best_score > 0 else 1.0


def response_covariance(grid: LikelihoodGrid, local: FloatArray, pose: FloatArray,
                        window: SearchWindow, drop: float = 0.1) -> FloatArray:
    """Covariance of a match from the shape of its response surface (Karto's
    ``ComputePositionalCovariance`` / ``ComputeAngularCovariance``; Olson 2009, sec. IV).

    Over the window's translations at the matched angle, and over the fine angles of one
    coarse step either side at the matched translation, every pose whose response is
    within ``drop`` of the best counts, weighted by its response; the covariance is the
    weighted second moment of their offsets from the match (x, y, theta; no cross terms
    between translation and angle).  A corridor or an open hall -- responses as good
    all along one direction -- gives a long covariance there, a unique fit a short one
    (at most one cell and one fine step wide, the floor is left to the caller)."""
    res = grid.resolution
    half = max(1, round(0.5 * window.dimension / res))
    n = max(1, round(window.coarse_angle_resolution / window.fine_angle_resolution))
    offsets = window.fine_angle_resolution * np.arange(-n, n + 1)
    rows, cols = _cells_at_angles(grid, local, pose[:2], pose[2] + offsets)
    xy = _translation_moments(grid.fine, rows[n], cols[n], half, drop * local.shape[0],
                              2 if half > 6 else 1)
    scores = _sums_at_rows(grid.fine, rows, cols)
    return surface_covariance_matrix(xy, res, scores, np.asarray(offsets, dtype=np.float64),
                                     drop * local.shape[0])


def coupled_covariance(grid: LikelihoodGrid, local: FloatArray, pose: FloatArray,
                       hessian: FloatArray, unit: FloatArray, ratio: float,
                       steps: int = 30, drop: float = 0.1) -> FloatArray | None:
    """Covariance along a *coupled* weak direction of a match, which
    :func:`response_covariance` cannot see; ``None`` when there is none.

    The response surface is sampled along x and y at the matched angle and along the
    angle at the matched position, so it misses a direction that mixes both: a scan
    whose returns are one cluster a few metres away (a rack corner seen across an open
    hall by a 3.5 m lidar) fits as well turned about that cluster -- rotation plus the
    translation that keeps the cluster in place -- as at the match.  The Gauss-Newton
    Hessian ``hessian`` (``J^T J`` of the smeared fit) knows that direction: its weakest
    eigenvector, in units of the perfect match's deviations ``unit`` (x, y, theta).
    When that direction is at least ``ratio`` times longer than the strongest (standard
    deviations, the same test as the odometry edges' ``slam_links.degenerate``), the response is
    scored at ``-steps..steps`` unit steps along it and, as Karto's
    ``ComputePositionalCovariance`` does over its window, the offsets within ``drop``
    (a share of the points) of the best count, weighted by their score: their second
    moment is the variance along the direction."""
    h = np.asarray(hessian, float) * unit[:, None] * unit[None, :]
    w, v = np.linalg.eigh(0.5 * (h + h.T))
    if w[-1] <= 0.0 or w[-1] < ratio * ratio * max(float(w[0]), 1e-12):
        return None
    d = v[:, 0] * unit  # one step along the weakest direction (metres, radians)
    t = np.arange(-steps, steps + 1, dtype=np.float64)
    th = pose[2] + t * d[2]
    c, s = np.cos(th)[:, None], np.sin(th)[:, None]
    wx = c * local[:, 0] - s * local[:, 1] + (pose[0] + t * d[0])[:, None]
    wy = s * local[:, 0] + c * local[:, 1] + (pose[1] + t * d[1])[:, None]
    cols = np.rint((wx - grid.origin[0]) / grid.resolution).astype(np.int64)
    rows = np.rint((wy - grid.origin[1]) / grid.resolution).astype(np.int64)
    scores = _sums_at_rows(grid.fine, rows, cols)
    keep = scores >= scores.max() - drop * local.shape[0]
    weights = scores[keep]
    if weights.sum() <= 0.0:
        return None
    var = float((weights * t[keep] ** 2).sum() / weights.sum())
    return var * np.outer(d, d)


@numba.njit(cache=True)
def _sums_at_rows(fine: NDArray[np.float32], rows: NDArray[np.int64],
                  cols: NDArray[np.int64]) -> NDArray[np.float64]:
    out = np.empty(rows.shape[0])
    for a in range(rows.shape[0]):
        out[a] = sum_under(fine, rows[a], cols[a], 0, 0)
    return out


@numba.njit(cache=True)
def _translation_moments(fine: NDArray[np.float32], rows: NDArray[np.int64],
                         cols: NDArray[np.int64], half: int, drop: float, stride: int
                         ) -> NDArray[np.float64]:
    """Weighted second moments (cells^2) of the offsets whose summed score is within
    ``drop`` of the best over ``[-half, half]^2``, sampled every ``stride`` cells."""
    n = half // stride
    size = 2 * n + 1
    scores = np.empty((size, size))
    for i in range(size):
        for j in range(size):
            scores[i, j] = sum_under(fine, rows, cols, (i - n) * stride, (j - n) * stride)
    return offset_moments(scores, drop, stride)


@numba.njit(cache=True)
def offset_moments(scores: NDArray[np.float64], drop: float, stride: int
                   ) -> NDArray[np.float64]:
    """Weighted second moments (cells^2) of the translations of a response surface:
    ``scores`` ``(2n+1, 2n+1)`` holds the score at offset ``((i - n) * stride, (j - n) *
    stride)`` cells (rows: y); the offsets within ``drop`` of the best count, weighted
    by their score (Karto's ``ComputePositionalCovariance``).  Shared with the
    branch-and-bound matcher's :func:`navstack.mapping.fast_matcher.surface_covariance`."""
    size = scores.shape[0]
    n = size // 2
    best = -1.0
    for i in range(size):
        for j in range(size):
            if scores[i, j] > best:
                best = scores[i, j]
    out = np.zeros((2, 2))
    norm = 0.0
    for i in range(size):
        for j in range(size):
            v = scores[i, j]
            if v >= best - drop:
                dy = (i - n) * stride
                dx = (j - n) * stride
                norm += v
                out[0, 0] += v * dx * dx
                out[0, 1] += v * dx * dy
                out[1, 1] += v * dy * dy
    if norm > 0:
        out /= norm
    out[1, 0] = out[0, 1]
    return out


def surface_covariance_matrix(xy: FloatArray, resolution: float, angle_scores: FloatArray,
                              angle_offsets: FloatArray, drop: float) -> FloatArray:
    """The (x, y, theta) covariance of a response surface: the translation moments
    ``xy`` (cells^2, :func:`offset_moments`) in metres, and the response-weighted second
    moment of the angle offsets whose score is within ``drop`` of the best (Karto's
    ``ComputeAngularCovariance``); no cross terms between translation and angle."""
    keep = angle_scores >= angle_scores.max() - drop
    w = angle_scores[keep]
    var_th = float((w * angle_offsets[keep] ** 2).sum() / w.sum()) if w.sum() > 0 else 0.0
    cov = np.zeros((3, 3))
    cov[:2, :2] = xy * resolution * resolution
    cov[2, 2] = var_th
    return cov


def _response_and_hessian(grid: LikelihoodGrid, local: FloatArray,
                          pose: FloatArray) -> tuple[float, FloatArray]:
    _, mean, H = _gauss_newton(grid.fine, local, grid.origin[0], grid.origin[1],
                               grid.resolution, pose, 0.0, 1)
    return float(mean), H


def _covariance(H: FloatArray, response: float, resolution: float) -> FloatArray:
    """Match covariance from the Gauss-Newton Hessian (Hector SLAM), regularised.

    ``sigma^2 = residual variance * H^-1`` with the residual variance taken from the mean
    misfit ``1 - response``; a floor of a quarter cell (translation) and 0.25 deg keeps the
    graph well conditioned when the fit is perfect."""
    misfit = max(1.0 - response, 0.05)
    floor = np.diag([(0.25 * resolution) ** 2, (0.25 * resolution) ** 2,
                     math.radians(0.25) ** 2])
    try:
        cov = np.linalg.inv(H + np.eye(3) * 1e-6) * misfit * misfit
    except np.linalg.LinAlgError:
        cov = np.diag([1.0, 1.0, 0.1])
    cov = 0.5 * (cov + cov.T) + floor
    return cov
