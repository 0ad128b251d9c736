"""Fixes, odometry and parameters for the navsat_transform tests (pure and node)."""

from __future__ import annotations

import numpy as np

from navstack.core.msgs import (
    Header,
    NavSatFix,
    NavSatStatus,
    Odometry,
    Pose2D,
    PoseWithCovariance,
)
from navstack.geo.conversions import LocalCartesian
from navstack.localization.navsat import NavsatTransformParams

LAT0, LON0, ALT0 = 38.406415, -110.791924, 1380.0
ENU = LocalCartesian(LAT0, LON0, 0.0)
COV = np.diag([4.0, 1.0, 9.0])


def fix_at(e: float, n: float, u: float = ALT0, t: float = 0.0, frame: str = "gps",
           cov: np.ndarray = COV, status: int = NavSatStatus.STATUS_FIX,
           cov_type: int = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN) -> NavSatFix:
    lat, lon, alt = ENU.reverse(e, n, u)
    return NavSatFix(Header(t, frame), NavSatStatus(status, 1), lat, lon, alt, cov, cov_type)


def odom_at(x: float, y: float, yaw: float, t: float = 0.0,
            cov: np.ndarray | None = None) -> Odometry:
    c = np.zeros((6, 6)) if cov is None else cov
    return Odometry(Header(t, "map"), "base_link",
                    PoseWithCovariance(Pose2D(x, y, yaw).to_pose(), c))


def local_params(**kw: object) -> NavsatTransformParams:
    return NavsatTransformParams.from_mapping({"use_local_cartesian": True, **kw})
