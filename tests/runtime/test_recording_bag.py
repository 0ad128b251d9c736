"""BagRecorder -> rosbag2 (MCAP / sqlite3) -> BagReader / AnyReader / BagPlayer, with
exact counts, times and fields, goal status recording and the one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability

from navstack.core.msgs import (
    Header,
    LaserScan,
    MapMetaData,
    OccupancyGrid,
    Odometry,
    Pose2D,
    PoseStamped,
    PoseWithCovariance,
    TFMessage,
    Transform,
    TransformStamped,
    Twist,
    Twist2D,
    Vector3,
)
from navstack.navigation.messages import NavigateToPoseGoal
from navstack.runtime.actions import ActionClient, ActionServer, GoalHandle
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.node import Runtime
from navstack.runtime.recording import (
    BagExistsError,
    BagFormatError,
    BagNotFoundError,
    BagPlayer,
    BagReader,
    BagRecorder,
    GoalStatusArray,
    UnsupportedTypeError,
    runtime_for_bag,
)

GRID = OccupancyGrid(Header(0.0, "map"), MapMetaData(0.0, 0.5, 4, 3, Pose2D(-1, -1, 0).to_pose()),
                     np.array([[0, 0, 100, -1], [0, 0, 0, 0], [100, 100, 0, 0]], np.int8))
STATIC = TFMessage((TransformStamped(Header(0.0, "base_link"), "laser",
                                     Transform(Vector3(0.1, 0.0, 0.2))),))
SCAN_DT, ODOM_DT = 0.125, 0.03125  # exact in binary: timer times are exact


def _scan(t: float) -> LaserScan:
    return LaserScan(Header(t, "laser"), -1.0, 1.0, 0.5, 0.0, 0.125, 0.1, 10.0,
                     np.array([1.0, 2.0, t, np.inf, 3.0], np.float32))


def _odom(t: float) -> Odometry:
    return Odometry(Header(t, "odom"), "base_link",
                    PoseWithCovariance(Pose2D(t, 0.5 * t, 0.1 * t).to_pose()))


def record_small(path: Path, storage: str = "mcap") -> Path:
    """1 s of scans (8), odometry + /tf (32 each), /cmd_vel (8), a latched /map and
    /tf_static published before recording, /imu (not a default topic) and one goal."""
    rt = Runtime()
    bus, sched = rt.bus, rt.scheduler
    bus.publisher("/map", OccupancyGrid, LATCHED).publish(GRID)
    bus.publisher("/tf_static", TFMessage, QoS(depth=1, latched=True)).publish(STATIC)

    def on_goal(handle: GoalHandle[NavigateToPoseGoal]) -> bool:
        sched.call_later(0.5, handle.succeed)
        return True

    ActionServer(bus, "/navigate_to_pose", on_goal)
    rec = BagRecorder(rt, path, storage=storage)
    scan, odom = bus.publisher("/scan", LaserScan), bus.publisher("/odom", Odometry)
    tf, cmd = bus.publisher("/tf", TFMessage), bus.publisher("/cmd_vel", Twist)
    sched.create_timer(SCAN_DT, lambda: scan.publish(_scan(sched.now)))
    sched.create_timer(ODOM_DT, lambda: odom.publish(_odom(sched.now)))
    sched.create_timer(ODOM_DT, lambda: tf.publish(TFMessage((TransformStamped(
        Header(sched.now, "odom"), "base_link", Transform.from_pose2d(Pose2D(sched.now, 0, 0))),
    ))))
    sched.create_timer(SCAN_DT, lambda: cmd.publish(Twist.planar(0.5, 0.0, sched.now)))
    imu = bus.publisher("/imu", Twist)
    sched.create_timer(SCAN_DT, lambda: imu.publish(Twist()))
    goal = PoseStamped.from_pose2d(Pose2D(3.0, 4.0, 0.0), "map", 0.25)
    sched.call_at(0.25, lambda: ActionClient(bus, "/navigate_to_pose").send_goal(
        NavigateToPoseGoal(goal)))
    sched.run_until(1.0)
    summary = rec.close()
    assert summary.counts == {"/map": 1, "/tf_static": 1, "/scan": 8, "/odom": 32, "/tf": 32,
                              "/cmd_vel": 8, "/goal_pose": 1,
                              "/navigate_to_pose/_action/status": 2}
    return path


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("rec") / "bag")


def test_rosbags_reads_types_counts_and_latched_qos(bag: Path) -> None:
    assert (bag / "metadata.yaml").exists() and list(bag.glob("*.mcap"))
    with AnyReader([bag]) as reader:
        conns = {c.topic: c for c in reader.connections}
        types = {t: c.msgtype for t, c in conns.items()}
        assert types == {"/map": "nav_msgs/msg/OccupancyGrid",
                         "/tf_static": "tf2_msgs/msg/TFMessage",
                         "/scan": "sensor_msgs/msg/LaserScan", "/odom": "nav_msgs/msg/Odometry",
                         "/tf": "tf2_msgs/msg/TFMessage", "/cmd_vel": "geometry_msgs/msg/Twist",
                         "/goal_pose": "geometry_msgs/msg/PoseStamped",
                         "/navigate_to_pose/_action/status": "action_msgs/msg/GoalStatusArray"}
        durable = {t for t, c in conns.items()
                   if c.ext.offered_qos_profiles[0].durability is QosDurability.TRANSIENT_LOCAL}
        assert durable == {"/map", "/tf_static"}
        scans = [(t, reader.deserialize(raw, c.msgtype)) for c, t, raw in
                 reader.messages(connections=[conns["/scan"]])]
    assert [t for t, _ in scans] == [int(k * 125_000_000) for k in range(1, 9)]
    assert scans[2][1].header.stamp.sec == 0 and scans[2][1].header.stamp.nanosec == 375_000_000
    assert scans[2][1].ranges.tolist() == [1.0, 2.0, 0.375, float("inf"), 3.0]


def test_reader_returns_the_recorded_messages(bag: Path) -> None:
    with BagReader(bag) as reader:
        assert reader.start_time == 0.0 and reader.end_time == 1.0
        assert reader.message_count == 85
        msgs = list(reader.messages(["/odom", "/map", "/tf_static"]))
    assert {m.topic for m in msgs[:2]} == {"/map", "/tf_static"}  # latched: at the start
    grid = next(m.msg for m in msgs if m.topic == "/map")
    assert np.array_equal(grid.data, GRID.data) and grid.info.resolution == 0.5
    odom = [m for m in msgs if m.topic == "/odom"]
    assert [m.log_time for m in odom] == [k * ODOM_DT for k in range(1, 33)]
    p = odom[10].msg.pose.pose.to_pose2d()
    t = 11 * ODOM_DT
    assert odom[10].msg.header.stamp == t
    assert (p.x, p.y) == (t, 0.5 * t) and p.theta == pytest.approx(0.1 * t, abs=1e-15)


def test_goal_pose_and_action_status_are_recorded(bag: Path) -> None:
    with BagReader(bag) as reader:
        goals = list(reader.messages(["/goal_pose"]))
        status = list(reader.messages(["/navigate_to_pose/_action/status"]))
    assert [(g.log_time, g.msg.to_pose2d()) for g in goals] == [(0.25, Pose2D(3.0, 4.0, 0.0))]
    assert [s.log_time for s in status] == [0.25, 0.75]
    first, last = (s.msg.status_list[0] for s in status)
    assert isinstance(status[0].msg, GoalStatusArray)
    assert (first.status, last.status) == (2, 4)  # EXECUTING, then SUCCEEDED
    assert first.goal_info == last.goal_info
    assert first.goal_info.stamp == 0.25 and first.goal_info.goal_id == (1).to_bytes(16, "big")


def test_player_replays_in_order_on_the_scheduler_clock(bag: Path) -> None:
    rt = runtime_for_bag(bag)
    seen: list[tuple[str, float]] = []
    rt.bus.add_tap(lambda topic, msg, now: seen.append((topic, now)))
    counts = BagPlayer(rt, bag).run()
    assert counts == {"/map": 1, "/tf_static": 1, "/scan": 8, "/odom": 32, "/tf": 32,
                      "/cmd_vel": 8, "/goal_pose": 1, "/navigate_to_pose/_action/status": 2}
    with BagReader(bag) as reader:
        recorded = [(m.topic, m.log_time) for m in reader.messages()]
    assert seen == recorded
    # the runtime's TF buffer was fed from the played /tf and /tf_static
    assert rt.tf.lookup_pose2d("odom", "base_link", 0.5).x == pytest.approx(0.5)
    assert rt.tf.lookup_pose2d("base_link", "laser").x == pytest.approx(0.1)


def test_player_loops_and_latches(bag: Path) -> None:
    rt = runtime_for_bag(bag)
    player = BagPlayer(rt, bag, ["/scan", "/map"], loop=True, max_loops=3)
    times: list[float] = []
    rt.bus.add_tap(lambda topic, msg, now: times.append(now) if topic == "/scan" else None)
    counts = player.run()
    assert counts == {"/scan": 24, "/map": 3} and player.loops_done == 3
    gap = 1.0 / 8  # duration / (messages - 1): 1 s span, 9 messages on the played topics
    second = [t - (1.0 + gap) for t in times[8:16]]
    assert second == pytest.approx(times[:8], abs=1e-9)
    late: list[OccupancyGrid] = []
    rt.bus.subscribe("/map", OccupancyGrid, late.append, LATCHED)  # joins after playback
    rt.scheduler.run_for(0.0)
    assert len(late) == 1 and np.array_equal(late[0].data, GRID.data)


def test_sqlite3_storage_reads_back_the_same(tmp_path: Path, bag: Path) -> None:
    other = record_small(tmp_path / "db", storage="sqlite3")
    assert list(other.glob("*.db3"))
    with BagReader(other) as a, BagReader(bag) as b:
        assert [(m.topic, m.log_time) for m in a.messages()] == \
            [(m.topic, m.log_time) for m in b.messages()]


def test_unsupported_topic_type_is_named(tmp_path: Path) -> None:
    rt = Runtime()
    rec = BagRecorder(rt, tmp_path / "bag", topics=["/planar"])
    with pytest.raises(UnsupportedTypeError, match="topic '/planar' carries Twist2D"):
        rt.bus.publisher("/planar", Twist2D).publish(Twist2D(1.0, 0.0, 0.0))
    rec.close()
    everything = BagRecorder(rt, tmp_path / "all", all_topics=True)
    rt.bus.publisher("/planar", Twist2D).publish(Twist2D(1.0, 0.0, 0.0))
    rt.bus.publisher("/cmd", Twist).publish(Twist())
    summary = everything.close()
    assert summary.counts == {"/cmd": 1} and list(summary.skipped) == ["/planar"]


def test_errors_name_the_file_and_the_fix(tmp_path: Path, bag: Path) -> None:
    with pytest.raises(BagNotFoundError) as err:
        BagReader(tmp_path / "nothere.bag")
    assert str(err.value) == (f"{tmp_path / 'nothere.bag'}: no such bag (give a rosbag2 folder "
                              f"with metadata.yaml, an .mcap or .db3 file, or a ROS 1 .bag file)")
    text = tmp_path / "notes.txt"
    text.write_text("hello")
    with pytest.raises(BagFormatError) as ferr:
        BagReader(text)
    assert str(ferr.value) == (f"{text}: unknown bag format '.txt' (expected a rosbag2 folder, "
                               f".mcap, .db3 or a ROS 1 .bag)")
    broken = tmp_path / "broken.bag"
    broken.write_bytes(b"#ROSBAG V2.0\nnot really")
    with pytest.raises(BagFormatError, match=r"broken.bag: not a readable bag \("):
        BagReader(broken).open()
    with pytest.raises(BagExistsError) as eerr:
        BagRecorder(Runtime(), tmp_path)  # a folder that is not a bag
    assert str(eerr.value) == (f"{tmp_path}: output folder exists and is not a bag navstack "
                               f"wrote; remove it or choose another output path")


def test_fast_mcap_writer_writes_the_bytes_rosbags_writes(tmp_path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer

    from navstack.runtime.recording.convert import humble_typestore
    from navstack.runtime.recording.mcap_fast import FastWriter

    store = humble_typestore()
    payloads = [bytes(range(k % 50 + 4)) * 300 for k in range(900)]  # > 1 MiB: 2+ chunks
    files = []
    for cls, name in ((Writer, "ref"), (FastWriter, "fast")):
        w = cls(tmp_path / name / "bag", version=8, storage_plugin=StoragePlugin.MCAP)
        w.open()
        a = w.add_connection("/a", "std_msgs/msg/String", typestore=store)
        b = w.add_connection("/b", "std_msgs/msg/String", typestore=store)
        for k, data in enumerate(payloads):
            w.write(a if k % 3 else b, 1_000_000 * (900 - k) if k < 5 else 10**9 + k, data)
        w.close()
        files.append((tmp_path / name / "bag" / "bag.mcap").read_bytes())
        files.append((tmp_path / name / "bag" / "metadata.yaml").read_bytes())
    assert len(files[0]) > 2**20 and files[0] == files[2] and files[1] == files[3]
