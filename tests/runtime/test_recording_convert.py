"""navstack <-> ROS 2 conversions: exact round trips through CDR, and the direct CDR
encoders byte-identical to rosbags' serializer."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

from navstack.core.msgs import (
    Bool,
    Clock,
    CollisionMonitorState,
    ColorRGBA,
    CostmapFilterInfo,
    DiagnosticArray,
    DiagnosticStatus,
    Float64,
    Header,
    Imu,
    JointState,
    Joy,
    KeyValue,
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
    Point,
    PointCloud,
    PointCloud2,
    PointField,
    Polygon,
    Pose,
    Pose2D,
    PoseArray,
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    Range,
    SpeedLimit,
    String,
    TFMessage,
    Transform,
    TransformStamped,
    Twist,
    TwistStamped,
    TwistWithCovariance,
    TwistWithCovarianceStamped,
    Vector3,
)
from navstack.runtime.recording import (
    GoalInfo,
    GoalStatusArray,
    GoalStatusEntry,
    RosCodec,
    UnsupportedTypeError,
)
from navstack.runtime.recording.cdr import FAST_ENCODERS
from navstack.runtime.recording.rostime import from_ns, from_sec_nsec, to_ns, to_sec_nsec

CODEC = RosCodec()
COV6 = np.arange(36, dtype=np.float64).reshape(6, 6) / 7.0
COV3 = np.arange(9, dtype=np.float64).reshape(3, 3) / 3.0


def _equal(a: Any, b: Any) -> bool:
    """Field-by-field equality (numpy arrays by value, NaN == NaN, inf == inf)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(
            _equal(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
            if not f.name.startswith("_"))
    if isinstance(a, tuple | list):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


def _pose(x: float, y: float, yaw: float) -> Pose:
    return Pose2D(x, y, yaw).to_pose()


# stamps are whole nanoseconds, so they survive builtin_interfaces/Time exactly
SAMPLES: list[Any] = [
    String("héllo"), Bool(True), Float64(-2.5), Clock(1234.5), Header(3.25, "map"),
    Vector3(1.0, -2.0, 3.5), Point(0.5, 0.25, -1.0), Quaternion(0.0, 0.0, 0.6, 0.8),
    _pose(1.0, 2.0, 0.5), Pose2D(1.5, -2.5, 3.0),
    PoseStamped(Header(7.125, "map"), _pose(3.0, 4.0, -1.0)),
    PoseWithCovariance(_pose(1.0, 1.0, 1.0), COV6),
    PoseWithCovarianceStamped(Header(1.5, "map"), PoseWithCovariance(_pose(1, 2, 3), COV6)),
    PoseArray(Header(2.0, "map"), (_pose(1, 2, 3), _pose(-1, 0, 0.5))),
    Transform(Vector3(1, 2, 0), Quaternion.from_yaw(0.3)),
    TransformStamped(Header(5.0, "odom"), "base_link", Transform(Vector3(1, 2, 0))),
    Twist.planar(0.5, 0.0, -0.25), TwistStamped(Header(1.0, "base_link"), Twist.planar(1, 2, 3)),
    TwistWithCovariance(Twist.planar(0.1, 0.2, 0.3), COV6),
    TwistWithCovarianceStamped(Header(9.0, "gps"), TwistWithCovariance(Twist.planar(1, 1, 0),
                                                                       COV6)),
    Polygon(((0.5, 0.25), (-0.5, 0.25), (-0.5, -0.25))),
    LaserScan(Header(10.125, "laser"), -2.356194, 2.356194, 0.004363323, 0.0, 0.1, 0.05, 12.0,
              np.array([1.0, np.inf, 2.5, np.nan, 11.0], np.float32),
              np.array([1.0, 2.0, 3.0, 4.0, 5.0], np.float32)),
    PointCloud(Header(4.0, "velodyne"), np.array([[1, 2, 3], [4.5, -5, 6]], np.float32)),
    Imu(Header(1.0, "imu_link"), Quaternion.from_yaw(0.4), COV3, Vector3(0.1, 0.2, 0.3),
        COV3 * 2, Vector3(0.0, 0.0, 9.81), COV3 * 3),
    MagneticField(Header(2.0, "mag"), Vector3(2e-5, 0.0, -4e-5), COV3),
    NavSatFix(Header(3.0, "gps"), NavSatStatus(NavSatStatus.STATUS_FIX, 1), 38.4063, -110.7918,
              1400.5, COV3, NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN),
    Odometry(Header(12.5, "odom"), "base_link", PoseWithCovariance(_pose(1, 2, 0.3), COV6),
             TwistWithCovariance(Twist.planar(0.4, 0.0, -0.2), COV6 * 2)),
    OccupancyGrid(Header(0.0, "map"), MapMetaData(1.0, 0.05, 3, 2, _pose(-1.0, -2.0, 0.0)),
                  np.array([[0, 100, -1], [50, 0, 0]], np.int8)),
    Path.from_array(np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.25], [2.0, 1.0, 0.5]]), "map", 6.0),
    TFMessage((TransformStamped(Header(1.0, "map"), "odom", Transform(Vector3(1, 0, 0))),
               TransformStamped(Header(1.0, "odom"), "base_link",
                                Transform.from_pose2d(Pose2D(3, 4, 1.0))))),
    Marker(Header(1.0, "map"), "goals", 7, Marker.SPHERE, Marker.ADD, _pose(1, 2, 0),
           Vector3(0.5, 0.5, 0.5), ColorRGBA(1.0, 0.5, 0.0, 1.0), (Point(1, 2, 3),), "G1"),
    MarkerArray((Marker(ns="a", id=1), Marker(ns="b", id=2, text="x"))),
    GoalStatusArray((GoalStatusEntry(GoalInfo(bytes(range(16)), 4.5), 4),)),
    CostmapFilterInfo(Header(1.5, ""), 1, "/speed_filter_mask", 100.0, -1.0),
    SpeedLimit(Header(2.25, "odom"), True, 30.0),
    Joy(Header(0.5, "joy"), (0.25, -1.0, 0.1), (0, 1, 1)),
    Range(Header(0.75, "sonar"), 0, 0.26, 0.02, 4.0, 1.3),
    CollisionMonitorState(3, "FootprintApproach"),
    JointState(Header(2.5, "base_link"), ("left_wheel_joint", "right_wheel_joint"),
               (1.5, -2.0), (0.25, 0.5), ()),
    PointField("ring", 16, PointField.UINT16, 1),
    KeyValue("vcu.packets_rx", "42"),
    DiagnosticStatus(DiagnosticStatus.ERROR, "vehicle_driver: rover_vcu", "link lost",
                     "rover", (KeyValue("link_lost", "true"),)),
    DiagnosticArray(Header(1.0, ""), (DiagnosticStatus(0, "a", "ok", "hw", ()),)),
]


@pytest.mark.parametrize("msg", SAMPLES, ids=lambda m: type(m).__name__)
def test_round_trip_through_cdr_is_exact(msg: Any) -> None:
    ros_type = CODEC.ros_type(type(msg))
    back = CODEC.deserialize(CODEC.serialize(msg), ros_type)
    assert _equal(back, msg), (back, msg)


def test_every_bus_message_type_has_a_ros_counterpart() -> None:
    from navstack.core import msgs

    covered = {type(m).__name__ for m in SAMPLES} | {"NavSatStatus", "ColorRGBA", "MapMetaData",
                                                     "PointCloud2"}  # below
    # Twist2D is navstack's planar velocity and NavigationHold its pause request: no
    # ROS 2 message has those shapes
    assert set(msgs.__all__) - covered == {"Twist2D", "NavigationHold"}


def test_point_cloud2_is_written_whole_and_read_back_as_xyz() -> None:
    cloud = PointCloud2.from_fields(Header(3.0, "velodyne"), {
        "x": np.array([1.0, np.nan], np.float32), "y": np.array([2.0, 0.0], np.float32),
        "z": np.array([-0.5, 0.0], np.float32), "ring": np.array([3, 4], np.uint16)})
    ros = CODEC.to_ros(cloud)
    assert [f.name for f in ros.fields] == ["x", "y", "z", "ring"] and ros.point_step == 14
    back = CODEC.deserialize(CODEC.serialize(cloud), "sensor_msgs/msg/PointCloud2")
    assert isinstance(back, PointCloud) and back.header == cloud.header
    assert np.array_equal(back.xyz, cloud.xyz().astype(np.float32), equal_nan=True)


@pytest.mark.parametrize("msg", [m for m in SAMPLES if type(m) in FAST_ENCODERS] + [
    Odometry(Header(-0.25, "o"), "b", PoseWithCovariance(_pose(1, 2, 3), COV6[:5, :5])),
    LaserScan(Header(1.0, "x"), ranges=np.zeros(0, np.float32)),
    TFMessage(()),
    Imu(Header(0.1, "imu"), orientation_covariance=np.array([-1.0, 0, 0, 0, 0, 0, 0, 0, 0])),
], ids=lambda m: type(m).__name__)
def test_direct_encoders_match_rosbags_bytes(msg: Any) -> None:
    conv = CODEC.conversion_for(type(msg))
    reference = bytes(CODEC.typestore.serialize_cdr(conv.to_ros(msg, CODEC.r), conv.ros_type))
    assert FAST_ENCODERS[type(msg)](msg) == reference


def test_time_conversions() -> None:
    assert to_sec_nsec(12.5) == (12, 500_000_000)
    assert to_sec_nsec(-0.25) == (-1, 750_000_000)
    assert to_sec_nsec(0.9999999999) == (1, 0)  # rounds to the nearest nanosecond
    assert from_sec_nsec(-1, 750_000_000) == -0.25
    assert to_ns(1.5) == 1_500_000_000
    assert from_ns(1_700_000_000_123_456_789) == pytest.approx(1_700_000_000.1234568, abs=1e-6)
    t = 1_700_000_123.456789
    assert abs(from_sec_nsec(*to_sec_nsec(t)) - t) < 1e-6  # float64 limit at epoch scale


def test_frame_ids_lose_a_leading_slash_on_read() -> None:
    ros = CODEC.to_ros(TransformStamped(Header(1.0, "/odom"), "/base_link"))
    back = CODEC.from_ros("geometry_msgs/msg/TransformStamped", ros)
    assert (back.header.frame_id, back.child_frame_id) == ("odom", "base_link")


def test_unsupported_types_are_named() -> None:
    from navstack.core.msgs import Twist2D

    with pytest.raises(UnsupportedTypeError) as err:
        CODEC.ros_type(Twist2D, "/cmd_planar")
    assert str(err.value).startswith("topic '/cmd_planar' carries Twist2D, which has no ROS 2 "
                                     "message counterpart; leave it out of the recorded topics")
    with pytest.raises(UnsupportedTypeError) as err:
        CODEC.conversion_from("sensor_msgs/msg/Image", "/camera")
    assert str(err.value).startswith("topic '/camera' has type sensor_msgs/msg/Image, which "
                                     "navstack cannot convert; leave the topic out")


def test_float32_fields_come_back_as_their_shortest_decimal() -> None:
    """LaserScan angles and map resolution are float32 in ROS: 0.05 stays 0.05, and a
    float64 with more digits comes back rounded to float32 precision (~7 digits)."""
    scan = LaserScan(Header(0.0, "laser"), angle_increment=2 * np.pi / 360, range_max=12.0)
    back = CODEC.deserialize(CODEC.serialize(scan), "sensor_msgs/msg/LaserScan")
    assert back.angle_increment == 0.017453292
    assert back.range_max == 12.0
