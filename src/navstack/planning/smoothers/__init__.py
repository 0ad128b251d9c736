"""Path smoothers with Nav2 ``nav2_smoother`` semantics.

``SimpleSmoother(params).smooth(path, costmap) -> Path`` and
``SavitzkyGolaySmoother(params).smooth(path, costmap) -> Path`` keep the end points and
cusps fixed, smooth each directional segment separately, re-derive headings (flipped on
reversing segments) and never introduce a collision into the path (rule in
:mod:`navstack.planning.smoothers.common`).
"""

from navstack.planning.smoothers.common import (
    SmootherTimedOut,
    find_directional_path_segments,
    update_approximate_path_orientations,
)
from navstack.planning.smoothers.savitzky_golay import (
    SavitzkyGolaySmoother,
    SavitzkyGolaySmootherParams,
    savitzky_golay_coefficients,
)
from navstack.planning.smoothers.simple import SimpleSmoother, SimpleSmootherParams

__all__ = [
    "SavitzkyGolaySmoother", "SavitzkyGolaySmootherParams", "SimpleSmoother",
    "SimpleSmootherParams", "SmootherTimedOut", "find_directional_path_segments",
    "savitzky_golay_coefficients", "update_approximate_path_orientations",
]
