"""navstack <-> ROS 2 conversions for std_msgs, builtin_interfaces and geometry_msgs.

``to_*`` functions build rosbags message objects from the classes in ``r`` (the ROS 2
Humble typestore's classes, see :class:`~navstack.runtime.recording.convert.RosCodec`);
``from_*`` functions read any object with the ROS field names (duck typing), so they work
on messages deserialized from ROS 2 bags and from ROS 1 bags alike (ROS 1 headers carry
an extra ``seq``, which is dropped).  Frame ids lose a leading ``/`` (ROS 1 tf allowed
it, tf2 forbids it).  Covariances are ``float64[36]`` / ``float64[9]`` row-major in ROS
and ``(6, 6)`` / ``(3, 3)`` arrays in navstack.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.core.msgs import (
    Bool,
    Clock,
    Float64,
    Header,
    Point,
    Polygon,
    Pose,
    Pose2D,
    PoseArray,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    String,
    Transform,
    TransformStamped,
    Twist,
    TwistStamped,
    TwistWithCovariance,
    TwistWithCovarianceStamped,
    Vector3,
)
from navstack.runtime.recording.rostime import from_sec_nsec, to_sec_nsec

__all__ = [
    "f32", "frame", "from_cov", "from_header", "from_point", "from_pose", "from_quaternion",
    "from_time", "from_transform_stamped", "from_twist", "from_vector3", "to_cov",
    "to_header", "to_point", "to_pose", "to_quaternion", "to_time", "to_transform_stamped",
    "to_twist", "to_vector3",
]


# --- builtin_interfaces / std_msgs ---------------------------------------------------------
def to_time(t: float, r: Any) -> Any:
    sec, nsec = to_sec_nsec(t)
    return r.Time(sec=sec, nanosec=nsec)


def from_time(o: Any) -> float:
    return from_sec_nsec(int(o.sec), int(o.nanosec))


def frame(frame_id: str) -> str:
    """A tf2-valid frame id (ROS 1 bags may write ``/base_link``)."""
    return frame_id[1:] if frame_id.startswith("/") else frame_id


def f32(x: Any) -> float:
    """A ROS ``float32`` field as the shortest float64 that rounds to it (``0.05`` stays
    ``0.05`` rather than becoming ``0.05000000074505806``)."""
    return float(str(np.float32(x)))


def to_header(h: Header, r: Any) -> Any:
    return r.Header(stamp=to_time(h.stamp, r), frame_id=h.frame_id)


def from_header(o: Any) -> Header:
    return Header(from_time(o.stamp), frame(str(o.frame_id)))


def to_cov(a: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Row-major flat ``float64[n*n]`` of an ``(n, n)`` covariance (zeros if malformed)."""
    flat = np.asarray(a, dtype=np.float64).reshape(-1)
    return flat.copy() if flat.size == n * n else np.zeros(n * n)


def from_cov(a: Any, n: int) -> NDArray[np.float64]:
    return np.array(a, dtype=np.float64).reshape(n, n)


def to_clock(m: Clock, r: Any) -> Any:
    return r.Clock(clock=to_time(m.clock, r))


def from_clock(o: Any) -> Clock:
    return Clock(from_time(o.clock))


def to_string(m: String, r: Any) -> Any:
    return r.String(data=m.data)


def from_string(o: Any) -> String:
    return String(str(o.data))


def to_bool(m: Bool, r: Any) -> Any:
    return r.Bool(data=bool(m.data))


def from_bool(o: Any) -> Bool:
    return Bool(bool(o.data))


def to_float64(m: Float64, r: Any) -> Any:
    return r.Float64(data=float(m.data))


def from_float64(o: Any) -> Float64:
    return Float64(float(o.data))


# --- geometry_msgs primitives --------------------------------------------------------------
def to_vector3(v: Vector3, r: Any) -> Any:
    return r.Vector3(x=float(v.x), y=float(v.y), z=float(v.z))


def from_vector3(o: Any) -> Vector3:
    return Vector3(float(o.x), float(o.y), float(o.z))


def to_point(p: Point, r: Any) -> Any:
    return r.Point(x=float(p.x), y=float(p.y), z=float(p.z))


def from_point(o: Any) -> Point:
    return Point(float(o.x), float(o.y), float(o.z))


def to_quaternion(q: Quaternion, r: Any) -> Any:
    return r.Quaternion(x=float(q.x), y=float(q.y), z=float(q.z), w=float(q.w))


def from_quaternion(o: Any) -> Quaternion:
    return Quaternion(float(o.x), float(o.y), float(o.z), float(o.w))


def to_pose(p: Pose, r: Any) -> Any:
    return r.Pose(position=to_point(p.position, r), orientation=to_quaternion(p.orientation, r))


def from_pose(o: Any) -> Pose:
    return Pose(from_point(o.position), from_quaternion(o.orientation))


def to_pose2d(p: Pose2D, r: Any) -> Any:
    return r.Pose2D(x=float(p.x), y=float(p.y), theta=float(p.theta))


def from_pose2d(o: Any) -> Pose2D:
    return Pose2D(float(o.x), float(o.y), float(o.theta))


def to_transform(t: Transform, r: Any) -> Any:
    return r.Transform(translation=to_vector3(t.translation, r),
                       rotation=to_quaternion(t.rotation, r))


def from_transform(o: Any) -> Transform:
    return Transform(from_vector3(o.translation), from_quaternion(o.rotation))


def to_transform_stamped(t: TransformStamped, r: Any) -> Any:
    return r.TransformStamped(header=to_header(t.header, r), child_frame_id=t.child_frame_id,
                              transform=to_transform(t.transform, r))


def from_transform_stamped(o: Any) -> TransformStamped:
    return TransformStamped(from_header(o.header), frame(str(o.child_frame_id)),
                            from_transform(o.transform))


def to_twist(t: Twist, r: Any) -> Any:
    return r.Twist(linear=to_vector3(t.linear, r), angular=to_vector3(t.angular, r))


def from_twist(o: Any) -> Twist:
    return Twist(from_vector3(o.linear), from_vector3(o.angular))


def to_twist_stamped(t: TwistStamped, r: Any) -> Any:
    return r.TwistStamped(header=to_header(t.header, r), twist=to_twist(t.twist, r))


def from_twist_stamped(o: Any) -> TwistStamped:
    return TwistStamped(from_header(o.header), from_twist(o.twist))


# --- with covariance / stamped -------------------------------------------------------------
def to_pose_with_covariance(p: PoseWithCovariance, r: Any) -> Any:
    return r.PoseWithCovariance(pose=to_pose(p.pose, r), covariance=to_cov(p.covariance, 6))


def from_pose_with_covariance(o: Any) -> PoseWithCovariance:
    return PoseWithCovariance(from_pose(o.pose), from_cov(o.covariance, 6))


def to_twist_with_covariance(t: TwistWithCovariance, r: Any) -> Any:
    return r.TwistWithCovariance(twist=to_twist(t.twist, r), covariance=to_cov(t.covariance, 6))


def from_twist_with_covariance(o: Any) -> TwistWithCovariance:
    return TwistWithCovariance(from_twist(o.twist), from_cov(o.covariance, 6))


def to_pose_stamped(p: PoseStamped, r: Any) -> Any:
    return r.PoseStamped(header=to_header(p.header, r), pose=to_pose(p.pose, r))


def from_pose_stamped(o: Any) -> PoseStamped:
    return PoseStamped(from_header(o.header), from_pose(o.pose))


def to_pose_with_covariance_stamped(p: PoseWithCovarianceStamped, r: Any) -> Any:
    return r.PoseWithCovarianceStamped(header=to_header(p.header, r),
                                       pose=to_pose_with_covariance(p.pose, r))


def from_pose_with_covariance_stamped(o: Any) -> PoseWithCovarianceStamped:
    return PoseWithCovarianceStamped(from_header(o.header), from_pose_with_covariance(o.pose))


def to_twist_with_covariance_stamped(t: TwistWithCovarianceStamped, r: Any) -> Any:
    return r.TwistWithCovarianceStamped(header=to_header(t.header, r),
                                        twist=to_twist_with_covariance(t.twist, r))


def from_twist_with_covariance_stamped(o: Any) -> TwistWithCovarianceStamped:
    return TwistWithCovarianceStamped(from_header(o.header), from_twist_with_covariance(o.twist))


def to_pose_array(p: PoseArray, r: Any) -> Any:
    return r.PoseArray(header=to_header(p.header, r), poses=[to_pose(q, r) for q in p.poses])


def from_pose_array(o: Any) -> PoseArray:
    return PoseArray(from_header(o.header), tuple(from_pose(q) for q in o.poses))


def to_polygon(p: Polygon, r: Any) -> Any:
    return r.Polygon(points=[r.Point32(x=float(x), y=float(y), z=0.0) for x, y in p.points])


def from_polygon(o: Any) -> Polygon:
    return Polygon(tuple((f32(q.x), f32(q.y)) for q in o.points))
