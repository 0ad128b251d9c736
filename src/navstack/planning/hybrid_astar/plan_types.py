"""Plan records and formatting helpers of the Hybrid-A* planner."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import Path, Pose2D


@dataclass
class HybridPlan:
    """A plan with what the search knows about it (all poses in the costmap frame)."""

    path: Path
    raw: NDArray[np.float64]
    """Unsmoothed ``(N, 3)`` poses."""
    smoothed: NDArray[np.float64]
    """``(N, 3)`` poses after the smoother (== ``raw`` when smoothing is off)."""
    direction: NDArray[np.int8]
    """+1 / -1 per pose: travel direction of the motion reaching it."""
    iterations: int
    analytic: bool
    """True when the path ends with an analytic Dubins/RS shot."""
    reached_goal: bool
    """False when the path ends at the best node within ``tolerance`` instead."""
    search_ms: float
    total_ms: float
    stats: dict[str, float] = field(default_factory=dict)


def fmt_xy(p: Pose2D) -> str:
    """``(x, y)`` with 2 decimals, as the planner errors print positions."""
    return f"({p.x:.2f}, {p.y:.2f})"


def fmt_heading(theta: float) -> str:
    """A heading in radians and degrees."""
    return f"{theta:.3f} rad ({math.degrees(theta):.1f} deg)"


def heading_ranges(bins_set: NDArray[np.int64] | list[int], bins: int) -> str:
    """Heading bins as degree ranges in [0, 360), e.g. ``"340..20, 150..210"``."""
    present = sorted({int(b) % bins for b in bins_set})
    if not present:
        return "none"
    groups: list[list[int]] = [[present[0], present[0]]]
    for b in present[1:]:
        if b == groups[-1][1] + 1:
            groups[-1][1] = b
        else:
            groups.append([b, b])
    if len(groups) > 1 and groups[0][0] == 0 and groups[-1][1] == bins - 1:
        groups[0][0] = groups.pop()[0]  # the range wraps through 0 deg
    step = 360.0 / bins
    return ", ".join(f"{a * step:g}" if a == b else f"{a * step:g}..{b * step:g}"
                     for a, b in groups)


def downsample_max(data: NDArray[np.uint8], factor: int) -> NDArray[np.uint8]:
    """Nav2 ``CostmapDownsampler``: each ``factor x factor`` block takes its maximum."""
    h, w = data.shape
    hd, wd = -(-h // factor), -(-w // factor)
    pad = np.zeros((hd * factor, wd * factor), dtype=np.uint8)
    pad[:h, :w] = data
    return np.ascontiguousarray(pad.reshape(hd, factor, wd, factor).max(axis=(1, 3)))
