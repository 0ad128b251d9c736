"""Robot profiles: drive kinematics, footprint and sensor suite of a (simulated) robot.

A profile is a YAML file (built-ins live in ``navstack/sim/robots/``)::

    name: turtlebot
    kinematics: {type: diff_drive, max_vel_x: 0.26, max_vel_theta: 1.82, ...}
    robot_radius: 0.22            # or footprint: "[[x, y], ...]" (Nav2 costmap_2d names)
    footprint_padding: 0.01
    sensors:
      lidar: {frame_id: base_scan, mount: {x: -0.064, z: 0.122}, rate_hz: 10, ...}
      odometry: {rate_hz: 30, linear_velocity_noise_std: 0.01, ...}
      imu: {enabled: false}
      ground_truth: {rate_hz: 50}
      gnss: {enabled: true, rate_hz: 5, horizontal_noise_std: 2.0}    # off by default
      magnetometer: {enabled: true, declination: 0.19}                # off by default
      georeference: {latitude: 38.4064, longitude: -110.7919}         # world on the Earth

Every key is validated on load: unknown keys, wrong types and out-of-range values raise
:class:`~navstack.core.errors.ConfigError` naming the file and the key path
(``robot.kinematics.max_vel_xx: unknown key (did you mean 'max_vel_x'?)``).

Sensor noise parameters default to an *ideal* sensor (no noise, no dropout); the
built-in profiles set realistic values explicitly.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import ConfigDict, Field, ValidationInfo, field_validator

from navstack.core.errors import ConfigError, UnknownNameError
from navstack.core.msgs import Pose2D
from navstack.core.params import Params
from navstack.core.polygon import Footprint, parse_footprint
from navstack.sim.kinematics import KinematicModel, KinematicsParams, make_model
from navstack.sim.robots import ROBOTS_DIR

_FINITE = ConfigDict(allow_inf_nan=False)
Vec3 = tuple[float, float, float]


class MountParams(Params):
    """Pose of a sensor frame in ``base_link`` (the URDF joint origin): x, y, z [m], yaw [rad]."""

    model_config = _FINITE

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0

    @property
    def pose2d(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)


class LidarParams(Params):
    """A planar scanning lidar (sensor_msgs/LaserScan semantics).

    ``beams`` rays from ``angle_min`` to ``angle_max`` (sensor frame, CCW).  For a full
    circle (span 2*pi) the last ray stops one increment short of ``angle_max`` so no
    direction is sampled twice.  ``noise_std``/``bias`` [m] perturb each range; the
    noise standard deviation grows with range as ``noise_std + noise_std_per_m * r`` (a
    triangulation lidar such as the LDS-01 is specified in percent of the range).
    ``dropout_prob`` loses single beams (reported as +inf, no return) and
    ``scan_dropout_prob`` whole scans (nothing published).
    """

    model_config = _FINITE

    enabled: bool = True
    topic: str = "scan"
    frame_id: str = "base_scan"
    mount: MountParams = Field(default_factory=MountParams)
    rate_hz: float = Field(default=10.0, gt=0.0)
    angle_min: float = Field(default=-math.pi, ge=-2.0 * math.pi, le=2.0 * math.pi)
    angle_max: float = Field(default=math.pi, ge=-2.0 * math.pi, le=2.0 * math.pi)
    beams: int = Field(default=360, ge=2)
    range_min: float = Field(default=0.12, ge=0.0)
    range_max: float = Field(default=12.0, gt=0.0)
    noise_std: float = Field(default=0.0, ge=0.0)
    noise_std_per_m: float = Field(default=0.0, ge=0.0)
    bias: float = 0.0
    dropout_prob: float = Field(default=0.0, ge=0.0, le=1.0)
    scan_dropout_prob: float = Field(default=0.0, ge=0.0, le=1.0)

    @field_validator("angle_max")
    @classmethod
    def _span(cls, value: float, info: ValidationInfo) -> float:
        lo = info.data.get("angle_min")
        if lo is not None and not 0.0 < value - lo <= 2.0 * math.pi + 1e-9:
            raise ValueError(f"angle_max - angle_min must be in (0, 2*pi], angle_min is {lo}")
        return value

    @field_validator("range_max")
    @classmethod
    def _ranges(cls, value: float, info: ValidationInfo) -> float:
        lo = info.data.get("range_min")
        if lo is not None and value <= lo:
            raise ValueError(f"range_max must be > range_min ({lo})")
        return value


class Lidar3dParams(Params):
    """A multi-ring (3-D) lidar, Velodyne VLP-16 class, as a ``sensor_msgs/PointCloud2``.

    ``rings`` beams fanned from ``elevation_min`` to ``elevation_max`` [rad] (VLP-16:
    16 rings, -15..+15 deg), ``azimuths`` columns over the full circle per revolution
    (VLP-16 at 10 Hz: 0.2 deg, 1800), ranges ``range_min``..``range_max`` with
    ``noise_std`` [m] along the beam.  The 2-D world is extruded: static cells are
    ``obstacle_height`` [m] tall, moving obstacles ``moving_obstacle_height``, and the
    ground is the plane z = 0 of ``base_link``.  Off unless a profile enables it; the
    cloud is published on ``topic`` in ``frame_id`` (organised: one row per ring).
    """

    model_config = _FINITE

    enabled: bool = False
    topic: str = "velodyne_points"
    frame_id: str = "velodyne"
    mount: MountParams = Field(default_factory=MountParams)
    rate_hz: float = Field(default=10.0, gt=0.0)
    rings: int = Field(default=16, ge=1, le=256)
    elevation_min: float = Field(default=-0.2617993877991494, ge=-1.5, le=1.5)
    elevation_max: float = Field(default=0.2617993877991494, ge=-1.5, le=1.5)
    azimuths: int = Field(default=1800, ge=8)
    range_min: float = Field(default=0.4, ge=0.0)
    range_max: float = Field(default=100.0, gt=0.0)
    noise_std: float = Field(default=0.0, ge=0.0)
    obstacle_height: float = Field(default=2.5, gt=0.0)
    moving_obstacle_height: float = Field(default=1.7, gt=0.0)


class OdometryParams(Params):
    """Wheel odometry (nav_msgs/Odometry in ``frame_id`` -> ``child_frame_id``).

    Noise std values are for the velocity averaged over one period ``1 / rate_hz``
    (what an encoder-differencing driver reports).  ``*_scale_error`` is the systematic
    calibration error (measured = (1 + e) * true; e.g. a wrong wheel radius or
    separation); ``slip_prob`` is the chance per period that the wheels slip and the
    motion of that period goes uncounted.  ``enable_odom_tf`` is ros2_control
    diff_drive_controller's name for publishing ``odom -> base_link``.
    """

    model_config = _FINITE

    enabled: bool = True
    topic: str = "odom"
    frame_id: str = "odom"
    child_frame_id: str = "base_link"
    rate_hz: float = Field(default=50.0, gt=0.0)
    enable_odom_tf: bool = True
    linear_velocity_noise_std: float = Field(default=0.0, ge=0.0)
    angular_velocity_noise_std: float = Field(default=0.0, ge=0.0)
    linear_scale_error: float = Field(default=0.0, gt=-1.0, lt=1.0)
    angular_scale_error: float = Field(default=0.0, gt=-1.0, lt=1.0)
    slip_prob: float = Field(default=0.0, ge=0.0, le=1.0)
    yaw_rate_source: Literal["wheels", "imu"] = "wheels"
    """``wheels``: the twist's yaw rate and the heading come from the wheels (a
    diff-drive controller's odometry).  ``imu``: from the IMU's gyro z, averaged over
    the IMU samples since the previous message, and the pose is dead-reckoned with it
    (``heading += w dt``, speed from the wheels) -- the golf cart's odometry, wheel
    pulses plus gyro (FIELD-ROBOTS.md), as its driver computes it from the sensor
    Arduino's lines.  Needs the IMU."""
    unsigned_speed: bool = False
    """The wheel sensor measures speed without direction (a pulse counter, as the golf
    cart's): the odometry's speed is the magnitude of the measured one, signed with the
    last non-zero commanded direction -- as the cart's driver signs it."""


class ImuParams(Params):
    """A 6-axis IMU with orientation output (sensor_msgs/Imu).

    ``gyro_bias`` [rad/s] and ``accel_bias`` [m/s^2] are constant (x, y, z) offsets in
    the IMU frame; noise std values are per sample.
    """

    model_config = _FINITE

    enabled: bool = True
    topic: str = "imu"
    frame_id: str = "imu_link"
    mount: MountParams = Field(default_factory=MountParams)
    rate_hz: float = Field(default=100.0, gt=0.0)
    orientation_noise_std: float = Field(default=0.0, ge=0.0)
    gyro_noise_std: float = Field(default=0.0, ge=0.0)
    gyro_bias: Vec3 = (0.0, 0.0, 0.0)
    accel_noise_std: float = Field(default=0.0, ge=0.0)
    accel_bias: Vec3 = (0.0, 0.0, 0.0)
    dropout_prob: float = Field(default=0.0, ge=0.0, le=1.0)


class CameraParams(Params):
    """A level forward pinhole camera (sensor_msgs/Image + CameraInfo).

    ``width`` x ``height`` pixels over ``horizontal_fov`` [rad] (square pixels: fx = fy =
    (width / 2) / tan(horizontal_fov / 2), principal point at the image centre), at
    ``rate_hz``, mounted at ``mount`` (``frame_id``, x forward; the image is in
    ``optical_frame_id``, default ``<frame_id>_optical``: z forward, x right, y down).
    ``distortion`` is plumb_bob (k1, k2, p1, p2, k3), applied to the rendered image.

    ``mode``: ``image`` renders grey images (``encoding`` mono8 or bgr8) on ``topic``;
    ``corners`` publishes only the projected corners of the visible markers plus
    ``corner_noise_std`` [px] Gaussian noise (fiducial_msgs/FiducialArray on
    ``corners_topic``), a cheap stand-in for image + detector in fast tests.  Corners mode
    reports markers up to ``max_range`` [m] whose sides are at least
    ``min_marker_pixels`` long; images show everything and leave it to the detector.
    ``pixel_noise_std`` [grey levels] is per-pixel Gaussian noise; ``oversample`` the
    supersampling factor of marker rendering (anti-aliasing, 1 = off);
    ``motion_blur`` smears the image by the rotation during ``exposure_time`` [s].
    """

    model_config = _FINITE

    enabled: bool = False
    topic: str = "camera/image_raw"
    info_topic: str = "camera/camera_info"
    corners_topic: str = "fiducial_vertices"
    frame_id: str = "camera_link"
    optical_frame_id: str = ""
    mount: MountParams = Field(default_factory=MountParams)
    rate_hz: float = Field(default=30.0, gt=0.0)
    width: int = Field(default=640, ge=16, le=4096)
    height: int = Field(default=480, ge=16, le=4096)
    horizontal_fov: float = Field(default=1.047, gt=0.0, lt=math.pi)
    max_range: float = Field(default=3.0, gt=0.0)
    mode: Literal["image", "corners"] = "image"
    encoding: Literal["mono8", "bgr8"] = "mono8"
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    pixel_noise_std: float = Field(default=0.0, ge=0.0, le=64.0)
    corner_noise_std: float = Field(default=0.0, ge=0.0)
    min_marker_pixels: float = Field(default=10.0, ge=0.0)
    oversample: int = Field(default=4, ge=1, le=8)
    motion_blur: bool = False
    exposure_time: float = Field(default=0.01, ge=0.0, le=1.0)

    @property
    def optical_frame(self) -> str:
        """The frame of the images (``optical_frame_id`` or ``<frame_id>_optical``)."""
        return self.optical_frame_id or f"{self.frame_id}_optical"


class GripperParams(Params):
    """A front gripper that lifts a package (TurtleBot course: a servo gripper with a
    magnet brace).  Closing attaches the package whose centre lies in the reach zone:
    ``reach_min`` .. ``reach_max`` [m] ahead of the footprint's front edge and within
    ``half_width`` [m] of the centre line; the package is then carried (lifted, not
    dragged) until the gripper opens.  ``close_time`` [s] is how long closing takes (the
    course's servo ramp: 20 steps of 0.1 s)."""

    model_config = _FINITE

    enabled: bool = False
    reach_min: float = Field(default=-0.02, ge=-0.5, le=1.0)
    reach_max: float = Field(default=0.12, gt=-0.5, le=1.0)
    half_width: float = Field(default=0.08, gt=0.0, le=1.0)
    close_time: float = Field(default=2.0, ge=0.0)


class GroundTruthParams(Params):
    """Exact pose and twist of ``base_link`` in the world frame (for evaluation)."""

    model_config = _FINITE

    enabled: bool = True
    topic: str = "ground_truth"
    frame_id: str = "map"
    child_frame_id: str = "base_link"
    rate_hz: float = Field(default=50.0, gt=0.0)


class GeoReferenceParams(Params):
    """Where the simulated world lies on the Earth, for the GNSS and the magnetometer.

    The world origin is at WGS84 ``latitude``/``longitude`` [deg] and ``altitude`` [m above
    the ellipsoid]; the world x axis points at ENU yaw ``world_yaw`` [rad] (0: x east,
    y north), so a world point (x, y) is at ENU ``R(world_yaw) (x, y)`` about that datum.
    The default is the Mars Desert Research Station, Utah (University Rover Challenge).
    """

    model_config = _FINITE

    latitude: float = Field(default=38.406415, ge=-90.0, le=90.0)
    longitude: float = Field(default=-110.791924, ge=-180.0, le=180.0)
    altitude: float = 1380.0
    world_yaw: float = 0.0


class GnssParams(Params):
    """A GNSS receiver (sensor_msgs/NavSatFix on ``topic``, ENU velocity on
    ``velocity_topic`` as geometry_msgs/TwistWithCovarianceStamped, as the ublox driver's
    ``fix_velocity``).

    The antenna sits at ``mount``.  Position error per axis (east and north) is white
    noise of ``horizontal_noise_std`` [m] plus a first-order Gauss-Markov bias of
    stationary std ``bias_std`` [m] and correlation time ``bias_time_constant`` [s] (the
    slowly wandering error of an uncorrected receiver); ``vertical_noise_std`` [m] for
    the altitude.  ``velocity_noise_std`` [m/s] per axis on the Doppler velocity (speed
    and course over ground).  During each ``outages`` interval ``[start, end)`` of
    simulation time the receiver reports ``STATUS_NO_FIX`` with NaN position and no
    velocity.  Unlike the other sensors the default noise is not zero: a GNSS without
    error is not a useful default (2 m per axis is a typical single-band receiver).
    """

    model_config = _FINITE

    enabled: bool = False
    topic: str = "gps/fix"
    velocity_topic: str = "gps/vel"
    frame_id: str = "gps_link"
    mount: MountParams = Field(default_factory=MountParams)
    rate_hz: float = Field(default=5.0, gt=0.0)
    horizontal_noise_std: float = Field(default=2.0, ge=0.0)
    vertical_noise_std: float = Field(default=3.0, ge=0.0)
    bias_std: float = Field(default=0.0, ge=0.0)
    bias_time_constant: float = Field(default=60.0, gt=0.0)
    velocity_noise_std: float = Field(default=0.05, ge=0.0)
    outages: tuple[tuple[float, float], ...] = ()

    @field_validator("outages")
    @classmethod
    def _intervals(cls, value: tuple[tuple[float, float], ...]
                   ) -> tuple[tuple[float, float], ...]:
        for start, end in value:
            if not end > start:
                raise ValueError(f"each outage is [start, end) with end > start, got "
                                 f"[{start}, {end}]")
        return value


class MagnetometerParams(Params):
    """A 3-axis magnetometer (sensor_msgs/MagneticField [T] in ``frame_id``).

    The Earth's field has ``horizontal_intensity`` [T] towards magnetic north, which lies
    ``declination`` [rad] east of true north (the sign WMM/NOAA use), and
    ``vertical_intensity`` [T] downwards (positive in the northern hemisphere).
    ``heading_offset`` [rad] rotates the measured field as an uncalibrated mounting or
    soft-iron error would (the sensor reads as if yawed by it); ``hard_iron`` [T] is a
    constant offset in the sensor frame and ``noise_std`` [T] white noise per axis.
    """

    model_config = _FINITE

    enabled: bool = False
    topic: str = "imu/mag"
    frame_id: str = "mag_link"
    mount: MountParams = Field(default_factory=MountParams)
    rate_hz: float = Field(default=20.0, gt=0.0)
    declination: float = Field(default=0.0, ge=-math.pi, le=math.pi)
    horizontal_intensity: float = Field(default=2.2e-5, gt=0.0)
    vertical_intensity: float = 4.4e-5
    heading_offset: float = Field(default=0.0, ge=-math.pi, le=math.pi)
    hard_iron: Vec3 = (0.0, 0.0, 0.0)
    noise_std: float = Field(default=0.0, ge=0.0)


class SensorsParams(Params):
    """The robot's sensor suite; each sensor can be switched off with ``enabled: false``.

    ``gnss``, ``magnetometer`` and ``camera`` are off unless a profile enables them;
    ``georeference`` places the world on the Earth for both.
    """

    lidar: LidarParams = Field(default_factory=LidarParams)
    lidar3d: Lidar3dParams = Field(default_factory=Lidar3dParams)
    odometry: OdometryParams = Field(default_factory=OdometryParams)
    imu: ImuParams = Field(default_factory=ImuParams)
    camera: CameraParams = Field(default_factory=CameraParams)
    ground_truth: GroundTruthParams = Field(default_factory=GroundTruthParams)
    gnss: GnssParams = Field(default_factory=GnssParams)
    magnetometer: MagnetometerParams = Field(default_factory=MagnetometerParams)
    georeference: GeoReferenceParams = Field(default_factory=GeoReferenceParams)


Polygon2 = tuple[tuple[float, float], ...]


class RobotParams(Params):
    """A robot profile.  Footprint names and defaults follow Nav2 costmap_2d
    (``footprint`` "[]" -> use ``robot_radius`` 0.1; ``footprint_padding`` 0.01).
    """

    model_config = _FINITE

    name: str = ""
    description: str = ""
    base_frame_id: str = "base_link"
    kinematics: KinematicsParams = Field(default_factory=KinematicsParams)
    footprint: Polygon2 | None = None
    robot_radius: float = Field(default=0.1, gt=0.0)
    footprint_padding: float = Field(default=0.01, ge=0.0)
    sensors: SensorsParams = Field(default_factory=SensorsParams)
    gripper: GripperParams = Field(default_factory=GripperParams)

    @field_validator("footprint", mode="before")
    @classmethod
    def _parse_footprint(cls, value: Any) -> Any:
        if value is None or (isinstance(value, str) and value.strip() in ("", "[]")):
            return None
        if isinstance(value, str):
            pts = parse_footprint(value)
        else:
            if isinstance(value, list | tuple) and len(value) == 0:
                return None
            pts = np.asarray(value, dtype=np.float64)
            if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
                raise ValueError(f"footprint needs at least 3 [x, y] points, got {value!r}")
        return tuple((float(x), float(y)) for x, y in pts)

    def footprint_model(self) -> Footprint:
        """The padded footprint: the polygon if given, else a circle of ``robot_radius``."""
        if self.footprint is not None:
            return Footprint.from_polygon(np.asarray(self.footprint, dtype=np.float64),
                                          self.footprint_padding)
        return Footprint.from_radius(self.robot_radius, self.footprint_padding)

    def kinematic_model(self) -> KinematicModel:
        """The drive model built from ``kinematics``."""
        return make_model(self.kinematics)


# --- loading ------------------------------------------------------------------------------
def list_robots() -> list[str]:
    """Names of the built-in robot profiles."""
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.yaml"))


def _deep_merge(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _deep_merge(out[key], value)
        else:
            out[key] = value
    return out


def _resolve(name_or_path: str | Path) -> Path:
    text = str(name_or_path)
    is_path = (isinstance(name_or_path, Path) or "/" in text or "\\" in text
               or text.endswith((".yaml", ".yml")))
    if is_path:
        path = Path(name_or_path)
        if not path.is_file():
            raise ConfigError("robot profile file not found; pass a built-in name "
                              f"({', '.join(list_robots())}) or an existing YAML file",
                              file=str(path))
        return path
    known = list_robots()
    if text not in known:
        raise UnknownNameError("robot", text, known)
    return ROBOTS_DIR / f"{text}.yaml"


def robot_from_mapping(data: Mapping[str, Any], *, file: str = "",
                       key_path: str = "robot") -> RobotParams:
    """Validate an inline robot profile (e.g. the ``robot:`` section of a stack YAML)."""
    return RobotParams.from_mapping(data, file=file, key_path=key_path)


def load_robot(name_or_path: str | Path,
               overrides: Mapping[str, Any] | None = None) -> RobotParams:
    """Load a built-in profile by name (see :func:`list_robots`) or a YAML file by path.

    ``overrides`` is deep-merged into the file's mapping before validation (e.g.
    ``{"sensors": {"lidar": {"noise_std": 0.0}}}``).  A profile without ``name`` is
    named after its file.  Raises ``UnknownNameError`` for an unknown built-in name
    and ``ConfigError`` for a missing/unreadable file or invalid keys.
    """
    path = _resolve(name_or_path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read robot profile: {exc}", file=str(path)) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"invalid YAML: {exc}", file=str(path)) from None
    if data is None or data == {}:
        raise ConfigError("empty robot profile", file=str(path), suggestion=(
            "give at least 'kinematics' and 'footprint' or 'robot_radius' (see the built-in "
            "profiles: navstack robots)"))
    if not isinstance(data, Mapping):
        raise ConfigError(f"a robot profile must be a mapping of keys, got "
                          f"{type(data).__name__}", file=str(path), key_path="robot")
    if overrides:
        data = _deep_merge(data, overrides)
    data = {"name": path.stem, **data}
    return robot_from_mapping(data, file=str(path))
