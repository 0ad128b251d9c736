"""Message dataclasses named and shaped after their ROS 2 counterparts.

Field names follow the ROS 2 message of the same name; arrays are numpy; time is float
seconds.  ``runtime/`` converts to ROS time and CDR at the boundary.
"""

from navstack.core.msgs.geometry_msgs import (
    Point,
    Polygon,
    Pose,
    Pose2D,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    Transform,
    TransformStamped,
    Twist,
    Twist2D,
    TwistStamped,
    TwistWithCovariance,
    Vector3,
)
from navstack.core.msgs.sensor_msgs import (
    ColorRGBA,
    Imu,
    LaserScan,
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
from navstack.core.msgs.std import Bool, Clock, Float64, Header, String

__all__ = [
    "Bool", "Clock", "ColorRGBA", "Float64", "Header", "Imu", "LaserScan", "MapMetaData",
    "Marker", "MarkerArray", "NavSatFix", "NavSatStatus", "OccupancyGrid", "Odometry", "Path",
    "Point", "PointCloud", "Polygon", "Pose", "Pose2D", "PoseStamped", "PoseWithCovariance",
    "PoseWithCovarianceStamped", "Quaternion", "String", "TFMessage", "Transform",
    "TransformStamped", "Twist", "Twist2D", "TwistStamped", "TwistWithCovariance", "Vector3",
]
