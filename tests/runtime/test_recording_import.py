"""Bag import (a ROS 1 bag written with rosbags -> navstack rosbag2 MCAP) and the bag CLI
commands (``bag info``, ``bag import``, ``replay``) with their one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from typer.testing import CliRunner

from navstack.app import app
from navstack.core.msgs import Imu, LaserScan, NavSatFix, Odometry, TFMessage
from navstack.runtime.recording import (
    BagFormatError,
    BagPlayer,
    BagReader,
    UnsupportedTypeError,
    import_bag,
    runtime_for_bag,
)

runner = CliRunner()
N = 5


def _ros1_bag(path: Path) -> Path:
    """A ROS 1 bag as a ROS 1 robot writes it: '/'-prefixed frames, tf/tfMessage, a camera
    topic navstack cannot convert; 5 messages per topic at 10 Hz from t = 1000 s."""
    ts = get_typestore(Stores.ROS1_NOETIC)
    ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                   "tf/msg/tfMessage"))
    T = ts.types
    with Ros1Writer(path) as w:
        conns = {name: w.add_connection(name, kind, typestore=ts) for name, kind in (
            ("/scan", "sensor_msgs/msg/LaserScan"), ("/odom", "nav_msgs/msg/Odometry"),
            ("/imu", "sensor_msgs/msg/Imu"), ("/fix", "sensor_msgs/msg/NavSatFix"),
            ("/tf", "tf/msg/tfMessage"), ("/camera", "sensor_msgs/msg/Image"))}
        for k in range(N):
            sec, nsec = 1000, k * 100_000_000

            def hdr(frame: str, seq: int = k, s: int = sec, ns: int = nsec) -> object:
                return T["std_msgs/msg/Header"](seq=seq, stamp=T["builtin_interfaces/msg/Time"](
                    sec=s, nanosec=ns), frame_id=frame)

            quat = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
            vec = T["geometry_msgs/msg/Vector3"]
            msgs = {
                "/scan": T["sensor_msgs/msg/LaserScan"](
                    header=hdr("/laser"), angle_min=-1.5, angle_max=1.5, angle_increment=1.5,
                    time_increment=0.0, scan_time=0.1, range_min=0.1, range_max=30.0,
                    ranges=np.array([1.0, 2.0, float(k)], np.float32),
                    intensities=np.zeros(0, np.float32)),
                "/odom": T["nav_msgs/msg/Odometry"](
                    header=hdr("/odom"), child_frame_id="/base_link",
                    pose=T["geometry_msgs/msg/PoseWithCovariance"](
                        pose=T["geometry_msgs/msg/Pose"](
                            position=T["geometry_msgs/msg/Point"](x=0.1 * k, y=0.0, z=0.0),
                            orientation=quat), covariance=np.zeros(36)),
                    twist=T["geometry_msgs/msg/TwistWithCovariance"](
                        twist=T["geometry_msgs/msg/Twist"](linear=vec(x=1.0, y=0.0, z=0.0),
                                                           angular=vec(x=0.0, y=0.0, z=0.0)),
                        covariance=np.zeros(36))),
                "/imu": T["sensor_msgs/msg/Imu"](
                    header=hdr("imu"), orientation=quat, orientation_covariance=np.zeros(9),
                    angular_velocity=vec(x=0.0, y=0.0, z=0.5),
                    angular_velocity_covariance=np.zeros(9),
                    linear_acceleration=vec(x=0.0, y=0.0, z=9.81),
                    linear_acceleration_covariance=np.zeros(9)),
                "/fix": T["sensor_msgs/msg/NavSatFix"](
                    header=hdr("gps"), status=T["sensor_msgs/msg/NavSatStatus"](status=0,
                                                                                service=1),
                    latitude=38.4, longitude=-110.8, altitude=1400.0,
                    position_covariance=np.eye(3).reshape(-1), position_covariance_type=2),
                "/tf": T["tf/msg/tfMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
                    header=hdr("/odom"), child_frame_id="/base_link",
                    transform=T["geometry_msgs/msg/Transform"](
                        translation=vec(x=0.1 * k, y=0.0, z=0.0), rotation=quat))]),
                "/camera": T["sensor_msgs/msg/Image"](
                    header=hdr("cam"), height=1, width=1, encoding="mono8", is_bigendian=0,
                    step=1, data=np.zeros(1, np.uint8)),
            }
            for name, msg in msgs.items():
                w.write(conns[name], sec * 1_000_000_000 + nsec,
                        ts.serialize_ros1(msg, conns[name].msgtype))
    return path


@pytest.fixture(scope="module")
def ros1(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _ros1_bag(tmp_path_factory.mktemp("ros1") / "robot.bag")


def test_import_ros1_bag_to_mcap(tmp_path: Path, ros1: Path) -> None:
    result = import_bag(ros1, tmp_path / "imported")
    assert result.ros1
    assert result.summary.counts == {t: N for t in ("/scan", "/odom", "/imu", "/fix", "/tf")}
    assert result.summary.skipped == {"/camera": "type sensor_msgs/msg/Image has no navstack "
                                                 "conversion"}
    with AnyReader([tmp_path / "imported"]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
    assert types == {"/scan": "sensor_msgs/msg/LaserScan", "/odom": "nav_msgs/msg/Odometry",
                     "/imu": "sensor_msgs/msg/Imu", "/fix": "sensor_msgs/msg/NavSatFix",
                     "/tf": "tf2_msgs/msg/TFMessage"}
    with BagReader(tmp_path / "imported") as bag:
        assert (bag.start_time, bag.end_time) == (1000.0, 1000.4)
        got = {t: [m for m in bag.messages([t])] for t in ("/scan", "/odom", "/tf", "/fix",
                                                             "/imu")}
    scan = got["/scan"][3].msg
    assert isinstance(scan, LaserScan) and scan.header == type(scan.header)(1000.3, "laser")
    assert scan.ranges.tolist() == [1.0, 2.0, 3.0] and scan.range_max == 30.0
    odom = got["/odom"][2].msg
    assert isinstance(odom, Odometry) and odom.child_frame_id == "base_link"
    assert odom.pose.pose.position.x == pytest.approx(0.2) and odom.twist.twist.linear.x == 1.0
    tf = got["/tf"][4].msg
    assert isinstance(tf, TFMessage)
    assert (tf.transforms[0].header.frame_id, tf.transforms[0].child_frame_id) == \
        ("odom", "base_link")
    fix = got["/fix"][0].msg
    assert isinstance(fix, NavSatFix) and (fix.latitude, fix.position_covariance_type) == \
        (38.4, 2)
    assert isinstance(got["/imu"][1].msg, Imu) and got["/imu"][1].msg.angular_velocity.z == 0.5
    # the imported bag plays: the TF buffer learns odom -> base_link
    rt = runtime_for_bag(tmp_path / "imported")
    BagPlayer(rt, tmp_path / "imported").run()
    assert rt.tf.lookup_pose2d("odom", "base_link", 1000.4).x == pytest.approx(0.4)


def test_import_errors_name_the_topic(tmp_path: Path, ros1: Path) -> None:
    with pytest.raises(UnsupportedTypeError) as err:
        import_bag(ros1, tmp_path / "a", ["/scan", "/camera"])
    assert str(err.value).startswith(f"{ros1}: topic '/camera' has type sensor_msgs/msg/Image,"
                                     f" which navstack cannot convert; leave the topic out")
    assert not (tmp_path / "a").exists()
    with pytest.raises(BagFormatError) as ferr:
        import_bag(ros1, tmp_path / "b", ["/scan", "/lidar"])
    assert str(ferr.value) == (f"{ros1}: no topic /lidar in the bag (it has: /camera, /fix, "
                               f"/imu, /odom, /scan, /tf)")


def test_cli_bag_info_import_and_replay(tmp_path: Path, ros1: Path) -> None:
    res = runner.invoke(app, ["bag", "info", str(ros1)])
    assert res.exit_code == 0, res.output
    assert "span:     1000.000 .. 1000.400 s (0.400 s)" in res.output
    assert "sensor_msgs/msg/Image" in res.output and "(no navstack conversion)" in res.output
    out = tmp_path / "imp"
    res = runner.invoke(app, ["bag", "import", str(ros1), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert f"imported 25 messages on 5 topics from ROS 1 bag {ros1} into {out}" in res.output
    assert "warning: skipped /camera: type sensor_msgs/msg/Image" in res.output
    res = runner.invoke(app, ["bag", "import", str(ros1), "--out", str(out)])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert res.output.strip() == (f"error: {out}: a bag already exists there; remove it, "
                                  f"choose another output path or allow replacing it (--force)")
    res = runner.invoke(app, ["bag", "import", str(ros1), "--out", str(out), "--force"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["replay", str(out), "--rate", "0", "--echo", "/odom",
                              "--loop", "--duration", "0.75"])
    assert res.exit_code == 0, res.output
    assert "[1000.000] /odom Odometry {header={stamp=1000 frame_id=odom}" in res.output
    # pass 2 starts 0.4 s + one mean gap (0.4 / 24 s) later: 4 more per topic by 0.75 s
    assert "played 45 messages (1 complete pass):" in res.output
    assert res.output.count("/odom Odometry") == 9


def test_cli_errors_are_one_line(tmp_path: Path) -> None:
    res = runner.invoke(app, ["report", str(tmp_path / "none"), "--out", str(tmp_path / "r")])
    assert res.exit_code == 2
    assert res.output.strip() == (f"error: {tmp_path / 'none'}: no such bag (give a rosbag2 "
                                  f"folder with metadata.yaml, an .mcap or .db3 file, or a "
                                  f"ROS 1 .bag file)")
    bag = import_bag(_ros1_bag(tmp_path / "r.bag"), tmp_path / "imp").summary.path
    res = runner.invoke(app, ["replay", str(bag), "--echo", "/scna"])
    assert res.exit_code == 2
    assert res.output.strip() == ("error: unknown topic '/scna' (did you mean '/scan'?); known: "
                                  "/fix, /imu, /odom, /scan, /tf")
    (tmp_path / "x.csv").write_text("1,2\n")
    res = runner.invoke(app, ["replay", str(tmp_path / "x.csv")])
    assert res.exit_code == 2
    assert res.output.strip() == (f"error: {tmp_path / 'x.csv'}: unknown bag format '.csv' "
                                  f"(expected a rosbag2 folder, .mcap, .db3 or a ROS 1 .bag)")
