"""The navstack msg <-> ROS 2 message table and :class:`RosCodec` (objects and CDR bytes).

Every bus message type with a ROS 2 counterpart maps to its ROS 2 Humble type name
(``sensor_msgs/msg/LaserScan``, ...); ``RosCodec`` turns navstack messages into rosbags
message objects or CDR bytes and back.  Reading accepts the ROS 1 spelling of the same
types too (``tf/msg/tfMessage``), so ROS 1 bags convert through the same functions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from types import SimpleNamespace
from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from navstack.core import msgs as m
from navstack.runtime.recording import convert_command as c
from navstack.runtime.recording import convert_driver as d
from navstack.runtime.recording import convert_geometry as g
from navstack.runtime.recording import convert_nav2 as n
from navstack.runtime.recording import convert_sensor as s
from navstack.runtime.recording.cdr import FAST_ENCODERS
from navstack.runtime.recording.errors import UnsupportedTypeError
from navstack.runtime.recording.goal_status import GoalStatusArray


@dataclass(frozen=True)
class Conversion:
    """One message type: its ROS 2 name and the two conversion functions."""

    ros_type: str
    nav_type: type
    to_ros: Callable[[Any, Any], Any]
    from_ros: Callable[[Any], Any]


_TABLE: tuple[Conversion, ...] = (
    Conversion("std_msgs/msg/String", m.String, g.to_string, g.from_string),
    Conversion("std_msgs/msg/Bool", m.Bool, g.to_bool, g.from_bool),
    Conversion("std_msgs/msg/Float64", m.Float64, g.to_float64, g.from_float64),
    Conversion("std_msgs/msg/Header", m.Header, g.to_header, g.from_header),
    Conversion("rosgraph_msgs/msg/Clock", m.Clock, g.to_clock, g.from_clock),
    Conversion("geometry_msgs/msg/Vector3", m.Vector3, g.to_vector3, g.from_vector3),
    Conversion("geometry_msgs/msg/Point", m.Point, g.to_point, g.from_point),
    Conversion("geometry_msgs/msg/Quaternion", m.Quaternion, g.to_quaternion,
               g.from_quaternion),
    Conversion("geometry_msgs/msg/Pose", m.Pose, g.to_pose, g.from_pose),
    Conversion("geometry_msgs/msg/Pose2D", m.Pose2D, g.to_pose2d, g.from_pose2d),
    Conversion("geometry_msgs/msg/PoseStamped", m.PoseStamped, g.to_pose_stamped,
               g.from_pose_stamped),
    Conversion("geometry_msgs/msg/PoseWithCovariance", m.PoseWithCovariance,
               g.to_pose_with_covariance, g.from_pose_with_covariance),
    Conversion("geometry_msgs/msg/PoseWithCovarianceStamped", m.PoseWithCovarianceStamped,
               g.to_pose_with_covariance_stamped, g.from_pose_with_covariance_stamped),
    Conversion("geometry_msgs/msg/PoseArray", m.PoseArray, g.to_pose_array, g.from_pose_array),
    Conversion("geometry_msgs/msg/Transform", m.Transform, g.to_transform, g.from_transform),
    Conversion("geometry_msgs/msg/TransformStamped", m.TransformStamped,
               g.to_transform_stamped, g.from_transform_stamped),
    Conversion("geometry_msgs/msg/Twist", m.Twist, g.to_twist, g.from_twist),
    Conversion("geometry_msgs/msg/TwistStamped", m.TwistStamped, g.to_twist_stamped,
               g.from_twist_stamped),
    Conversion("geometry_msgs/msg/TwistWithCovariance", m.TwistWithCovariance,
               g.to_twist_with_covariance, g.from_twist_with_covariance),
    Conversion("geometry_msgs/msg/TwistWithCovarianceStamped", m.TwistWithCovarianceStamped,
               g.to_twist_with_covariance_stamped, g.from_twist_with_covariance_stamped),
    Conversion("geometry_msgs/msg/Polygon", m.Polygon, g.to_polygon, g.from_polygon),
    Conversion("sensor_msgs/msg/LaserScan", m.LaserScan, s.to_laser_scan, s.from_laser_scan),
    # written with all its fields; a ROS PointCloud2 reads back as the xyz PointCloud
    # below (the later entry of a ROS type is the one reading uses)
    Conversion("sensor_msgs/msg/PointCloud2", m.PointCloud2, d.to_point_cloud2,
               s.from_point_cloud),
    Conversion("sensor_msgs/msg/PointCloud2", m.PointCloud, s.to_point_cloud,
               s.from_point_cloud),
    Conversion("sensor_msgs/msg/PointField", m.PointField, d.to_point_field,
               d.from_point_field),
    Conversion("sensor_msgs/msg/JointState", m.JointState, d.to_joint_state,
               d.from_joint_state),
    Conversion("diagnostic_msgs/msg/KeyValue", m.KeyValue, d.to_key_value, d.from_key_value),
    Conversion("diagnostic_msgs/msg/DiagnosticStatus", m.DiagnosticStatus,
               d.to_diagnostic_status, d.from_diagnostic_status),
    Conversion("diagnostic_msgs/msg/DiagnosticArray", m.DiagnosticArray,
               d.to_diagnostic_array, d.from_diagnostic_array),
    Conversion("sensor_msgs/msg/Imu", m.Imu, s.to_imu, s.from_imu),
    Conversion("sensor_msgs/msg/MagneticField", m.MagneticField, s.to_magnetic_field,
               s.from_magnetic_field),
    Conversion("sensor_msgs/msg/NavSatFix", m.NavSatFix, s.to_nav_sat_fix, s.from_nav_sat_fix),
    Conversion("nav_msgs/msg/Odometry", m.Odometry, s.to_odometry, s.from_odometry),
    Conversion("nav_msgs/msg/OccupancyGrid", m.OccupancyGrid, s.to_occupancy_grid,
               s.from_occupancy_grid),
    Conversion("nav_msgs/msg/Path", m.Path, s.to_path, s.from_path),
    Conversion("tf2_msgs/msg/TFMessage", m.TFMessage, s.to_tf_message, s.from_tf_message),
    Conversion("visualization_msgs/msg/Marker", m.Marker, s.to_marker, s.from_marker),
    Conversion("visualization_msgs/msg/MarkerArray", m.MarkerArray, s.to_marker_array,
               s.from_marker_array),
    Conversion("action_msgs/msg/GoalStatusArray", GoalStatusArray, s.to_goal_status_array,
               s.from_goal_status_array),
    Conversion("nav2_msgs/msg/CostmapFilterInfo", m.CostmapFilterInfo,
               n.to_costmap_filter_info, n.from_costmap_filter_info),
    Conversion("nav2_msgs/msg/SpeedLimit", m.SpeedLimit, n.to_speed_limit,
               n.from_speed_limit),
    Conversion("sensor_msgs/msg/Joy", m.Joy, c.to_joy, c.from_joy),
    Conversion("sensor_msgs/msg/Range", m.Range, c.to_range, c.from_range),
    Conversion("nav2_msgs/msg/CollisionMonitorState", m.CollisionMonitorState,
               c.to_collision_monitor_state, c.from_collision_monitor_state),
)

#: ROS 1 (and old) spellings read as the ROS 2 type of the same layout
ROS_TYPE_ALIASES: dict[str, str] = {"tf/msg/tfMessage": "tf2_msgs/msg/TFMessage"}

BY_NAV_TYPE: dict[type, Conversion] = {c.nav_type: c for c in _TABLE}
BY_ROS_TYPE: dict[str, Conversion] = {c.ros_type: c for c in _TABLE}


def supported_ros_types() -> list[str]:
    """ROS type names that convert to navstack messages (aliases included)."""
    return sorted([*BY_ROS_TYPE, *ROS_TYPE_ALIASES])


@lru_cache(maxsize=1)
def humble_typestore() -> Typestore:
    """The ROS 2 Humble typestore plus the nav2_msgs types the bus carries (built once;
    read-only afterwards)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in n.NAV2_MSG_DEFINITIONS.items():
        store.register(get_types_from_msg(text, name))
    store.register(get_types_from_msg(c.COLLISION_MONITOR_STATE_DEFINITION,
                                      "nav2_msgs/msg/CollisionMonitorState"))
    return store


def _short_names(store: Typestore) -> SimpleNamespace:
    """``r.LaserScan``, ``r.Header``, ... for every class the table needs."""
    wanted = {c.ros_type for c in _TABLE} | {
        "builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration",
        "geometry_msgs/msg/Point32", "sensor_msgs/msg/PointField",
        "sensor_msgs/msg/NavSatStatus", "nav_msgs/msg/MapMetaData", "std_msgs/msg/ColorRGBA",
        "sensor_msgs/msg/CompressedImage", "visualization_msgs/msg/MeshFile",
        "action_msgs/msg/GoalStatus", "action_msgs/msg/GoalInfo",
        "unique_identifier_msgs/msg/UUID"}
    return SimpleNamespace(**{name.rsplit("/", 1)[1]: store.types[name] for name in wanted})


class RosCodec:
    """Converts navstack messages to ROS 2 (objects, CDR bytes) and back."""

    def __init__(self, typestore: Typestore | None = None) -> None:
        self.typestore = typestore or humble_typestore()
        self.r = _short_names(self.typestore)

    @staticmethod
    def conversion_for(nav_type: type, topic: str = "") -> Conversion:
        conv = BY_NAV_TYPE.get(nav_type)
        if conv is None:
            where = f"topic '{topic}' carries " if topic else ""
            raise UnsupportedTypeError(
                f"{where}{nav_type.__name__}, which has no ROS 2 message counterpart; "
                f"leave it out of the recorded topics (supported: "
                f"{', '.join(sorted(t.__name__ for t in BY_NAV_TYPE))})")
        return conv

    @staticmethod
    def conversion_from(ros_type: str, topic: str = "") -> Conversion:
        conv = BY_ROS_TYPE.get(ROS_TYPE_ALIASES.get(ros_type, ros_type))
        if conv is None:
            where = f"topic '{topic}' has type " if topic else "type "
            raise UnsupportedTypeError(
                f"{where}{ros_type}, which navstack cannot convert; leave the topic out "
                f"(convertible: {', '.join(supported_ros_types())})")
        return conv

    def ros_type(self, nav_type: type, topic: str = "") -> str:
        return self.conversion_for(nav_type, topic).ros_type

    def to_ros(self, msg: Any) -> Any:
        return self.conversion_for(type(msg)).to_ros(msg, self.r)

    def from_ros(self, ros_type: str, obj: Any, topic: str = "") -> Any:
        return self.conversion_from(ros_type, topic).from_ros(obj)

    def serialize(self, msg: Any) -> bytes:
        """CDR bytes of ``msg`` (direct encoders for the high-rate types)."""
        fast = FAST_ENCODERS.get(type(msg))
        if fast is not None:
            return fast(msg)
        conv = self.conversion_for(type(msg))
        data = self.typestore.serialize_cdr(conv.to_ros(msg, self.r), conv.ros_type)
        return bytes(data)

    def deserialize(self, data: bytes | memoryview, ros_type: str) -> Any:
        """The navstack message of CDR ``data`` of ``ros_type`` (a Humble type)."""
        conv = self.conversion_from(ros_type)
        return conv.from_ros(self.typestore.deserialize_cdr(bytes(data), conv.ros_type))
