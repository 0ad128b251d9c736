"""sensor_msgs and nav_msgs equivalents used by sensors, mapping and navigation."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs.geometry_msgs import (
    Point,
    Pose,
    PoseStamped,
    PoseWithCovariance,
    Quaternion,
    TransformStamped,
    TwistWithCovariance,
    Vector3,
)
from navstack.core.msgs.std import Header


def _empty_f32() -> NDArray[np.float32]:
    return np.zeros(0, dtype=np.float32)


def _zeros3x3() -> NDArray[np.float64]:
    return np.zeros((3, 3))


@dataclass(frozen=True, slots=True, eq=False)
class LaserScan:
    """sensor_msgs/LaserScan.  ``ranges`` float32 [m]; ``inf`` means no return.

    Beam ``i`` points at ``angle_min + i * angle_increment`` in ``header.frame_id``.
    """

    header: Header = field(default_factory=Header)
    angle_min: float = 0.0
    angle_max: float = 0.0
    angle_increment: float = 0.0
    time_increment: float = 0.0
    scan_time: float = 0.0
    range_min: float = 0.0
    range_max: float = 0.0
    ranges: NDArray[np.float32] = field(default_factory=_empty_f32)
    intensities: NDArray[np.float32] = field(default_factory=_empty_f32)

    def angles(self) -> NDArray[np.float64]:
        """Beam angles [rad], one per range."""
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges),
                                                                 dtype=np.float64)

    def points(self) -> NDArray[np.float64]:
        """``(M, 2)`` end points of the valid returns in the scan frame."""
        r = np.asarray(self.ranges, dtype=np.float64)
        a = self.angles()
        ok = np.isfinite(r) & (r >= self.range_min) & (r <= self.range_max)
        return np.column_stack((r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])))


@dataclass(frozen=True, slots=True, eq=False)
class PointCloud:
    """PointCloud2 equivalent: ``xyz`` float32 array of shape (N, 3) in the header frame."""

    header: Header = field(default_factory=Header)
    xyz: NDArray[np.float32] = field(default_factory=lambda: np.zeros((0, 3), np.float32))


@dataclass(frozen=True, slots=True)
class PointField:
    """sensor_msgs/PointField: one named field of a point (``datatype`` constants below)."""

    INT8 = 1
    UINT8 = 2
    INT16 = 3
    UINT16 = 4
    INT32 = 5
    UINT32 = 6
    FLOAT32 = 7
    FLOAT64 = 8
    name: str = ""
    offset: int = 0
    datatype: int = 7
    count: int = 1


_POINTFIELD_DTYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}


@dataclass(frozen=True, slots=True, eq=False)
class PointCloud2:
    """sensor_msgs/PointCloud2: ``height`` x ``width`` points of ``point_step`` bytes in
    ``data`` (uint8), laid out by ``fields``.  An organised cloud from a multi-ring lidar
    has ``height`` = rings and ``width`` = points per ring.

    :meth:`from_fields` builds one from numpy columns; :meth:`field` reads a column back.
    """

    header: Header = field(default_factory=Header)
    height: int = 1
    width: int = 0
    fields: tuple[PointField, ...] = ()
    is_bigendian: bool = False
    point_step: int = 0
    row_step: int = 0
    data: NDArray[np.uint8] = field(default_factory=lambda: np.zeros(0, np.uint8))
    is_dense: bool = False

    @staticmethod
    def from_fields(header: Header, columns: dict[str, NDArray[np.generic]],
                    height: int = 1) -> PointCloud2:
        """A little-endian cloud with one field per column (all columns of equal length;
        float32, float64, uint16, ... kept as given), ``height`` rows."""
        names = list(columns)
        arrays = [np.ascontiguousarray(columns[n]).reshape(-1) for n in names]
        n = len(arrays[0]) if arrays else 0
        if any(len(a) != n for a in arrays):
            raise ValueError("PointCloud2.from_fields: columns differ in length")
        if height < 1 or n % height:
            raise ValueError(f"PointCloud2.from_fields: {n} points do not fill {height} rows")
        by_dtype = {v: k for k, v in _POINTFIELD_DTYPES.items()}
        fields, offset, formats = [], 0, []
        for name, arr in zip(names, arrays, strict=True):
            code = arr.dtype.newbyteorder("<").str[1:]
            if code not in by_dtype:
                raise ValueError(f"PointCloud2.from_fields: unsupported dtype {arr.dtype} "
                                 f"for field {name!r}")
            fields.append(PointField(name, offset, by_dtype[code], 1))
            formats.append("<" + code)
            offset += arr.dtype.itemsize
        rec = np.zeros(n, dtype=np.dtype({"names": names, "formats": formats}))
        for name, arr in zip(names, arrays, strict=True):
            rec[name] = arr
        xyz = [columns[c] for c in ("x", "y", "z") if c in columns]
        dense = bool(all(np.isfinite(np.asarray(c, dtype=np.float64)).all() for c in xyz))
        return PointCloud2(header, height, n // height, tuple(fields), False, offset,
                           offset * (n // height), rec.view(np.uint8).reshape(-1), dense)

    def field(self, name: str) -> NDArray[np.generic]:
        """Column ``name`` as a flat numpy array (a copy)."""
        f = next((f for f in self.fields if f.name == name), None)
        if f is None:
            raise KeyError(f"PointCloud2 has no field {name!r}; fields: "
                           f"{', '.join(x.name for x in self.fields)}")
        dtype = np.dtype(("<" if not self.is_bigendian else ">") + _POINTFIELD_DTYPES[f.datatype])
        view = np.ndarray((self.height * self.width,), dtype=dtype,
                          buffer=np.ascontiguousarray(self.data).tobytes(), offset=f.offset,
                          strides=(self.point_step,))
        return view.copy()

    def xyz(self) -> NDArray[np.float64]:
        """``(N, 3)`` float64 points."""
        return np.column_stack([self.field(c).astype(np.float64) for c in "xyz"])


@dataclass(frozen=True, slots=True, eq=False)
class JointState:
    """sensor_msgs/JointState: per joint ``position`` [rad], ``velocity`` [rad/s]."""

    header: Header = field(default_factory=Header)
    name: tuple[str, ...] = ()
    position: tuple[float, ...] = ()
    velocity: tuple[float, ...] = ()
    effort: tuple[float, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class Imu:
    """sensor_msgs/Imu.  A covariance with element [0, 0] == -1 means "not provided"."""

    header: Header = field(default_factory=Header)
    orientation: Quaternion = field(default_factory=Quaternion)
    orientation_covariance: NDArray[np.float64] = field(default_factory=_zeros3x3)
    angular_velocity: Vector3 = field(default_factory=Vector3)
    angular_velocity_covariance: NDArray[np.float64] = field(default_factory=_zeros3x3)
    linear_acceleration: Vector3 = field(default_factory=Vector3)
    linear_acceleration_covariance: NDArray[np.float64] = field(default_factory=_zeros3x3)


@dataclass(frozen=True, slots=True, eq=False)
class MagneticField:
    """sensor_msgs/MagneticField [tesla], in ``header.frame_id``."""

    header: Header = field(default_factory=Header)
    magnetic_field: Vector3 = field(default_factory=Vector3)
    magnetic_field_covariance: NDArray[np.float64] = field(default_factory=_zeros3x3)


@dataclass(frozen=True, slots=True)
class NavSatStatus:
    """sensor_msgs/NavSatStatus: ``status`` -1 no fix, 0 fix, 1 SBAS, 2 GBAS."""

    STATUS_NO_FIX = -1
    STATUS_FIX = 0
    STATUS_SBAS_FIX = 1
    STATUS_GBAS_FIX = 2
    SERVICE_GPS = 1
    status: int = 0
    service: int = 1


@dataclass(frozen=True, slots=True, eq=False)
class NavSatFix:
    """sensor_msgs/NavSatFix: WGS84 degrees and metres above the ellipsoid."""

    COVARIANCE_TYPE_UNKNOWN = 0
    COVARIANCE_TYPE_APPROXIMATED = 1
    COVARIANCE_TYPE_DIAGONAL_KNOWN = 2
    COVARIANCE_TYPE_KNOWN = 3
    header: Header = field(default_factory=Header)
    status: NavSatStatus = field(default_factory=NavSatStatus)
    latitude: float = 0.0
    longitude: float = 0.0
    altitude: float = 0.0
    position_covariance: NDArray[np.float64] = field(default_factory=_zeros3x3)
    position_covariance_type: int = 0


@dataclass(frozen=True, slots=True, eq=False)
class Odometry:
    """nav_msgs/Odometry: pose in ``header.frame_id``, twist in ``child_frame_id``."""

    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass(frozen=True, slots=True)
class MapMetaData:
    """nav_msgs/MapMetaData: ``origin`` is the pose of cell (0, 0)'s outer corner."""

    map_load_time: float = 0.0
    resolution: float = 0.05
    width: int = 0
    height: int = 0
    origin: Pose = field(default_factory=Pose)


@dataclass(frozen=True, slots=True, eq=False)
class OccupancyGrid:
    """nav_msgs/OccupancyGrid.  ``data`` is int8 of shape (height, width), row 0 at the
    map origin (lowest y), values 0..100 occupancy probability and -1 unknown.
    """

    header: Header = field(default_factory=Header)
    info: MapMetaData = field(default_factory=MapMetaData)
    data: NDArray[np.int8] = field(default_factory=lambda: np.zeros((0, 0), np.int8))

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell containing map-frame point (x, y); may be out of bounds."""
        o = self.info.origin.to_pose2d()
        dx, dy = x - o.x, y - o.y
        c, s = math.cos(-o.theta), math.sin(-o.theta)
        lx, ly = c * dx - s * dy, s * dx + c * dy
        return math.floor(ly / self.info.resolution), math.floor(lx / self.info.resolution)


class _Unset:
    """Marks an argument not given (``None`` is a meaningful ``_poses`` value)."""


_UNSET = _Unset()


@dataclass(frozen=True, slots=True, eq=False, init=False, repr=False)
class Path:
    """nav_msgs/Path: a sequence of stamped poses in ``header.frame_id``.

    The ``(N, 3)`` (x, y, theta) array view is computed once and cached (controllers ask
    for it every cycle); a Path is immutable, so the cache never goes stale.  A Path
    built :meth:`from_array` makes its ``poses`` on first access: controllers that only
    read the array (a plan re-transformed into ``odom`` on every replan) never pay for
    hundreds of ``PoseStamped`` objects.
    """

    header: Header
    _poses: tuple[PoseStamped, ...] | None
    _xyt: NDArray[np.float64] | None

    def __init__(self, header: Header | None = None, poses: Iterable[PoseStamped] = (),
                 _xyt: NDArray[np.float64] | None = None,
                 _poses: Iterable[PoseStamped] | _Unset | None = _UNSET) -> None:
        """``_poses`` is the field as :func:`dataclasses.fields` names it (the transport's
        decoder and :func:`dataclasses.replace` pass it); ``None`` there means "made from
        ``_xyt`` on first access"."""
        object.__setattr__(self, "header", Header() if header is None else header)
        if isinstance(_poses, _Unset):
            _poses = poses
        elif _poses is None and _xyt is None:
            raise ValueError("Path: _poses=None needs the _xyt array to make them from")
        if _poses is not None and not isinstance(_poses, tuple):
            _poses = tuple(_poses)
        object.__setattr__(self, "_poses", _poses)
        object.__setattr__(self, "_xyt", _xyt)

    @property
    def poses(self) -> tuple[PoseStamped, ...]:
        if self._poses is None:
            h = self.header
            arr = self._xyt
            assert arr is not None
            half = 0.5 * arr[:, 2]
            rows = zip(arr[:, 0].tolist(), arr[:, 1].tolist(), np.sin(half).tolist(),
                       np.cos(half).tolist(), strict=True)
            object.__setattr__(self, "_poses", tuple(
                PoseStamped(h, Pose(Point(x, y, 0.0), Quaternion(0.0, 0.0, qz, qw)))
                for x, y, qz, qw in rows))
        assert self._poses is not None
        return self._poses

    def __repr__(self) -> str:
        return f"Path(header={self.header!r}, poses={self.poses!r})"

    @staticmethod
    def from_array(xyt: NDArray[np.float64], frame_id: str = "map", stamp: float = 0.0) -> Path:
        """Build from an ``(N, 3)`` array of (x, y, theta).

        The quaternions are computed for all rows at once when ``poses`` is first read
        (``Quaternion.from_yaw`` per row took most of the time of a long path: 10 us per
        pose).
        """
        arr = np.array(xyt, dtype=np.float64).reshape(-1, 3)
        arr.setflags(write=False)
        path = Path(Header(stamp, frame_id), (), arr)
        object.__setattr__(path, "_poses", None)
        return path

    @property
    def num_poses(self) -> int:
        """How many poses, without building the ``PoseStamped`` objects of a path made
        from an array (``if path.poses`` built them all: ~1 ms for a long plan)."""
        if self._poses is not None:
            return len(self._poses)
        assert self._xyt is not None
        return int(self._xyt.shape[0])

    def as_array(self) -> NDArray[np.float64]:
        """``(N, 3)`` array of (x, y, theta) (read-only; copy before modifying)."""
        if self._xyt is None:
            arr = (np.zeros((0, 3)) if not self.poses else
                   np.array([[p.pose.position.x, p.pose.position.y, p.pose.orientation.yaw]
                             for p in self.poses]))
            arr.setflags(write=False)
            object.__setattr__(self, "_xyt", arr)
        assert self._xyt is not None
        return self._xyt

    def length(self) -> float:
        xy = self.as_array()[:, :2]
        return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0


@dataclass(frozen=True, slots=True)
class TFMessage:
    """tf2_msgs/TFMessage."""

    transforms: tuple[TransformStamped, ...] = ()


@dataclass(frozen=True, slots=True)
class ColorRGBA:
    r: float = 0.0
    g: float = 0.0
    b: float = 0.0
    a: float = 1.0


@dataclass(frozen=True, slots=True)
class Marker:
    """visualization_msgs/Marker (subset): type, pose, scale and points."""

    ARROW = 0
    CUBE = 1
    SPHERE = 2
    CYLINDER = 3
    LINE_STRIP = 4
    LINE_LIST = 5
    POINTS = 8
    TEXT_VIEW_FACING = 9
    ADD = 0
    DELETE = 2
    header: Header = field(default_factory=Header)
    ns: str = ""
    id: int = 0
    type: int = 0
    action: int = 0
    pose: Pose = field(default_factory=Pose)
    scale: Vector3 = field(default_factory=lambda: Vector3(1.0, 1.0, 1.0))
    color: ColorRGBA = field(default_factory=ColorRGBA)
    points: tuple[Point, ...] = ()
    text: str = ""


@dataclass(frozen=True, slots=True)
class MarkerArray:
    """visualization_msgs/MarkerArray."""

    markers: tuple[Marker, ...] = ()
