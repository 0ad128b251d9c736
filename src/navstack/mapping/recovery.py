"""Wide search for a scan whose odometry cannot be trusted (:mod:`odometry_check`).

The local map around the prediction (the running buffer plus the nodes nearest to it) is
rasterised once into precomputed grids and the scan is placed by the branch-and-bound
matcher of :mod:`navstack.mapping.fast_matcher` over the full circle of headings and a
square of ``radius`` metres -- as far as the robot could have moved -- on a raster of
about 40 cells per radius (never finer than ``loop_search_space_resolution``).  Karto's distance
penalty is stretched over the window (``minimum_distance_penalty`` at its edge), so of
two equally good fits the nearer one wins; a fit is only believed when no pose farther
than ``loop_match_ambiguity_distance`` scores ``loop_match_maximum_ambiguity`` times as
well (the uniqueness test of loop closure), or when all such rivals lie along one line at
the same heading (a corridor: the fit is kept with the window's extent as its variance
along the corridor).  The winner is refined by the local matcher.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from navstack.mapping.fast_matcher import (
    Exclusion,
    PrecomputedGrids,
    WideWindow,
    angle_step,
    voxel_filter,
    wide_match,
)
from navstack.mapping.loop_closure import corridor_direction
from navstack.mapping.scan_matcher import MatchResult

if TYPE_CHECKING:
    from navstack.mapping.slam import SlamMapper

FloatArray = NDArray[np.float64]

__all__ = ["wide_link"]


def wide_link(mapper: SlamMapper, points: FloatArray, guess: FloatArray, radius: float,
              reference: Sequence[int]) -> MatchResult | None:
    """Best unique pose of ``points`` (robot frame) within ``radius`` of ``guess`` (any
    heading) against the map around it, refined; ``None`` if none is good and unique.

    The winner is taken when it scores at least ``loop_match_minimum_response_fine`` and
    is unique (or a corridor)."""
    p = mapper.params
    mapper.stats.wide_searches += 1
    near = mapper._nearest_nodes(guess, 2 * p.scan_buffer_size,
                                 p.scan_buffer_maximum_scan_distance + radius)
    ids = list(dict.fromkeys([*reference, *near]))
    if not ids or points.shape[0] < 10:
        return None
    ref, normals, line_like = mapper._world_features(ids)
    for half, half_angle in ((radius, math.pi),):
        found = _search(mapper, ref, points, guess, half, half_angle)
        if found is None:
            continue
        pose, res, corridor = found
        fine = mapper.match_points(ref, normals, line_like, points, pose,
                                   mapper.refine_window if res <= 0.05 else None)
        if fine is None or fine.response < p.loop_match_minimum_response_fine:
            continue
        if corridor is None:
            return fine
        # along a corridor the place is only known to the window: say so
        cov = fine.covariance.copy()
        cov[:2, :2] += half * half * np.outer(corridor, corridor)
        return replace(fine, covariance=cov)
    return None


def _search(mapper: SlamMapper, ref: FloatArray, points: FloatArray, guess: FloatArray,
            half: float, half_angle: float
            ) -> tuple[FloatArray, float, FloatArray | None] | None:
    """One stage: the best unique pose (or a corridor's), the raster resolution and the
    corridor direction (``None`` when unique)."""
    p = mapper.params
    # a coarser raster for a wider window (about 40 cells across the radius): the local
    # matcher refines the winner anyway
    res = max(p.loop_search_space_resolution, half / 40.0)
    smear = max(p.loop_search_space_smear_deviation, 0.5 * res)
    depth = min(max(math.ceil(math.log2(max(half / res, 2.0))) - 1, 3), 7)
    grids = PrecomputedGrids(ref, res, smear, depth)
    query = voxel_filter(points, res)
    minimum = p.minimum_distance_penalty
    variance = 0.2 * half * half / max(1.0 - minimum, 1e-3)
    window = WideWindow(half, half, half_angle, angle_step(query, res))
    best = wide_match(grids, query, guess, window,
                      min_score=p.loop_match_minimum_response_fine,
                      distance_penalty=(variance, minimum))
    if best is None:
        return None
    d = p.loop_match_ambiguity_distance
    rival = wide_match(grids, query, guess, window,
                       min_score=best.score * p.loop_match_maximum_ambiguity,
                       distance_penalty=(variance, minimum),
                       exclusion=Exclusion((best.pose[0], best.pose[1]), (1.0, 0.0), d, d,
                                           0.0, math.pi))
    if rival is None:
        return best.pose, res, None
    corridor = corridor_direction(grids, query, guess, window, best.pose, best.score,
                                  rival.pose, p.loop_match_maximum_ambiguity, d)
    return None if corridor is None else (best.pose, res, corridor)
