"""GNSS fixes into the robot's world frame: robot_localization's ``navsat_transform_node``.

The semantics follow robot_localization (``navsat_transform.cpp``, ROS 2):

1. **Datum.**  The first usable fix, the robot's world pose from ``/odometry/filtered`` at
   that moment and its heading from ``/imu`` (or from the odometry with
   ``use_odometry_yaw``) fix the transform between the Cartesian frame (UTM, or a local
   ENU frame with ``use_local_cartesian``) and the world frame.  With ``wait_for_datum``
   the ``datum`` parameter ``[lat, lon, yaw]`` is used instead: the world origin sits at
   (lat, lon) with its x axis at ENU yaw ``yaw`` (robot_localization's SetDatum).
2. **Heading.**  ``yaw_cartesian = imu_yaw + magnetic_declination_radians + yaw_offset +
   meridian_convergence`` -- the declination is *added* as robot_localization does
   (issue #374 on its sign); the UTM meridian convergence is 0 for a local frame.  The
   IMU yaw is corrected for the IMU's mounting yaw on ``base_link`` through TF.
3. **Antenna offset.**  The fix is of the antenna (the fix's ``header.frame_id``); the
   ``base_link -> antenna`` offset from TF, rotated by the heading, is removed both when
   the datum is taken and from every output.
4. **Outputs** at ``frequency``: ``/odometry/gps`` (nav_msgs/Odometry of ``base_link`` in
   the world frame, position covariance = the fix covariance rotated into the world
   frame, orientation unobserved) and, with ``publish_filtered_gps``, ``/gps/filtered``
   (NavSatFix of the filtered odometry's position, covariance rotated back).  With
   ``broadcast_cartesian_transform`` the world <-> ``utm`` / ``local_enu`` transform is
   sent on ``/tf_static`` (as the parent of the world frame with
   ``broadcast_cartesian_transform_as_parent_frame``; z zeroed with ``zero_altitude``).

Differences, on purpose: fixes with ``STATUS_NO_FIX``, a NaN or infinite coordinate, or
``COVARIANCE_TYPE_UNKNOWN`` are rejected *and counted with a reason*
(:attr:`NavsatTransform.rejections`); a robot_localization user wiring a receiver that
reports no covariance gets a clear count instead of a filter fed zero variance.  All
later fixes are projected into the datum's UTM zone (robot_localization's ``setUTMZone``
behaviour), so a route across a zone boundary stays continuous.

:class:`NavsatTransform` is the pure computation; the node on the bus (subscriptions, TF
lookups of the sensor mounts, the ``frequency`` timer) is
:class:`~navstack.nodes.navsat.NavsatTransformNode`.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from navstack.core.errors import TransformError
from navstack.core.geometry import normalize_angle
from navstack.core.msgs import (
    Header,
    NavSatFix,
    NavSatStatus,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    Transform,
    TransformStamped,
    TwistWithCovariance,
    Vector3,
)
from navstack.core.params import Params
from navstack.geo.conversions import LocalCartesian, geodetic_to_utm, utm_forward, utm_to_geodetic

__all__ = ["CartesianTransform", "NavsatTransform", "NavsatTransformParams",
           "fix_rejection_reason"]

UNOBSERVED_VARIANCE = 1e6
"""Variance put on the orientation of ``/odometry/gps`` (a fix says nothing about it)."""
STATUS_GBAS_FIX = 2
"""sensor_msgs/NavSatStatus value robot_localization gives ``/gps/filtered``."""
COVARIANCE_TYPE_KNOWN = 3
"""sensor_msgs/NavSatFix full covariance known."""
FloatArray = NDArray[np.float64]


class NavsatTransformParams(Params):
    """robot_localization ``navsat_transform_node`` parameters (names and defaults)."""

    frequency: float = Field(default=10.0, gt=0.0)
    delay: float = Field(default=0.0, ge=0.0)
    transform_timeout: float = Field(default=0.0, ge=0.0)
    magnetic_declination_radians: float = 0.0
    yaw_offset: float = 0.0
    zero_altitude: bool = False
    publish_filtered_gps: bool = True
    use_odometry_yaw: bool = False
    wait_for_datum: bool = False
    datum: tuple[float, float, float] | None = None
    use_local_cartesian: bool = False
    broadcast_cartesian_transform: bool = False
    broadcast_cartesian_transform_as_parent_frame: bool = False

    @model_validator(mode="after")
    def _datum_given(self) -> NavsatTransformParams:
        if self.wait_for_datum and self.datum is None:
            raise ValueError("wait_for_datum is true but datum is not set; give "
                             "datum: [latitude_deg, longitude_deg, yaw_rad]")
        if self.datum is not None and not -90.0 <= self.datum[0] <= 90.0:
            raise ValueError(f"datum latitude {self.datum[0]} is outside [-90, 90]; the order "
                             "is [latitude, longitude, yaw]")
        return self


def fix_rejection_reason(fix: NavSatFix) -> str:
    """Why ``fix`` cannot be used ("" if it can): no fix, non-finite, unknown covariance."""
    if fix.status.status == NavSatStatus.STATUS_NO_FIX:
        return "no_fix"
    if not (math.isfinite(fix.latitude) and math.isfinite(fix.longitude)
            and math.isfinite(fix.altitude)):
        return "non_finite"
    if fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN:
        return "unknown_covariance"
    cov = np.asarray(fix.position_covariance, dtype=np.float64)
    if cov.size != 9 or not np.all(np.isfinite(cov)):
        return "bad_covariance"
    return ""


_REASON_TEXT = {
    "no_fix": "status is STATUS_NO_FIX",
    "non_finite": "latitude, longitude or altitude is NaN or infinite",
    "unknown_covariance": ("position_covariance_type is COVARIANCE_TYPE_UNKNOWN; configure "
                           "the receiver driver to report its covariance"),
    "bad_covariance": "position_covariance is not a finite 3x3 matrix",
}


@dataclass(frozen=True)
class CartesianTransform:
    """``world <- cartesian``: ``p_world = R(yaw) p_cart[:2] + (x, y)``, ``z_w = z_c + z``."""

    x: float
    y: float
    z: float
    yaw: float

    def to_world(self, cx: float, cy: float, cz: float) -> tuple[float, float, float]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return self.x + c * cx - s * cy, self.y + s * cx + c * cy, cz + self.z

    def to_cartesian(self, wx: float, wy: float, wz: float) -> tuple[float, float, float]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = wx - self.x, wy - self.y
        return c * dx + s * dy, -s * dx + c * dy, wz - self.z


def _rotate_position_covariance(cov3: FloatArray, yaw: float) -> FloatArray:
    c, s = math.cos(yaw), math.sin(yaw)
    r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return r @ cov3 @ r.T


class NavsatTransform:
    """The pure core of the node: feed it fixes, headings and odometry; ask for outputs.

    ``antenna`` arguments are the ``base_link -> antenna`` offset (x, y, z) [m].
    """

    def __init__(self, params: NavsatTransformParams | None = None) -> None:
        self.params = params or NavsatTransformParams()
        self.rejections: Counter[str] = Counter()
        self.last_rejection = ""
        self.transform: CartesianTransform | None = None
        self.world_frame_id = "odom"
        self.base_link_frame_id = "base_link"
        self._datum_fix: tuple[float, float, float] | None = None  # lat, lon, alt
        self._datum_cart: tuple[float, float, float] | None = None
        self._datum_antenna = (0.0, 0.0, 0.0)
        self._zone, self._northp = 0, True
        self._local: LocalCartesian | None = None
        self.convergence = 0.0
        self._yaw: float | None = None
        self._odom_at_datum: tuple[float, float, float, float] | None = None  # x, y, z, yaw
        self.latest_cart: tuple[float, float, float] | None = None
        self.latest_fix_cov = np.zeros((3, 3))
        self.latest_fix_stamp = 0.0
        self.latest_antenna = (0.0, 0.0, 0.0)
        self.latest_odom: Odometry | None = None
        self._gps_updated = self._odom_updated = False
        self.manual_datum = False
        if self.params.wait_for_datum and self.params.datum is not None:
            lat, lon, yaw = self.params.datum
            self.set_datum(lat, lon, yaw)

    # --- inputs ------------------------------------------------------------------------
    @property
    def transform_good(self) -> bool:
        return self.transform is not None

    def _cartesian(self, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
        if self._local is not None:
            return self._local.forward(lat, lon, alt)
        e, n, _, _ = utm_forward(lat, lon, self._zone, self._northp)
        return e, n, alt

    def _set_datum_fix(self, lat: float, lon: float, alt: float) -> None:
        self._datum_fix = (lat, lon, alt)
        if self.params.use_local_cartesian:
            self._local = LocalCartesian(lat, lon, 0.0)  # as robot_localization: h0 = 0
            self.convergence = 0.0
        else:
            u = geodetic_to_utm(lat, lon)
            self._zone, self._northp, self.convergence = u.zone, u.northp, u.convergence
        self._datum_cart = self._cartesian(lat, lon, alt)

    def set_datum(self, latitude: float, longitude: float, yaw: float,
                  altitude: float = 0.0) -> None:
        """robot_localization's SetDatum: the world origin is at (latitude, longitude) and
        the world x axis has heading ``yaw`` (treated like an IMU yaw: declination, offset
        and convergence are added).  Recomputes the transform."""
        self.manual_datum = True
        self.transform = None
        self._set_datum_fix(latitude, longitude, altitude)
        self._datum_antenna = (0.0, 0.0, 0.0)
        self._odom_at_datum = (0.0, 0.0, 0.0, 0.0)
        self._yaw = yaw
        self.compute_transform()

    def add_fix(self, fix: NavSatFix, antenna: tuple[float, float, float] = (0.0, 0.0, 0.0)
                ) -> bool:
        """Take a fix; returns False (and counts the reason) if it is unusable."""
        reason = fix_rejection_reason(fix)
        if reason:
            self.rejections[reason] += 1
            self.last_rejection = (f"rejected fix at t={fix.header.stamp:.3f} s: "
                                   f"{_REASON_TEXT[reason]}")
            return False
        if not self.transform_good and not self.manual_datum:  # newest fix until computed
            self._set_datum_fix(fix.latitude, fix.longitude, fix.altitude)
            self._datum_antenna = antenna
        self.latest_cart = self._cartesian(fix.latitude, fix.longitude, fix.altitude)
        self.latest_fix_cov = np.asarray(fix.position_covariance,
                                         dtype=np.float64).reshape(3, 3).copy()
        self.latest_fix_stamp = fix.header.stamp
        self.latest_antenna = antenna
        self._gps_updated = True
        return True

    def add_heading(self, yaw: float) -> None:
        """The ``base_link`` yaw from the IMU (ENU, mounting already removed).  Only used
        until the transform is computed, as in robot_localization."""
        if not self.transform_good and not self.manual_datum:
            self._yaw = float(yaw)

    def add_odometry(self, odom: Odometry) -> None:
        """The robot's pose in the world frame (``/odometry/filtered``)."""
        self.world_frame_id = odom.header.frame_id or self.world_frame_id
        self.base_link_frame_id = odom.child_frame_id or self.base_link_frame_id
        p = odom.pose.pose
        if not self.transform_good and not self.manual_datum:
            self._odom_at_datum = (p.position.x, p.position.y, p.position.z,
                                   p.orientation.yaw)
            if self.params.use_odometry_yaw:
                self._yaw = p.orientation.yaw
        self.latest_odom = odom
        self._odom_updated = True

    def compute_transform(self) -> bool:
        """Fix the world <- cartesian transform once a fix, a heading and odometry are in."""
        if self.transform is not None:
            return True
        if self._datum_cart is None or self._yaw is None or self._odom_at_datum is None:
            return False
        p = self.params
        heading = normalize_angle(self._yaw + p.magnetic_declination_radians + p.yaw_offset
                                  + self.convergence)
        cx, cy, cz = self._datum_cart
        ax, ay, az = self._datum_antenna
        c, s = math.cos(heading), math.sin(heading)
        cx, cy, cz = cx - (c * ax - s * ay), cy - (s * ax + c * ay), cz - az  # robot origin
        wx, wy, wz, wyaw = self._odom_at_datum
        yaw = normalize_angle(wyaw - heading)
        cr, sr = math.cos(yaw), math.sin(yaw)
        self.transform = CartesianTransform(wx - (cr * cx - sr * cy), wy - (sr * cx + cr * cy),
                                            wz - cz, yaw)
        return True

    # --- outputs -----------------------------------------------------------------------
    def world_from_ll(self, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
        """World-frame point of a geodetic point (robot_localization's ``fromLL``)."""
        if self.transform is None:
            raise TransformError("navsat transform not computed yet: it needs a fix, a "
                                 "heading and odometry (or a datum)")
        return self.transform.to_world(*self._cartesian(lat, lon, alt))

    def ll_from_world(self, x: float, y: float, z: float) -> tuple[float, float, float]:
        """Geodetic point of a world-frame point (robot_localization's ``toLL``)."""
        if self.transform is None:
            raise TransformError("navsat transform not computed yet: it needs a fix, a "
                                 "heading and odometry (or a datum)")
        cx, cy, cz = self.transform.to_cartesian(x, y, z)
        if self._local is not None:
            return self._local.reverse(cx, cy, cz)
        lat, lon = utm_to_geodetic(cx, cy, self._zone, self._northp)
        return lat, lon, cz

    def gps_odometry(self, robot_yaw: float | None = None) -> Odometry | None:
        """``/odometry/gps`` for the newest fix not yet reported (needs new odometry too,
        as robot_localization does); ``robot_yaw`` (world) rotates the antenna offset,
        default the latest odometry's yaw."""
        if self.transform is None or not (self._gps_updated and self._odom_updated):
            return None
        assert self.latest_cart is not None and self.latest_odom is not None
        x, y, z = self.transform.to_world(*self.latest_cart)
        yaw = self.latest_odom.pose.pose.orientation.yaw if robot_yaw is None else robot_yaw
        ax, ay, az = self.latest_antenna
        c, s = math.cos(yaw), math.sin(yaw)
        x, y, z = x - (c * ax - s * ay), y - (s * ax + c * ay), z - az
        if self.params.zero_altitude:
            z = 0.0
        cov = np.zeros((6, 6))
        cov[:3, :3] = _rotate_position_covariance(self.latest_fix_cov, self.transform.yaw)
        cov[3, 3] = cov[4, 4] = cov[5, 5] = UNOBSERVED_VARIANCE
        self._gps_updated = False
        return Odometry(Header(self.latest_fix_stamp, self.world_frame_id),
                        self.base_link_frame_id,
                        PoseWithCovariance(Pose(Point(x, y, z), Quaternion()), cov),
                        TwistWithCovariance())

    def filtered_gps(self) -> NavSatFix | None:
        """``/gps/filtered``: the latest odometry position as a fix (once per odometry)."""
        if self.transform is None or not self._odom_updated or self.latest_odom is None:
            return None
        odom = self.latest_odom
        pos = odom.pose.pose.position
        lat, lon, alt = self.ll_from_world(pos.x, pos.y, pos.z)
        cov = _rotate_position_covariance(
            np.asarray(odom.pose.covariance, dtype=np.float64)[:3, :3], -self.transform.yaw)
        self._odom_updated = False
        return NavSatFix(Header(odom.header.stamp, self.base_link_frame_id),
                         NavSatStatus(STATUS_GBAS_FIX, 1), lat, lon, alt, cov,
                         COVARIANCE_TYPE_KNOWN)

    def cartesian_transform_message(self, stamp: float) -> TransformStamped | None:
        """The world <-> ``utm``/``local_enu`` transform to broadcast (None until known)."""
        if self.transform is None:
            return None
        t = self.transform
        frame = "local_enu" if self.params.use_local_cartesian else "utm"
        z = 0.0 if self.params.zero_altitude else t.z
        if self.params.broadcast_cartesian_transform_as_parent_frame:
            cx, cy, cz = t.to_cartesian(0.0, 0.0, 0.0)
            return TransformStamped(Header(stamp, frame), self.world_frame_id, Transform(
                Vector3(cx, cy, 0.0 if self.params.zero_altitude else cz),
                Quaternion.from_yaw(-t.yaw)))
        return TransformStamped(Header(stamp, self.world_frame_id), frame,
                                Transform(Vector3(t.x, t.y, z), Quaternion.from_yaw(t.yaw)))
