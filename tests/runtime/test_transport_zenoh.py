"""The Zenoh transport on loopback: CDR payloads readable by rosbags (issue 21 acceptance
7), rmw_zenoh keys, latched late joiners, clock estimation and compensation, remote
services and actions, blackouts and the robot's link watchdog."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest
import zenoh

from navstack.core.msgs import Header, OccupancyGrid, Odometry, Twist
from navstack.nodes.link_watchdog import LinkWatchdog
from navstack.runtime.actions import ActionClient, ActionServer, GoalHandle, GoalStatus
from navstack.runtime.bus import LATCHED, QoS
from navstack.runtime.recording.convert import RosCodec, humble_typestore
from navstack.runtime.transports.keys import dds_type_name, topic_key
from navstack.runtime.transports.remote_calls import (
    ActionProxy,
    LinkError,
    proxy_service,
    serve_action,
    serve_service,
)
from tests.runtime.test_recording_convert import SAMPLES, _equal
from tests.runtime.zenoh_helpers import link_pair, run_both

CODEC = RosCodec()


def _ros_type_from_key(key: str) -> str:
    """``0/t/X/sensor_msgs::msg::dds_::LaserScan_/RIHS01_..`` -> ``sensor_msgs/msg/LaserScan``."""
    dds = key.split("/")[-2]
    pkg, kind, _, name = dds.split("::")
    return f"{pkg}/{kind}/{name[:-1]}"


def test_every_published_type_decodes_with_rosbags_from_its_key() -> None:
    robot, base = link_pair()
    got: list[tuple[str, bytes]] = []
    raw = base.session.declare_subscriber(
        "0/t/**", lambda s: got.append((str(s.key_expr), s.payload.to_bytes())))
    try:
        time.sleep(0.5)  # the subscriber's declaration reaches the robot
        pubs = []
        for msg in SAMPLES:
            name = f"/t/{type(msg).__name__}"
            robot.export_topic(name, type(msg))
            pubs.append((robot.runtime.bus.publisher(name, type(msg)), msg))
        time.sleep(0.3)
        for pub, msg in pubs:
            pub.publish(msg)
        deadline = time.monotonic() + 5.0
        while len(got) < len(SAMPLES) and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        raw.undeclare()
        robot.close()
        base.close()
    assert len(got) == len(SAMPLES)
    store = humble_typestore()
    by_name = {f"t/{type(m).__name__}": m for m in SAMPLES}
    for key, payload in got:
        ros_type = _ros_type_from_key(key)
        assert key.endswith(store.hash_rihs01(ros_type))
        decoded = store.deserialize_cdr(payload, ros_type)  # rosbags' own deserializer
        sent = by_name[key.split("/", 1)[1].rsplit("/", 2)[0]]
        back = CODEC.from_ros(ros_type, decoded)
        if type(back) is type(sent):  # PointCloud2 reads back as the xyz PointCloud
            assert _equal(back, sent), key


def test_keys_follow_rmw_zenoh() -> None:
    assert dds_type_name("sensor_msgs/msg/LaserScan") == "sensor_msgs::msg::dds_::LaserScan_"
    key = topic_key(0, "/robot1/scan", "sensor_msgs/msg/LaserScan")
    assert key.startswith("0/robot1/scan/sensor_msgs::msg::dds_::LaserScan_/RIHS01_")
    assert len(key.rsplit("_", 1)[1]) == 64


def test_latched_map_reaches_a_late_joiner_and_stamps_are_compensated() -> None:
    robot, base = link_pair(robot_offset=2.0)
    grid = next(s for s in SAMPLES if isinstance(s, OccupancyGrid))  # stamped 0.0
    try:
        robot.export_topic("/map", OccupancyGrid, qos=LATCHED)
        robot.export_topic("/odom", Odometry)
        map_pub = robot.runtime.bus.publisher("/map", OccupancyGrid, LATCHED)
        map_pub.publish(grid)  # before anyone imports it
        odom_pub = robot.runtime.bus.publisher("/odom", Odometry)
        robot.scheduler.create_timer(0.05, lambda: odom_pub.publish(
            Odometry(Header(robot.scheduler.now, "odom"), "base_link")))
        maps: list[OccupancyGrid] = []
        errors: list[float] = []
        base.import_topic("/map", OccupancyGrid, peer="robot", qos=LATCHED)
        base.import_topic("/odom", Odometry, peer="robot", qos=QoS(depth=10))
        rt = base.runtime
        rt.bus.subscribe("/map", OccupancyGrid, maps.append, LATCHED)
        rt.bus.subscribe("/odom", Odometry, lambda o: errors.append(
            base.scheduler.clock() - o.header.stamp))
        run_both(robot, base, 3.0)
        offset = base.offset("robot")
    finally:
        robot.close()
        base.close()
    assert maps and _equal(maps[0].data, grid.data) and _equal(maps[0].info, grid.info)
    assert maps[0].header.stamp == pytest.approx(-2.0, abs=0.005)  # moved to the base clock
    assert abs(offset - 2.0) < 0.005
    assert len(errors) > 10
    # compensated stamps land on the base's clock: a few ms of transit, not 2 s
    assert 0.0 <= float(np.median(errors)) < 0.05


def test_without_compensation_stamps_keep_the_robot_clock() -> None:
    robot, base = link_pair(robot_offset=-2.0, base_kw={"clock": {"compensate": False}})
    try:
        robot.export_topic("/odom", Odometry)
        base.import_topic("/odom", Odometry, peer="robot")
        pub = robot.runtime.bus.publisher("/odom", Odometry)
        robot.scheduler.create_timer(0.05, lambda: pub.publish(
            Odometry(Header(robot.scheduler.now, "odom"), "base_link")))
        ages: list[float] = []
        base.runtime.bus.subscribe("/odom", Odometry, lambda o: ages.append(
            base.scheduler.clock() - o.header.stamp))
        run_both(robot, base, 2.0)
        health = base.health()["robot"]
    finally:
        robot.close()
        base.close()
    assert ages and 1.95 < float(np.median(ages)) < 2.05  # stamps 2 s in the past
    assert abs(float(health["offset_s"]) + 2.0) < 0.005
    assert health["compensated"] is False


class _Counter:
    """An action server on the robot: counts to ``goal`` with feedback, then succeeds."""

    def __init__(self, link: Any) -> None:
        self.sched = link.scheduler
        self.server: ActionServer[int] = ActionServer(link.runtime.bus, "/count", self.on_goal)

    def on_goal(self, handle: GoalHandle[int]) -> bool | str:
        if handle.goal < 0:
            return f"cannot count to {handle.goal}"
        for i in range(handle.goal):
            self.sched.call_later(0.05 * (i + 1), handle.publish_feedback, i + 1)
        self.sched.call_later(0.05 * (handle.goal + 1), handle.succeed, handle.goal * 10)
        return True


def test_remote_action_and_service() -> None:
    robot, base = link_pair()
    try:
        _Counter(robot)
        robot.runtime.bus.advertise_service("/double", lambda x: 2 * x)
        serve_action(robot, "/count", "base")
        serve_service(robot, "/double", "base")
        ActionProxy(base, "/count", "/count", "robot")
        proxy_service(base, "/double", "/double", "robot")
        run_both(robot, base, 1.0, until=lambda: base.ready("robot"))
        client: ActionClient[int] = ActionClient(base.runtime.bus, "/count")
        feedback: list[int] = []
        handles: list[GoalHandle[int]] = []
        answers: list[Any] = []

        def start() -> None:  # from inside the base's loop, while the robot's runs
            handles.append(client.send_goal(4, feedback.append))
            handles.append(client.send_goal(-1))
            answers.append(base.runtime.bus.call("/double", 21))

        base.scheduler.call_later(0.1, start)
        run_both(robot, base, 3.0, until=lambda: bool(handles) and handles[0].done)
        handle, rejected = handles
        answer = answers[0]
    finally:
        robot.close()
        base.close()
    assert handle.status is GoalStatus.SUCCEEDED
    assert handle.result is not None and handle.result.result == 40
    assert feedback == [1, 2, 3, 4]
    assert rejected.status is GoalStatus.REJECTED
    assert rejected.result is not None and "cannot count to -1" in rejected.result.error_msg
    assert answer == 42


def test_a_service_without_its_server_is_a_link_error_naming_the_peer() -> None:
    robot, base = link_pair()
    try:
        proxy_service(base, "/nobody", "/nobody", "robot")
        with pytest.raises(LinkError, match="service '/nobody' on 'robot': no answer"):
            base.runtime.bus.call("/nobody", 1)
    finally:
        robot.close()
        base.close()


def test_blackout_stops_the_robot_within_half_a_second_and_it_resumes() -> None:
    robot, base = link_pair(robot_kw={"impairments": {"blackouts": [[2.0, 2.0]]}})
    try:
        rt = robot.runtime
        dog = LinkWatchdog(rt, lambda: robot.peer_up("base"))
        pub = rt.bus.publisher("/cmd_vel_guarded", Twist, QoS(depth=1))
        rt.scheduler.create_timer(0.05, lambda: pub.publish(Twist.planar(0.3, 0.0, 0.1)))
        cmds: list[tuple[float, float]] = []
        rt.bus.subscribe("/cmd_vel", Twist, lambda c: cmds.append((rt.now, c.linear.x)),
                         QoS(depth=100))
        rt.bring_up()
        run_both(base, robot, 5.5)
        start = robot.opened_at + 2.0
    finally:
        robot.close()
        base.close()
    assert len(dog.stops) >= 1 and len(dog.resumes) >= 1
    stop = next(t for t in dog.stops if t >= start)
    assert stop - start <= 0.5
    during = [vx for t, vx in cmds if stop <= t < start + 2.0]
    assert during and all(vx == 0.0 for vx in during)
    assert any(vx == 0.3 for t, vx in cmds if t > start + 2.5)  # resumed, no restart


def test_bad_endpoint_is_a_config_error() -> None:
    from navstack.core.errors import ConfigError
    from navstack.runtime.transports.config import TransportSection

    with pytest.raises(ConfigError, match=r"127\.0\.0\.1:7447.*<protocol>/<address>"):
        TransportSection.from_mapping({"kind": "zenoh", "listen": ["127.0.0.1:7447"]},
                                      file="stack.yaml", key_path="transport.robot")


def test_zenoh_is_importable_in_the_venv() -> None:
    assert hasattr(zenoh, "open")
