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

:func:`predicted_link` is the search for a scan with no odometry over its step (a gap),
around a *motion prediction* rather than an odometry pose: the same window, plus a
heading prior (Karto's angle penalty around the predicted heading, spanning the circle:
``minimum_distance_penalty`` at 180 degrees -- a robot seldom turns round between two
scans, and a corridor scan fits its own corridor turned round almost as well), leaves
kept down to the penalised floor (``loop_match_minimum_response_fine`` times both
penalties' minimum: the fit must still reach ``loop_match_minimum_response_fine``
unpenalised once refined, but a true pose near the edge of the window is no longer cut
before it is scored -- CSAIL scan 53 with every second interval's odometry removed: true
fit 0.51, 0.87 m from the prediction, penalised to 0.42 < 0.45), and an ambiguous best
kept, flagged, for the caller to weigh against the local fit around the prediction.
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

__all__ = ["predicted_link", "wide_link"]


def wide_link(mapper: SlamMapper, points: FloatArray, guess: FloatArray, radius: float,
              reference: Sequence[int]) -> MatchResult | None:
    """Best unique pose of ``points`` (robot frame) within ``radius`` of ``guess`` (any
    heading) against the map around it, refined; ``None`` if none is good and unique.

    The winner is taken when it scores at least ``loop_match_minimum_response_fine`` and
    is unique (or a corridor)."""
    return _link(mapper, points, guess, radius, reference, predicted=False)[0]


def predicted_link(mapper: SlamMapper, points: FloatArray, guess: FloatArray, radius: float,
                   reference: Sequence[int]) -> tuple[MatchResult | None, bool]:
    """:func:`wide_link` around a motion prediction ``guess`` (module docstring): the
    best fit (refined) or ``None``, and whether it was ambiguous -- another pose farther
    than ``loop_match_ambiguity_distance``, not along one corridor, scores at least
    ``loop_match_maximum_ambiguity`` times as well.  An ambiguous fit's covariance
    spans the window towards that rival."""
    return _link(mapper, points, guess, radius, reference, predicted=True)


def _link(mapper: SlamMapper, points: FloatArray, guess: FloatArray, radius: float,
          reference: Sequence[int], predicted: bool) -> tuple[MatchResult | None, bool]:
    p = mapper.params
    mapper.stats.wide_searches += 1
    near = mapper._nearest_nodes(guess, 2 * p.scan_buffer_size,
                                 p.scan_buffer_maximum_scan_distance + radius)
    ids = list(dict.fromkeys([*reference, *near]))
    if not ids or points.shape[0] < 10:
        return None, False
    ref, normals, line_like = mapper._world_features(ids)
    if ref.shape[0] == 0:  # the nodes around saw nothing in range: nothing to search
        return None, False
    half, half_angle = radius, math.pi
    found = _search(mapper, ref, points, guess, half, half_angle, predicted)
    if found is None:
        return None, False
    pose, res, direction, ambiguous = found
    fine = mapper.match_points(ref, normals, line_like, points, pose,
                               mapper.refine_window if res <= 0.05 else None)
    if fine is None or fine.response < p.loop_match_minimum_response_fine:
        return None, False
    if direction is None:
        return fine, False
    # along a corridor (or towards an ambiguous rival) the place is only known to the
    # window: say so
    cov = fine.covariance.copy()
    cov[:2, :2] += half * half * np.outer(direction, direction)
    return replace(fine, covariance=cov), ambiguous


def _search(mapper: SlamMapper, ref: FloatArray, points: FloatArray, guess: FloatArray,
            half: float, half_angle: float, predicted: bool
            ) -> tuple[FloatArray, float, FloatArray | None, bool] | None:
    """The best unique pose (or a corridor's; with ``predicted`` an ambiguous one too),
    the raster resolution, the corridor direction (or the rival's; ``None`` when
    unique) and whether the pose is ambiguous."""
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
    floor = p.loop_match_minimum_response_fine
    heading: tuple[float, float] = (math.inf, 0.0)
    if predicted:
        # Karto's angle penalty reaching the distance penalty's minimum at 180 degrees
        heading = (0.2 * math.pi ** 2 / max(1.0 - minimum, 1e-3), minimum)
        floor *= minimum * minimum
    best = wide_match(grids, query, guess, window, min_score=floor,
                      distance_penalty=(variance, minimum), angle_penalty=heading)
    if best is None:
        return None
    d = p.loop_match_ambiguity_distance
    rival = wide_match(grids, query, guess, window,
                       min_score=best.score * p.loop_match_maximum_ambiguity,
                       distance_penalty=(variance, minimum), angle_penalty=heading,
                       exclusion=Exclusion((best.pose[0], best.pose[1]), (1.0, 0.0), d, d,
                                           0.0, math.pi))
    if rival is None:
        return best.pose, res, None, False
    corridor = corridor_direction(grids, query, guess, window, best.pose, best.score,
                                  rival.pose, p.loop_match_maximum_ambiguity, d)
    if corridor is not None:
        return best.pose, res, corridor, False
    if not predicted:
        return None
    toward = rival.pose[:2] - best.pose[:2]
    return best.pose, res, toward / max(float(np.hypot(toward[0], toward[1])), 1e-9), True
