"""navstack <-> ROS 2 conversions for sensor_msgs, nav_msgs, tf2_msgs, visualization_msgs
and action_msgs (same conventions as :mod:`.convert_geometry`).

Shapes: ``OccupancyGrid.data`` is ``(height, width)`` in navstack and the same row-major
cells flattened in ROS (row 0 at the map origin in both); ``PointCloud`` (``xyz`` float32
``(N, 3)``) is written as an unorganised ``sensor_msgs/PointCloud2`` with float32 ``x``,
``y``, ``z`` fields and read back from any cloud whose ``x``/``y``/``z`` fields are
float32 or float64.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import (
    ColorRGBA,
    Imu,
    LaserScan,
    MagneticField,
    MapMetaData,
    Marker,
    MarkerArray,
    NavSatFix,
    NavSatStatus,
    OccupancyGrid,
    Odometry,
    Path,
    PointCloud,
    TFMessage,
)
from navstack.runtime.recording.convert_geometry import (
    f32,
    frame,
    from_cov,
    from_header,
    from_point,
    from_pose,
    from_pose_stamped,
    from_pose_with_covariance,
    from_quaternion,
    from_time,
    from_transform_stamped,
    from_twist_with_covariance,
    from_vector3,
    to_cov,
    to_header,
    to_point,
    to_pose,
    to_pose_stamped,
    to_pose_with_covariance,
    to_quaternion,
    to_time,
    to_transform_stamped,
    to_twist_with_covariance,
    to_vector3,
)
from navstack.runtime.recording.errors import BagFormatError
from navstack.runtime.recording.goal_status import (
    GoalInfo,
    GoalStatusArray,
    GoalStatusEntry,
)

_FLOAT32, _FLOAT64 = 7, 8  # sensor_msgs/PointField datatypes


def _f32(a: Any) -> NDArray[np.float32]:
    return np.array(a, dtype=np.float32).reshape(-1)


def to_laser_scan(m: LaserScan, r: Any) -> Any:
    return r.LaserScan(header=to_header(m.header, r), angle_min=float(m.angle_min),
                       angle_max=float(m.angle_max), angle_increment=float(m.angle_increment),
                       time_increment=float(m.time_increment), scan_time=float(m.scan_time),
                       range_min=float(m.range_min), range_max=float(m.range_max),
                       ranges=_f32(m.ranges), intensities=_f32(m.intensities))


def from_laser_scan(o: Any) -> LaserScan:
    return LaserScan(from_header(o.header), f32(o.angle_min), f32(o.angle_max),
                     f32(o.angle_increment), f32(o.time_increment), f32(o.scan_time),
                     f32(o.range_min), f32(o.range_max), _f32(o.ranges), _f32(o.intensities))


def to_point_cloud(m: PointCloud, r: Any) -> Any:
    xyz = np.ascontiguousarray(np.asarray(m.xyz, dtype="<f4").reshape(-1, 3))
    fields = [r.PointField(name=n, offset=4 * i, datatype=_FLOAT32, count=1)
              for i, n in enumerate("xyz")]
    return r.PointCloud2(header=to_header(m.header, r), height=1, width=len(xyz),
                         fields=fields, is_bigendian=False, point_step=12,
                         row_step=12 * len(xyz), data=np.frombuffer(xyz.tobytes(), np.uint8),
                         is_dense=bool(np.isfinite(xyz).all()))


def from_point_cloud(o: Any) -> PointCloud:
    fields = {f.name: f for f in o.fields}
    if not all(n in fields and fields[n].datatype in (_FLOAT32, _FLOAT64) for n in "xyz"):
        raise BagFormatError(f"PointCloud2 in '{frame(str(o.header.frame_id))}' has no float "
                             f"x/y/z fields (fields: {', '.join(fields) or 'none'}); only "
                             f"xyz clouds convert to navstack PointCloud")
    order = ">" if o.is_bigendian else "<"
    dtype = np.dtype({"names": list("xyz"),
                      "formats": [order + ("f4" if fields[n].datatype == _FLOAT32 else "f8")
                                  for n in "xyz"],
                      "offsets": [int(fields[n].offset) for n in "xyz"],
                      "itemsize": int(o.point_step)})
    count = int(o.width) * int(o.height)
    rows = np.frombuffer(np.asarray(o.data, np.uint8).tobytes(), dtype=dtype, count=count)
    xyz = np.column_stack([rows[n].astype(np.float32) for n in "xyz"]).reshape(-1, 3)
    return PointCloud(from_header(o.header), xyz)


def to_imu(m: Imu, r: Any) -> Any:
    return r.Imu(header=to_header(m.header, r), orientation=to_quaternion(m.orientation, r),
                 orientation_covariance=to_cov(m.orientation_covariance, 3),
                 angular_velocity=to_vector3(m.angular_velocity, r),
                 angular_velocity_covariance=to_cov(m.angular_velocity_covariance, 3),
                 linear_acceleration=to_vector3(m.linear_acceleration, r),
                 linear_acceleration_covariance=to_cov(m.linear_acceleration_covariance, 3))


def from_imu(o: Any) -> Imu:
    return Imu(from_header(o.header), from_quaternion(o.orientation),
               from_cov(o.orientation_covariance, 3), from_vector3(o.angular_velocity),
               from_cov(o.angular_velocity_covariance, 3), from_vector3(o.linear_acceleration),
               from_cov(o.linear_acceleration_covariance, 3))


def to_magnetic_field(m: MagneticField, r: Any) -> Any:
    return r.MagneticField(header=to_header(m.header, r),
                           magnetic_field=to_vector3(m.magnetic_field, r),
                           magnetic_field_covariance=to_cov(m.magnetic_field_covariance, 3))


def from_magnetic_field(o: Any) -> MagneticField:
    return MagneticField(from_header(o.header), from_vector3(o.magnetic_field),
                         from_cov(o.magnetic_field_covariance, 3))


def to_nav_sat_fix(m: NavSatFix, r: Any) -> Any:
    return r.NavSatFix(header=to_header(m.header, r),
                       status=r.NavSatStatus(status=int(m.status.status),
                                             service=int(m.status.service)),
                       latitude=float(m.latitude), longitude=float(m.longitude),
                       altitude=float(m.altitude),
                       position_covariance=to_cov(m.position_covariance, 3),
                       position_covariance_type=int(m.position_covariance_type))


def from_nav_sat_fix(o: Any) -> NavSatFix:
    return NavSatFix(from_header(o.header), NavSatStatus(int(o.status.status),
                                                         int(o.status.service)),
                     float(o.latitude), float(o.longitude), float(o.altitude),
                     from_cov(o.position_covariance, 3), int(o.position_covariance_type))


def to_odometry(m: Odometry, r: Any) -> Any:
    return r.Odometry(header=to_header(m.header, r), child_frame_id=m.child_frame_id,
                      pose=to_pose_with_covariance(m.pose, r),
                      twist=to_twist_with_covariance(m.twist, r))


def from_odometry(o: Any) -> Odometry:
    return Odometry(from_header(o.header), frame(str(o.child_frame_id)),
                    from_pose_with_covariance(o.pose), from_twist_with_covariance(o.twist))


def to_occupancy_grid(m: OccupancyGrid, r: Any) -> Any:
    i = m.info
    info = r.MapMetaData(map_load_time=to_time(i.map_load_time, r),
                         resolution=float(i.resolution), width=int(i.width),
                         height=int(i.height), origin=to_pose(i.origin, r))
    return r.OccupancyGrid(header=to_header(m.header, r), info=info,
                           data=np.asarray(m.data, dtype=np.int8).reshape(-1).copy())


def from_occupancy_grid(o: Any) -> OccupancyGrid:
    i = o.info
    width, height = int(i.width), int(i.height)
    data = np.array(o.data, dtype=np.int8).reshape(-1)
    if data.size != width * height:
        raise BagFormatError(f"OccupancyGrid in '{frame(str(o.header.frame_id))}' has "
                             f"{data.size} cells for {width} x {height}; the message is "
                             f"damaged")
    info = MapMetaData(from_time(i.map_load_time), f32(i.resolution), width, height,
                       from_pose(i.origin))
    return OccupancyGrid(from_header(o.header), info, data.reshape(height, width))


def to_path(m: Path, r: Any) -> Any:
    return r.Path(header=to_header(m.header, r), poses=[to_pose_stamped(p, r) for p in m.poses])


def from_path(o: Any) -> Path:
    return Path(from_header(o.header), tuple(from_pose_stamped(p) for p in o.poses))


def to_tf_message(m: TFMessage, r: Any) -> Any:
    return r.TFMessage(transforms=[to_transform_stamped(t, r) for t in m.transforms])


def from_tf_message(o: Any) -> TFMessage:
    return TFMessage(tuple(from_transform_stamped(t) for t in o.transforms))


def _to_color(c: ColorRGBA, r: Any) -> Any:
    return r.ColorRGBA(r=float(c.r), g=float(c.g), b=float(c.b), a=float(c.a))


def to_marker(m: Marker, r: Any) -> Any:
    """visualization_msgs/Marker; the fields navstack does not model get ROS defaults."""
    empty = np.zeros(0, np.uint8)
    header = to_header(m.header, r)
    return r.Marker(
        header=header, ns=m.ns, id=int(m.id), type=int(m.type), action=int(m.action),
        pose=to_pose(m.pose, r), scale=to_vector3(m.scale, r), color=_to_color(m.color, r),
        lifetime=r.Duration(sec=0, nanosec=0), frame_locked=False,
        points=[to_point(p, r) for p in m.points], colors=[], texture_resource="",
        texture=r.CompressedImage(header=header, format="", data=empty), uv_coordinates=[],
        text=m.text, mesh_resource="", mesh_file=r.MeshFile(filename="", data=empty),
        mesh_use_embedded_materials=False)


def from_marker(o: Any) -> Marker:
    c = o.color
    return Marker(from_header(o.header), str(o.ns), int(o.id), int(o.type), int(o.action),
                  from_pose(o.pose), from_vector3(o.scale),
                  ColorRGBA(float(c.r), float(c.g), float(c.b), float(c.a)),
                  tuple(from_point(p) for p in o.points), str(o.text))


def to_marker_array(m: MarkerArray, r: Any) -> Any:
    return r.MarkerArray(markers=[to_marker(k, r) for k in m.markers])


def from_marker_array(o: Any) -> MarkerArray:
    return MarkerArray(tuple(from_marker(k) for k in o.markers))


def to_goal_status_array(m: GoalStatusArray, r: Any) -> Any:
    return r.GoalStatusArray(status_list=[
        r.GoalStatus(goal_info=r.GoalInfo(
            goal_id=r.UUID(uuid=np.frombuffer(s.goal_info.goal_id.ljust(16, b"\0")[:16],
                                              np.uint8).copy()),
            stamp=to_time(s.goal_info.stamp, r)), status=int(s.status))
        for s in m.status_list])


def from_goal_status_array(o: Any) -> GoalStatusArray:
    return GoalStatusArray(tuple(
        GoalStatusEntry(GoalInfo(np.asarray(s.goal_info.goal_id.uuid, np.uint8).tobytes(),
                                 from_time(s.goal_info.stamp)), int(s.status))
        for s in o.status_list))

