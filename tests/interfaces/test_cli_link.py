"""`navstack link monitor` / `link replay` on loopback UDP, and `navstack drive`."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

from typer.testing import CliRunner

from navstack.app import app
from navstack.drivers.packet_log import read_packet_log
from navstack.drivers.rover_telemetry import RoverOdometryPacket, encode_rover_odometry

runner = CliRunner()


def _free_udp_port() -> int:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = int(s.getsockname()[1])
    s.close()
    return port


def test_monitor_decodes_logs_and_replay_sends_back(tmp_path: Path) -> None:
    port = _free_udp_port()
    packets = [b"104510123001", encode_rover_odometry(RoverOdometryPacket(
        7, 1234, 0.5, 0.75, 0.25, 0.0, 1)), b"10451012300X"]

    def send() -> None:
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline:  # wait until the monitor holds the port
            probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                probe.bind(("0.0.0.0", port))
            except OSError:
                break
            finally:
                probe.close()
            time.sleep(0.02)
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        for p in packets:
            s.sendto(p, ("127.0.0.1", port))
            time.sleep(0.02)
        s.close()

    threading.Thread(target=send, daemon=True).start()
    log = tmp_path / "run.jsonl"
    result = runner.invoke(app, ["link", "monitor", "--udp", str(port), "--count", "3",
                                 "--duration", "30", "--log", str(log)])
    assert result.exit_code == 0, result.output
    out = result.output
    assert "VCU command 104510123001: linear_x +0.123 m/s, angular_z +0.45 rad/s, LED auto" \
        in out
    assert "odometry #7 t=1234 ms: tracks +0.500 / +0.750 m/s" in out and "E-STOP" in out
    assert "MALFORMED rover telemetry: length 12" not in out
    assert "MALFORMED rover VCU command: non-digit character" in out
    assert "3 packets: 2 decoded, 1 malformed" in out
    header, logged = read_packet_log(log)
    assert header["protocol"] == "rover_vcu" and [p.data for p in logged] == packets
    # replay the log to a listening socket, as fast as possible
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(2.0)
    target = f"127.0.0.1:{rx.getsockname()[1]}"
    result = runner.invoke(app, ["link", "replay", str(log), "--to", target, "--rate", "0"])
    assert result.exit_code == 0, result.output
    assert f"sent 3 of 3 packets from {log}" in result.output
    assert [rx.recv(100) for _ in range(3)] == packets
    rx.close()


def test_link_cli_errors(tmp_path: Path) -> None:
    r = runner.invoke(app, ["link", "monitor"])
    assert r.exit_code == 2 and "exactly one of --udp PORT or --serial DEVICE" in r.output
    r = runner.invoke(app, ["link", "monitor", "--udp", "1", "--protocol", "morse"])
    assert r.exit_code == 2 and "unknown link protocol 'morse'" in r.output
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"hello": 1}\n')
    r = runner.invoke(app, ["link", "replay", str(bad), "--to", "127.0.0.1:9"])
    assert r.exit_code == 2 and "not a navstack packet log header" in r.output
    r = runner.invoke(app, ["drive", "--vehicle", str(tmp_path / "missing.yaml")])
    assert r.exit_code == 2 and "missing.yaml" in r.output
    r = runner.invoke(app, ["demo", "--robot", "rover", "--link", "serial",
                            "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "use --link udp" in r.output


def test_drive_sends_the_bring_up_command(tmp_path: Path) -> None:
    vcu = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    vcu.bind(("127.0.0.1", 0))
    vcu.settimeout(2.0)
    f = tmp_path / "rover.yaml"
    f.write_text("type: rover_vcu\nlinks:\n  vcu: {type: udp, bind: '127.0.0.1:0', "
                 f"remote: '127.0.0.1:{vcu.getsockname()[1]}'}}\n"
                 "command: {rate_hz: 20}\n")
    r = runner.invoke(app, ["drive", "--vehicle", str(f), "--cmd", "0.1,0.0",
                            "--duration", "0.6"])
    assert r.exit_code == 0, r.output
    got = []
    vcu.settimeout(0.2)
    try:
        while True:
            got.append(vcu.recv(100))
    except TimeoutError:
        pass
    vcu.close()
    assert b"000010100001" in got  # 0.1 m/s forward, auto
    assert got[-1] == b"000000000001"  # the link is lost (silent VCU) or the driver stops
    assert "link lost" in r.output and "driver stopped:" in r.output
