"""geometry_msgs equivalents, plus ``Pose2D``/``Twist2D`` for planar code.

Covariances are numpy arrays of shape (6, 6), row-major order x, y, z, rot x, rot y,
rot z as in ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from navstack.core.geometry import (
    normalize_angle,
    quaternion_to_yaw,
    se2_apply,
    yaw_to_quaternion,
)
from navstack.core.msgs.std import Header


def _zeros6() -> NDArray[np.float64]:
    return np.zeros((6, 6))


@dataclass(frozen=True, slots=True)
class Vector3:
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(frozen=True, slots=True)
class Point:
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(frozen=True, slots=True)
class Quaternion:
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0

    @staticmethod
    def from_yaw(yaw: float) -> Quaternion:
        return Quaternion(*yaw_to_quaternion(yaw))

    @property
    def yaw(self) -> float:
        return quaternion_to_yaw(self.x, self.y, self.z, self.w)


@dataclass(frozen=True, slots=True)
class Pose2D:
    """Planar pose (x, y, theta) in metres/radians; also the SE(2) transform type."""

    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0

    def as_array(self) -> NDArray[np.float64]:
        return np.array([self.x, self.y, self.theta])

    @staticmethod
    def from_array(a: NDArray[np.float64] | list[float] | tuple[float, ...]) -> Pose2D:
        return Pose2D(float(a[0]), float(a[1]), normalize_angle(float(a[2])))

    def compose(self, other: Pose2D) -> Pose2D:
        """``self ⊕ other``: ``other`` given in this pose's frame, in the parent frame.

        Scalar float math: this sits on per-message paths where numpy's per-call
        overhead would dominate (``se2_compose`` is the vectorised form).
        """
        c, s = math.cos(self.theta), math.sin(self.theta)
        return Pose2D(self.x + c * other.x - s * other.y, self.y + s * other.x + c * other.y,
                      normalize_angle(self.theta + other.theta))

    def __matmul__(self, other: Pose2D) -> Pose2D:
        return self.compose(other)

    def inverse(self) -> Pose2D:
        c, s = math.cos(self.theta), math.sin(self.theta)
        return Pose2D(-(c * self.x + s * self.y), s * self.x - c * self.y,
                      normalize_angle(-self.theta))

    def transform_points(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Map ``(N, 2)`` points from this pose's frame into its parent frame."""
        return se2_apply(self.as_array(), points)

    def distance_to(self, other: Pose2D) -> float:
        return math.hypot(other.x - self.x, other.y - self.y)

    def to_pose(self) -> Pose:
        return Pose(Point(self.x, self.y, 0.0), Quaternion.from_yaw(self.theta))


@dataclass(frozen=True, slots=True)
class Pose:
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)

    def to_pose2d(self) -> Pose2D:
        return Pose2D(self.position.x, self.position.y, self.orientation.yaw)


@dataclass(frozen=True, slots=True)
class PoseStamped:
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)

    @staticmethod
    def from_pose2d(p: Pose2D, frame_id: str = "map", stamp: float = 0.0) -> PoseStamped:
        return PoseStamped(Header(stamp, frame_id), p.to_pose())

    def to_pose2d(self) -> Pose2D:
        return self.pose.to_pose2d()


@dataclass(frozen=True, slots=True, eq=False)
class PoseWithCovariance:
    pose: Pose = field(default_factory=Pose)
    covariance: NDArray[np.float64] = field(default_factory=_zeros6)


@dataclass(frozen=True, slots=True, eq=False)
class PoseWithCovarianceStamped:
    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass(frozen=True, slots=True)
class Twist:
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)

    @staticmethod
    def planar(vx: float, vy: float, wz: float) -> Twist:
        return Twist(Vector3(vx, vy, 0.0), Vector3(0.0, 0.0, wz))

    def to_twist2d(self) -> Twist2D:
        return Twist2D(self.linear.x, self.linear.y, self.angular.z)


@dataclass(frozen=True, slots=True)
class Twist2D:
    """Planar velocity in the body frame: vx, vy [m/s], wz [rad/s]."""

    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0

    def to_twist(self) -> Twist:
        return Twist.planar(self.vx, self.vy, self.wz)

    def is_finite(self) -> bool:
        return math.isfinite(self.vx) and math.isfinite(self.vy) and math.isfinite(self.wz)


@dataclass(frozen=True, slots=True)
class TwistStamped:
    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@dataclass(frozen=True, slots=True, eq=False)
class TwistWithCovariance:
    twist: Twist = field(default_factory=Twist)
    covariance: NDArray[np.float64] = field(default_factory=_zeros6)


@dataclass(frozen=True, slots=True, eq=False)
class TwistWithCovarianceStamped:
    header: Header = field(default_factory=Header)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass(frozen=True, slots=True, eq=False)
class PoseArray:
    """geometry_msgs/PoseArray (AMCL's particle cloud)."""

    header: Header = field(default_factory=Header)
    poses: tuple[Pose, ...] = ()


@dataclass(frozen=True, slots=True)
class Transform:
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)

    @staticmethod
    def from_pose2d(p: Pose2D) -> Transform:
        return Transform(Vector3(p.x, p.y, 0.0), Quaternion.from_yaw(p.theta))

    def to_pose2d(self) -> Pose2D:
        return Pose2D(self.translation.x, self.translation.y, self.rotation.yaw)


@dataclass(frozen=True, slots=True)
class TransformStamped:
    """A transform from ``child_frame_id`` into ``header.frame_id`` (the parent)."""

    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass(frozen=True, slots=True)
class Polygon:
    """geometry_msgs/Polygon as an ``(N, 2)`` array of vertices [m]."""

    points: tuple[tuple[float, float], ...] = ()
