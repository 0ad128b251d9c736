"""Initial pose from GNSS + magnetometer, refined by matching the live scan to the map.

Outdoors-to-indoors start-up without a human clicking "2D Pose Estimate":

1. **Guess.**  The GNSS fix (antenna) is put into the local ENU frame of ``datum``
   (exact WGS84, :class:`navstack.geo.conversions.LocalCartesian`); the heading comes
   from the magnetometer (:func:`magnetometer_yaw`: ``pi/2 - declination - atan2(b_y,
   b_x)`` plus the configured ``magnetometer_yaw_offset``); the antenna lever arm is
   removed; ``map_from_enu`` ``[x, y, yaw]`` (the pose of the ENU frame in ``map``) takes
   the pose into the map.
2. **Correlative search.**  The *real* current scan is matched against a likelihood grid
   of the map's occupied cells (Olson, "Real-Time Correlative Scan Matching", ICRA 2009,
   via :func:`navstack.mapping.scan_matcher.match_scan`) over +-``linear_search``
   (3 m) and +-``angular_search`` (20 deg) around the guess -- wide enough for a 2 m
   (1 sigma per axis) GNSS error and a 15 deg magnetometer error.  Karto's distance and
   angle penalties are set weak (a broad prior around the guess) so a far but better fit
   wins.
3. **Point-to-line ICP** (Censi, ICRA 2008, :mod:`navstack.mapping.icp`) polishes the
   pose against the occupied cells' boundary points.

:class:`~navstack.nodes.initial_pose.InitialPoseNode` publishes the result as
``/initialpose`` (geometry_msgs/PoseWithCovarianceStamped in ``map``) for AMCL; if the
match response is below ``min_response`` the unrefined guess is
published with the GNSS/magnetometer covariance instead, and the reason is kept.
:func:`navstack.benchmarks.initial_pose.initial_pose_trials` measures the whole chain
in the simulator (``initial_pose_err_m``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from navstack.core.errors import InvalidMessage
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import (
    Header,
    LaserScan,
    MagneticField,
    NavSatFix,
    OccupancyGrid,
    Pose2D,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
)
from navstack.core.params import Params
from navstack.geo.conversions import LocalCartesian
from navstack.localization.navsat import fix_rejection_reason
from navstack.mapping.icp import line_normals, refine_point_to_line
from navstack.mapping.scan_matcher import LikelihoodGrid, SearchWindow, match_scan

FloatArray = NDArray[np.float64]

__all__ = ["InitialPoseEstimate", "InitialPoseParams", "MapMatcher",
           "estimate_initial_pose", "gnss_pose_guess",
           "magnetometer_yaw", "scan_in_base", "surface_points"]


class InitialPoseParams(Params):
    """Georeference of the map and the search.  ``datum`` [lat, lon, alt]: origin of the
    ENU frame; ``map_from_enu`` [x, y, yaw]: pose of that ENU frame in ``map``;
    ``magnetic_declination`` [rad, east positive as WMM gives it]; ``magnetometer_yaw_offset``
    [rad] is added to the magnetometer heading (mounting calibration).  Search:
    +-``linear_search`` [m], +-``angular_search`` [rad] at ``coarse_angle_resolution``;
    the likelihood grid has ``resolution`` [m] and ``smear_deviation`` [m].  A match with
    a response below ``retry_response`` is searched again over +-``retry_linear_search``
    (a GNSS error beyond the first window: 25% of fixes for 2 m per axis); below
    ``min_response`` the guess is kept unrefined."""

    datum: tuple[float, float, float]
    map_from_enu: tuple[float, float, float] = (0.0, 0.0, 0.0)
    magnetic_declination: float = 0.0
    magnetometer_yaw_offset: float = 0.0
    heading_std: float = Field(default=math.radians(15.0), gt=0.0)
    linear_search: float = Field(default=3.0, gt=0.0)
    angular_search: float = Field(default=math.radians(20.0), gt=0.0)
    coarse_angle_resolution: float = Field(default=math.radians(1.0), gt=0.0)
    fine_angle_resolution: float = Field(default=math.radians(0.1), gt=0.0)
    resolution: float = Field(default=0.05, gt=0.0)
    smear_deviation: float = Field(default=0.1, gt=0.0)
    distance_variance_penalty: float = Field(default=20.0, gt=0.0)
    angle_variance_penalty: float = Field(default=2.0, gt=0.0)
    occupied_threshold: int = Field(default=65, ge=1, le=100)
    retry_response: float = Field(default=0.8, ge=0.0, le=1.0)
    retry_linear_search: float = Field(default=6.0, gt=0.0)
    icp_max_distance: float = Field(default=0.3, gt=0.0)
    min_response: float = Field(default=0.5, ge=0.0, le=1.0)
    max_input_age: float = Field(default=1.0, gt=0.0)


def magnetometer_yaw(field_msg: MagneticField, declination: float = 0.0,
                     offset: float = 0.0) -> float:
    """ENU yaw [rad] of the magnetometer frame from a level reading: magnetic north is at
    sensor angle ``atan2(b_y, b_x)`` and at ENU yaw ``pi/2 - declination``."""
    b = field_msg.magnetic_field
    if not (math.isfinite(b.x) and math.isfinite(b.y)) or math.hypot(b.x, b.y) == 0.0:
        raise InvalidMessage(f"magnetic field ({b.x}, {b.y}) has no usable horizontal "
                             "component; check the magnetometer")
    return normalize_angle(0.5 * math.pi - declination - math.atan2(b.y, b.x) + offset)


def gnss_pose_guess(fix: NavSatFix, heading_enu: float, params: InitialPoseParams,
                    antenna: tuple[float, float] = (0.0, 0.0)) -> Pose2D:
    """``base_link`` pose in ``map`` from a fix of the antenna at ``antenna`` (x, y in
    ``base_link``) and the ``base_link`` ENU heading."""
    reason = fix_rejection_reason(fix)
    if reason:
        raise InvalidMessage(f"GNSS fix unusable for the initial pose ({reason}); wait for "
                             "a fix with status >= STATUS_FIX and a known covariance")
    lat0, lon0, alt0 = params.datum
    e, n, _ = LocalCartesian(lat0, lon0, alt0).forward(fix.latitude, fix.longitude,
                                                       fix.altitude)
    c, s = math.cos(heading_enu), math.sin(heading_enu)
    base_enu = Pose2D(e - (c * antenna[0] - s * antenna[1]),
                      n - (s * antenna[0] + c * antenna[1]), normalize_angle(heading_enu))
    return Pose2D(*params.map_from_enu).compose(base_enu)


@dataclass
class InitialPoseEstimate:
    """The published pose, its covariance (3x3 x, y, yaw), the guess it started from and
    whether the scan match was accepted (``reason`` says why not)."""

    pose: Pose2D
    covariance: FloatArray
    guess: Pose2D
    response: float
    refined: bool
    reason: str = ""
    icp_points: int = 0

    def message(self, stamp: float, frame_id: str = "map") -> PoseWithCovarianceStamped:
        cov = np.zeros((6, 6))
        cov[np.ix_([0, 1, 5], [0, 1, 5])] = self.covariance
        cov[2, 2] = cov[3, 3] = cov[4, 4] = 1e6
        return PoseWithCovarianceStamped(Header(stamp, frame_id),
                                         PoseWithCovariance(self.pose.to_pose(), cov))


@dataclass
class MapMatcher:
    """The map prepared once for matching: likelihood grid + boundary points with normals."""

    grid: LikelihoodGrid
    points: FloatArray
    normals: FloatArray
    line_like: NDArray[np.bool_]
    params: InitialPoseParams
    window: SearchWindow = field(init=False)
    wide_window: SearchWindow = field(init=False)

    def __post_init__(self) -> None:
        p = self.params
        self.window = SearchWindow(
            dimension=2.0 * p.linear_search, coarse_angle_offset=p.angular_search,
            coarse_angle_resolution=p.coarse_angle_resolution,
            fine_angle_resolution=p.fine_angle_resolution,
            distance_variance_penalty=p.distance_variance_penalty,
            angle_variance_penalty=p.angle_variance_penalty,
            minimum_distance_penalty=0.5, minimum_angle_penalty=0.5)
        self.wide_window = replace(self.window, dimension=2.0 * p.retry_linear_search)

    @classmethod
    def from_grid(cls, grid: OccupancyGrid, params: InitialPoseParams) -> MapMatcher:
        """Surface points of the occupied cells of ``grid`` (see :func:`surface_points`)."""
        info = grid.info
        occ = np.asarray(grid.data) >= params.occupied_threshold
        local = surface_points(occ, info.resolution)
        if local.shape[0] < 10:
            raise InvalidMessage(f"map has only {local.shape[0]} occupied boundary cells "
                                 f"(value >= {params.occupied_threshold}); nothing to match "
                                 "a scan to")
        pts = info.origin.to_pose2d().transform_points(local)
        margin = max(params.linear_search, params.retry_linear_search) + 1.0
        lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
        lgrid = LikelihoodGrid(pts, params.resolution, params.smear_deviation,
                               (lo[0], lo[1], hi[0], hi[1]))
        normals, line_like = line_normals(pts)
        return cls(lgrid, pts, normals, line_like, params)

    def refine(self, scan_base: FloatArray, guess: Pose2D,
               guess_covariance: FloatArray | None = None) -> InitialPoseEstimate:
        """Match ``scan_base`` (N, 2) points in ``base_link`` around ``guess`` (map)."""
        p = self.params
        prior = (np.diag([4.0, 4.0, p.heading_std ** 2]) if guess_covariance is None
                 else np.asarray(guess_covariance, float))
        if scan_base.shape[0] < 10:
            return InitialPoseEstimate(guess, prior, guess, 0.0, False,
                                       f"scan has {scan_base.shape[0]} valid points (< 10)")
        result = match_scan(self.grid, scan_base, guess.as_array(), self.window)
        if result.response < p.retry_response:
            wide = match_scan(self.grid, scan_base, guess.as_array(), self.wide_window)
            if wide.response > result.response:
                result = wide
        if result.response < p.min_response:
            return InitialPoseEstimate(guess, prior, guess, result.response, False,
                                       f"scan match response {result.response:.3f} below "
                                       f"min_response {p.min_response}: keeping the GNSS guess")
        pose, used = refine_point_to_line(self.points, self.normals, self.line_like,
                                          scan_base, result.pose,
                                          max_distance=p.icp_max_distance, huber=0.05,
                                          iterations=15)
        moved = math.hypot(pose[0] - result.pose[0], pose[1] - result.pose[1])
        if used == 0 or moved > 2.0 * p.resolution:
            pose = result.pose  # ICP found too little or left the matched basin: keep it
        return InitialPoseEstimate(Pose2D.from_array(pose), result.covariance, guess,
                                   result.response, True, icp_points=used)


def surface_points(occupied: NDArray[np.bool_], resolution: float) -> FloatArray:
    """Points (N, 2) on the obstacle surfaces a lidar sees, in the grid frame [m].

    One point per boundary cell (occupied with a free 4-neighbour), moved from the cell
    centre half a cell towards each free neighbour: onto the face of a wall, onto the
    outer corner of a corner cell.  Cell centres would sit half a cell behind the faces
    the ray caster (and a real lidar) returns, and point-to-line ICP would pull the pose
    by that much towards whichever walls dominate the scan."""
    occ = np.asarray(occupied, dtype=bool)
    padded = np.pad(occ, 1, constant_values=True)
    free_e = ~padded[1:-1, 2:]
    free_w = ~padded[1:-1, :-2]
    free_n = ~padded[2:, 1:-1]
    free_s = ~padded[:-2, 1:-1]
    boundary = occ & (free_e | free_w | free_n | free_s)
    rows, cols = np.nonzero(boundary)
    dx = free_e[rows, cols].astype(float) - free_w[rows, cols]
    dy = free_n[rows, cols].astype(float) - free_s[rows, cols]
    return np.column_stack([(cols + 0.5 + 0.5 * dx) * resolution,
                            (rows + 0.5 + 0.5 * dy) * resolution])


def scan_in_base(scan: LaserScan, mount: Pose2D) -> FloatArray:
    """Valid scan end points (N, 2) in ``base_link`` for a lidar mounted at ``mount``."""
    return mount.transform_points(scan.points())


def estimate_initial_pose(matcher: MapMatcher, fix: NavSatFix, field_msg: MagneticField,
                          scan: LaserScan, lidar_mount: Pose2D,
                          antenna: tuple[float, float] = (0.0, 0.0),
                          magnetometer_mount_yaw: float = 0.0) -> InitialPoseEstimate:
    """The whole chain: GNSS + magnetometer guess, then scan-to-map refinement."""
    p = matcher.params
    yaw = magnetometer_yaw(field_msg, p.magnetic_declination,
                           p.magnetometer_yaw_offset) - magnetometer_mount_yaw
    guess = gnss_pose_guess(fix, yaw, p, antenna)
    cov = np.asarray(fix.position_covariance, float).reshape(3, 3)
    r = p.map_from_enu[2]
    c, s = math.cos(r), math.sin(r)
    rot = np.array([[c, -s], [s, c]])
    prior = np.zeros((3, 3))
    prior[:2, :2] = rot @ cov[:2, :2] @ rot.T
    prior[2, 2] = p.heading_std ** 2
    return matcher.refine(scan_in_base(scan, lidar_mount), guess, prior)
