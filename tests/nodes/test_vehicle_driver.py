"""VehicleDriverNode over real links with a hand-driven far side: commands at a fixed
rate, stale and NaN commands, telemetry to /odom /imu /gps/fix /joint_states, malformed
packets counted, the watchdog's hold, the vehicle YAML's errors."""

from __future__ import annotations

import math
import socket
import struct
import time
from pathlib import Path

import numpy as np
import pytest

from navstack.core.errors import ConfigError
from navstack.core.msgs import (
    DiagnosticStatus,
    Imu,
    JointState,
    NavigationHold,
    NavSatFix,
    Odometry,
    Twist,
)
from navstack.drivers.cart_sensors import CartSensorSample, encode_sensor_line
from navstack.drivers.config import load_vehicle, vehicle_from_mapping
from navstack.drivers.golf_cart import decode_cart_command
from navstack.drivers.rover_telemetry import (
    RoverGnssPacket,
    RoverOdometryPacket,
    encode_rover_gnss,
    encode_rover_odometry,
)
from navstack.drivers.rover_vcu import decode_vcu_command
from navstack.nodes.vehicle_driver import VehicleDriverNode
from navstack.runtime.bus import QoS
from navstack.runtime.node import Runtime


def _vcu_socket() -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(1.0)
    return s


def _rover(vcu: socket.socket, watchdog: float = 0.3) -> tuple[Runtime, VehicleDriverNode]:
    host, port = vcu.getsockname()
    config = vehicle_from_mapping({
        "type": "rover_vcu", "links": {"vcu": {"type": "udp", "bind": "127.0.0.1:0",
                                               "remote": f"{host}:{port}"}},
        "command": {"rate_hz": 10.0, "timeout": 0.5}, "watchdog": {"timeout": watchdog}})
    rt = Runtime()
    driver = VehicleDriverNode(rt, config, threaded=False)
    rt.bring_up()
    return rt, driver


def _recv_all(s: socket.socket) -> list[bytes]:
    out = []
    s.settimeout(0.2)
    try:
        while True:
            out.append(s.recv(100))
    except TimeoutError:
        pass
    return out


def test_rover_commands_telemetry_and_watchdog() -> None:
    vcu = _vcu_socket()
    rt, driver = _rover(vcu)
    try:
        odom: list[Odometry] = []
        fixes: list[NavSatFix] = []
        joints: list[JointState] = []
        holds: list[NavigationHold] = []
        status: list[DiagnosticStatus] = []
        rt.bus.subscribe("/odom", Odometry, odom.append)
        rt.bus.subscribe("/gps/fix", NavSatFix, fixes.append)
        rt.bus.subscribe("/joint_states", JointState, joints.append)
        rt.bus.subscribe("/navigation/hold", NavigationHold, holds.append)
        rt.bus.subscribe("/vehicle/status", DiagnosticStatus, status.append)
        cmd = rt.bus.publisher("/cmd_vel", Twist)
        cmd.publish(Twist.planar(0.5, 0.0, 0.29))
        rt.scheduler.run_for(0.25)  # sent at once, then repeated at 10 Hz
        got = [decode_vcu_command(p) for p in _recv_all(vcu)]
        assert len(got) >= 3
        assert all((c.linear_x, c.angular_z, c.mode) == (0.5, 0.29, "auto") for c in got)
        cmd.publish(Twist.planar(math.nan, 0.0, 0.0))  # refused, counted
        rt.scheduler.run_for(0.01)
        assert driver.rejected_commands == 1
        driver_addr = driver.transports["vcu"].local_address  # type: ignore[attr-defined]
        # telemetry: odometry at 50 Hz for 1 s (0.4 m/s, 0.1 rad/s) and one GNSS fix
        for k in range(50):
            vcu.sendto(encode_rover_odometry(RoverOdometryPacket(
                k, 1000 + 20 * k, 0.36, 0.44, 0.1, 0.0, 2)), driver_addr)
            if k == 10:
                vcu.sendto(encode_rover_gnss(RoverGnssPacket(38.4, -110.8, 1380.0, 90.0, 0.4,
                                                             1.5, 2.5, 3, 10, 0)), driver_addr)
                vcu.sendto(b"garbage", driver_addr)  # malformed: counted
            time.sleep(0.001)
            rt.scheduler.run_for(0.02)
        time.sleep(0.05)
        rt.scheduler.run_for(0.02)
        assert len(odom) == 50
        o = odom[-1]
        assert o.twist.twist.linear.x == pytest.approx(0.4, abs=1e-6)
        assert o.twist.twist.angular.z == pytest.approx(0.1, abs=1e-6)
        # 49 intervals of 20 ms at 0.4 m/s, turning 0.1 rad/s
        assert o.pose.pose.to_pose2d().theta == pytest.approx(0.098, abs=1e-6)
        assert o.pose.pose.position.x == pytest.approx(0.392, abs=2e-3)
        assert len(fixes) == 1 and fixes[0].latitude == pytest.approx(38.4)
        assert fixes[0].position_covariance[0, 0] == pytest.approx(1.5 ** 2, rel=1e-6)
        assert joints[-1].name == ("left_wheel_joint", "right_wheel_joint")
        assert joints[-1].velocity[0] == pytest.approx(0.36 / 0.225, rel=1e-6)
        stats = driver.transports["vcu"].stats
        assert stats.malformed == 1 and "length 7" in stats.last_malformed
        assert not driver.watchdog.lost
        # silence: lost within 0.3 s + one poll, stop packets, hold published
        t0 = rt.now
        rt.scheduler.run_for(0.4)
        assert driver.watchdog.lost and driver.watchdog.lost_at - t0 <= 0.32
        assert holds and holds[-1].hold and holds[-1].reason.startswith("link lost")
        assert status[-1].level == DiagnosticStatus.ERROR
        _recv_all(vcu)
        cmd.publish(Twist.planar(0.5, 0.0, 0.2))
        rt.scheduler.run_for(0.15)
        assert all(decode_vcu_command(p).linear_x == 0.0 for p in _recv_all(vcu))
        # three packets in a row restore it
        for k in range(3):
            vcu.sendto(encode_rover_odometry(RoverOdometryPacket(60 + k, 3000 + 20 * k, 0, 0,
                                                                 0, 0, 0)), driver_addr)
            time.sleep(0.01)
            rt.scheduler.run_for(0.02)
        assert not driver.watchdog.lost and holds[-1].hold is False
    finally:
        rt.shut_down()
        vcu.close()


def test_stale_command_becomes_zero() -> None:
    vcu = _vcu_socket()
    rt, _ = _rover(vcu, watchdog=5.0)
    try:
        rt.bus.publisher("/cmd_vel", Twist).publish(Twist.planar(1.0, 0.0, 0.0))
        rt.scheduler.run_for(0.45)
        assert all(decode_vcu_command(p).linear_x == 1.0 for p in _recv_all(vcu))
        rt.scheduler.run_for(0.3)  # older than the 0.5 s timeout now
        late = [decode_vcu_command(p) for p in _recv_all(vcu)]
        assert late and late[-1].linear_x == 0.0
    finally:
        rt.shut_down()
        vcu.close()


def test_golf_cart_over_loop_urls() -> None:
    """loop:// links: the sensor line written into the port comes back to the driver;
    the steering packets are the '<fi' encoding of the physical steering angle."""
    config = vehicle_from_mapping({
        "type": "golf_cart",
        "links": {"steering": {"type": "serial", "port": "loop://"},
                  "sensors": {"type": "serial", "port": "loop://"}},
        "imu_calibration": {"accel": {"b": [0.1, 0.0, 0.0]}}})
    rt = Runtime()
    driver = VehicleDriverNode(rt, config, threaded=False)
    written: list[bytes] = []
    driver.command_listeners.append(lambda p, _w: written.append(p))
    imu: list[Imu] = []
    odom: list[Odometry] = []
    rt.bus.subscribe("/imu", Imu, imu.append)
    rt.bus.subscribe("/odom", Odometry, odom.append)
    rt.bring_up()
    try:
        rt.bus.publisher("/cmd_vel", Twist).publish(Twist.planar(1.0, 0.0, 0.1))
        rt.scheduler.run_for(0.01)
        c = decode_cart_command(written[0])
        assert c.speed_kmh == pytest.approx(3.6) and c.steps == -int(math.atan(0.24) * 497.84)
        sensors = driver.transports["sensors"]
        for k in range(3):
            sensors.write(encode_sensor_line(CartSensorSample(
                k, 100 + 20 * k, k, 1.0, (0.2, 0.0, 9.8), (0.0, 0.0, 0.1), (20.0, 0.0, -40.0))))
        time.sleep(0.05)
        rt.scheduler.run_for(0.02)
        assert len(odom) == 3 and odom[-1].twist.twist.linear.x == pytest.approx(1.0)
        assert imu[-1].linear_acceleration.x == pytest.approx(0.1)  # A (raw - b)
        assert imu[-1].orientation_covariance[0, 0] == -1.0
    finally:
        rt.shut_down()


def test_vehicle_yaml_errors(tmp_path: Path) -> None:
    f = tmp_path / "v.yaml"
    f.write_text("type: golf_cart\nlinks:\n  steering: {type: serial, port: /dev/ttyACM0}\n")
    with pytest.raises(ConfigError, match="needs link\\(s\\) sensors"):
        load_vehicle(f)
    f.write_text("type: rover_vcu\nlinks:\n  vcu: {type: udp}\n")
    with pytest.raises(ConfigError, match="udp link needs bind"):
        load_vehicle(f)
    f.write_text("type: rover_vcu\nlinks:\n  vcu: {type: udp, bind: '0.0.0.0:1'}\n"
                 "command: {rate_hzz: 20}\n")
    with pytest.raises(ConfigError, match="rate_hzz"):
        load_vehicle(f)
    f.write_text("type: tractor\nlinks: {}\n")
    with pytest.raises(ConfigError, match=str(f)):
        load_vehicle(f)


def test_ten_thousand_random_datagrams_are_counted_and_the_link_stays_up() -> None:
    """Acceptance 4 through the driver: random bytes, truncated and NaN-laden packets on
    the rover's UDP link, interleaved with valid odometry -- every bad one is counted,
    no exception escapes, every valid one is published and the link is never lost."""
    vcu = _vcu_socket()
    rt, driver = _rover(vcu, watchdog=0.3)
    odom: list[Odometry] = []
    rt.bus.subscribe("/odom", Odometry, odom.append, QoS(depth=1000))
    rng = np.random.default_rng(7)
    good = encode_rover_odometry(RoverOdometryPacket(0, 0, 0.1, 0.1, 0.0, 0.0, 0))
    addr = driver.transports["vcu"].local_address  # type: ignore[attr-defined]
    bad = valid = 0
    try:
        for k in range(10_000):
            kind = k % 4
            if kind == 0:
                packet = rng.bytes(int(rng.integers(0, 64)))
            elif kind == 1:
                packet = good[:int(rng.integers(0, len(good)))]
            elif kind == 2:
                packet = good[:14] + struct.pack("<f", float("nan")) + good[18:]
            else:
                packet = encode_rover_odometry(RoverOdometryPacket(
                    k % 65536, 20 * k, 0.1, 0.1, 0.0, 0.0, 0))
            if packet == good or (kind == 3):
                valid += 1
            else:
                bad += 1
            vcu.sendto(packet, addr)
            if k % 50 == 49:
                time.sleep(0.002)
                rt.scheduler.run_for(0.02)
        time.sleep(0.05)
        rt.scheduler.run_for(0.02)
        stats = driver.transports["vcu"].stats
        assert stats.malformed == bad and len(odom) == valid
        assert driver.watchdog.losses == 0 and driver.transports["vcu"].is_open
    finally:
        rt.shut_down()
        vcu.close()
