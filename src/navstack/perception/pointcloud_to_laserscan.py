"""pointcloud_to_laserscan: a 3-D cloud flattened into a planar scan (the ROS package of
that name, whose parameters and semantics this follows).

Points are taken in ``target_frame`` (the node transforms them; here they arrive as an
``(N, 3)`` array).  A point counts when it is finite, its height lies in
``[min_height, max_height]``, its horizontal range ``hypot(x, y)`` in
``[range_min, range_max]`` and its bearing ``atan2(y, x)`` in ``[angle_min, angle_max]``;
it falls into beam ``int((angle - angle_min) / angle_increment)`` and each beam keeps
its nearest point.  Beams with no point read ``+inf`` with ``use_inf`` (REP-117), else
``range_max + inf_epsilon``.  Defaults are the package's: heights from the smallest
positive double (so the ground plane z = 0 is left out) to the largest, the full circle
at 1 degree, ranges 0..max, ``inf_epsilon`` 1, ``use_inf`` true, scan time 1/30 s.
Vectorised: one ``np.minimum.at`` over the selected points.
"""

from __future__ import annotations

import math
import sys

import numpy as np
from numpy.typing import ArrayLike
from pydantic import ConfigDict, Field, model_validator

from navstack.core.msgs import Header, LaserScan
from navstack.core.params import Params

__all__ = ["PointCloudToLaserScanParams", "pointcloud_to_laserscan"]


class PointCloudToLaserScanParams(Params):
    """The ROS pointcloud_to_laserscan node's parameters (names and defaults)."""

    model_config = ConfigDict(allow_inf_nan=True)

    target_frame: str = ""
    """Frame the scan is built in ("": the cloud's own frame)."""
    transform_tolerance: float = Field(default=0.01, ge=0.0)
    min_height: float = sys.float_info.min
    max_height: float = sys.float_info.max
    angle_min: float = Field(default=-math.pi, ge=-2 * math.pi, le=2 * math.pi)
    angle_max: float = Field(default=math.pi, ge=-2 * math.pi, le=2 * math.pi)
    angle_increment: float = Field(default=math.pi / 180.0, gt=0.0)
    scan_time: float = Field(default=1.0 / 30.0, gt=0.0)
    range_min: float = Field(default=0.0, ge=0.0)
    range_max: float = Field(default=sys.float_info.max, gt=0.0)
    use_inf: bool = True
    inf_epsilon: float = Field(default=1.0, ge=0.0)

    @model_validator(mode="after")
    def _ordered(self) -> PointCloudToLaserScanParams:
        if not self.angle_max > self.angle_min:
            raise ValueError(f"angle_max ({self.angle_max}) must exceed angle_min "
                             f"({self.angle_min})")
        if not self.max_height >= self.min_height:
            raise ValueError(f"max_height ({self.max_height}) must be >= min_height "
                             f"({self.min_height})")
        if not self.range_max > self.range_min:
            raise ValueError(f"range_max ({self.range_max}) must exceed range_min "
                             f"({self.range_min})")
        return self

    @property
    def beams(self) -> int:
        return math.ceil((self.angle_max - self.angle_min) / self.angle_increment)


def pointcloud_to_laserscan(points: ArrayLike, params: PointCloudToLaserScanParams,
                            header: Header) -> LaserScan:
    """The scan of ``points`` ``(N, 3)`` [m] (already in the target frame)."""
    p = params
    xyz = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = p.beams
    fill = math.inf if p.use_inf else p.range_max + p.inf_epsilon
    ranges = np.full(n, fill, dtype=np.float64)
    x, y, z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    with np.errstate(invalid="ignore"):
        r = np.hypot(x, y)
        a = np.arctan2(y, x)
        keep = (np.isfinite(r) & np.isfinite(z) & (z >= p.min_height) & (z <= p.max_height)
                & (r >= p.range_min) & (r <= p.range_max) & (a >= p.angle_min)
                & (a <= p.angle_max))
    idx = ((a[keep] - p.angle_min) / p.angle_increment).astype(np.int64)
    idx = np.minimum(idx, n - 1)  # angle == angle_max lands in the last beam
    np.minimum.at(ranges, idx, r[keep])
    return LaserScan(header, p.angle_min, p.angle_max, p.angle_increment, 0.0, p.scan_time,
                     p.range_min, p.range_max, ranges.astype(np.float32),
                     np.zeros(0, np.float32))
