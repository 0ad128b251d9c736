"""Dashboard hardening (issue 18, part 7): one test per finding of the probe.

Wall-clock budgets (the e-stop round trip under a 400-viewer flood) are measured by
``navstack bench safety``; these tests assert the behaviour: caps, refusals, close codes,
status codes, bytes read, and that every e-stop under the flood still latches within one
control cycle of simulated time.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import shutil
import socket
import struct
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import ClientConnection, connect

from navstack.benchmarks import flood_client
from navstack.interfaces.stack import NavStack
from navstack.interfaces.web import DashboardHandle, serve_dashboard
from tests.interfaces.web.conftest import TOKEN, Base, Live, wait_until

CONTROL_PERIOD = 0.05
FLOOD = Path(flood_client.__file__)


def _ws_url(live: Live) -> str:
    return live.handle.url.replace("http://", "ws://") + "ws"


def _handshake(port: int) -> socket.socket:
    """A raw WebSocket client socket after a successful upgrade (no token)."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    assert head.startswith(b"HTTP/1.1 101"), head
    return sock


def _read_close_code(sock: socket.socket) -> int | None:
    """Read server frames until a close frame; its status code (None if the connection
    ended without one)."""
    buf = b""
    sock.settimeout(10)
    while True:
        try:
            chunk = sock.recv(65536)
        except (ConnectionResetError, TimeoutError):
            return None
        if not chunk:
            return None
        buf += chunk
        while len(buf) >= 2:
            opcode, n = buf[0] & 0x0F, buf[1] & 0x7F
            off = 2
            if n == 126:
                if len(buf) < 4:
                    break
                n, off = struct.unpack(">H", buf[2:4])[0], 4
            elif n == 127:
                if len(buf) < 10:
                    break
                n, off = struct.unpack(">Q", buf[2:10])[0], 10
            if len(buf) < off + n:
                break
            payload, buf = buf[off:off + n], buf[off + n:]
            if opcode == 0x8:
                return int(struct.unpack(">H", payload[:2])[0]) if len(payload) >= 2 else None


def test_big_unauthenticated_frame_is_refused_after_reading_at_most_64_kib(live: Live) -> None:
    port = live.handle.port
    sock = _handshake(port)
    size = 16 * 2**20
    mask = os.urandom(4)
    sock.sendall(bytes([0x81, 0xFF]) + struct.pack(">Q", size) + mask)  # text, masked
    chunk = os.urandom(65536)
    sent = 0
    try:
        while sent < size:
            sock.sendall(chunk)
            sent += len(chunk)
    except (BrokenPipeError, ConnectionResetError, TimeoutError):
        pass
    assert sent < size  # the server stopped taking the frame
    code = _read_close_code(sock)
    sock.close()
    stats = live.handle.read_stats
    assert stats is not None
    refused = wait_until(lambda: stats.refused(1009), 10, "the refused connection's record")
    assert code in (1009, None)  # 1009 "message too big" (the RST may overtake it)
    assert len(refused) == 1
    assert refused[0].bytes_read <= 64 * 1024
    print(f"refused a {size} byte frame after reading {refused[0].bytes_read} bytes")
    assert live.client.get("/api/hello").status_code == 200  # the server is fine


def test_malformed_websocket_json_gets_a_close_frame(live: Live) -> None:
    with connect(_ws_url(live), open_timeout=10) as ws:
        ws.send("{not json")
        error = None
        with pytest.raises(ConnectionClosed) as closed:
            while True:
                msg = json.loads(ws.recv(timeout=10))
                if msg["type"] == "error":
                    error = msg
    assert error is not None and error["status"] == 422
    assert error["error"].startswith("messages must be JSON: body is not JSON")
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1007
    with connect(_ws_url(live), open_timeout=10) as ws:
        ws.send("[" * 5000 + "]" * 5000)
        with pytest.raises(ConnectionClosed) as closed:
            while True:
                ws.recv(timeout=10)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1007
    assert "nested 5000 levels" in closed.value.rcvd.reason


def test_foreign_origin_and_host_are_refused(live: Live) -> None:
    own = f"http://127.0.0.1:{live.handle.port}"
    r = live.client.get("/api/state", headers={"Origin": "http://evil.example"})
    assert r.status_code == 403
    assert r.json()["error"] == "cross-site request from Origin 'http://evil.example' refused"
    r = live.client.post("/api/estop", json={}, headers={**live.auth(),
                                                        "Origin": "http://evil.example"})
    assert r.status_code == 403 and not live.runner.estop.latched
    r = live.client.get("/api/state", headers={"Host": "rebind.evil.example"})
    assert r.status_code == 403 and "Host 'rebind.evil.example'" in r.json()["error"]
    assert live.client.get("/api/state", headers={"Origin": own}).status_code == 200
    assert live.client.get("/api/state", headers={"Origin": f"http://localhost:"
                                                            f"{live.handle.port}"}
                           ).status_code == 200
    with pytest.raises(InvalidStatus) as refused:
        connect(_ws_url(live), origin="http://evil.example", open_timeout=10)  # type: ignore[arg-type]
    assert refused.value.response.status_code == 403
    with connect(_ws_url(live), origin=own, open_timeout=10) as ws:  # type: ignore[arg-type]
        assert json.loads(ws.recv(timeout=10))["type"] == "hello"


def test_bodies_nested_oversized_and_goal_bounds_get_4xx(live: Live) -> None:
    auth = {**live.auth(), "Content-Type": "application/json"}
    nested = b'{"x": ' + b"[" * 3000 + b"]" * 3000 + b', "y": 1}'
    r = live.client.post("/api/goal", content=nested, headers=auth)
    assert r.status_code == 422
    assert r.json()["error"] == ("body is not JSON within the limits: nested 3001 levels "
                                 "deep; at most 16 allowed")
    # a big body is refused from its Content-Length, before it is read
    with socket.create_connection(("127.0.0.1", live.handle.port), timeout=10) as sock:
        sock.sendall((f"POST /api/goal HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer "
                      f"{TOKEN}\r\nContent-Type: application/json\r\nContent-Length: "
                      f"{16 * 2**20}\r\n\r\n").encode() + b"[" * 1000)
        reply = b""
        while chunk := sock.recv(4096):
            reply += chunk
    assert reply.startswith(b"HTTP/1.1 413 ")
    assert reply.endswith(b'{"error": "body of 16777216 bytes is larger than 65536 bytes"}')
    r = live.client.post("/api/goal", content=b'{"x": 1, "y": ', headers=auth)
    assert r.status_code == 422 and r.json()["error"].startswith("body is not JSON")
    r = live.client.post("/api/goal", json={"x": 1e300, "y": 5.0}, headers=live.auth())
    assert r.status_code == 422
    assert r.json()["error"] == ("invalid 'goal' command: x: Input should be less than or "
                                 "equal to 100000000")
    r = live.client.post("/api/goal", json={"x": 100.0, "y": 5.0}, headers=live.auth())
    assert r.status_code == 422
    assert r.json()["error"] == ("invalid 'goal' command: x: x=100 is outside the map: x must "
                                 "lie in [0, 20] m (map frame)")
    r = live.client.post("/api/waypoints", json={"x": 5.0, "y": -3.0}, headers=live.auth())
    assert r.status_code == 422 and "y=-3 is outside the map" in r.json()["error"]
    assert live.state()["nav"]["status"] == "IDLE" and live.state()["waypoints"] == []


def test_rate_limit_spares_the_authenticated_estop() -> None:
    handle = serve_dashboard(NavStack("office", seed=1), "127.0.0.1", 0, TOKEN,
                             real_time_factor=None,
                             security={"http_rate": 0.2, "http_burst": 5},
                             announce=lambda _: None)
    auth = {"Authorization": f"Bearer {TOKEN}"}
    try:
        with httpx.Client(base_url=handle.url, timeout=15.0) as client:
            codes = [client.get("/api/hello").status_code for _ in range(8)]
            assert codes[:5] == [200] * 5 and 429 in codes[5:]
            r = client.get("/api/hello")
            assert r.status_code == 429 and int(r.headers["retry-after"]) >= 1
            assert r.json()["error"].startswith("too many requests from 127.0.0.1; retry in")
            r = client.post("/api/estop", json={}, headers=auth)
            assert r.status_code == 200 and handle.runner.estop.latched
            assert client.post("/api/estop", json={}).status_code == 429  # no token: limited
            assert client.post("/api/estop/release", headers=auth).status_code == 429
    finally:
        handle.stop()


def test_viewer_caps_refuse_extra_connections_with_1013() -> None:
    stack = NavStack("office", seed=1)
    handle = serve_dashboard(stack, "127.0.0.1", 0, TOKEN, real_time_factor=None,
                             security={"max_viewers": 3, "max_viewers_per_client": 2},
                             announce=lambda _: None)
    url = handle.url.replace("http://", "ws://") + "ws"
    try:
        with contextlib.ExitStack() as stack_:
            first = stack_.enter_context(connect(url, open_timeout=10))
            second = stack_.enter_context(connect(url, open_timeout=10))
            _viewer_caps(handle, url, first, second)
    finally:
        handle.stop()


def _viewer_caps(handle: DashboardHandle, url: str, first: ClientConnection,
                 second: ClientConnection) -> None:
    with connect(url, open_timeout=10) as third, pytest.raises(ConnectionClosed) as c:
        third.recv(timeout=10)
    assert c.value.rcvd is not None and c.value.rcvd.code == 1013
    assert c.value.rcvd.reason == "too many viewers from 127.0.0.1 (2); close other tabs"
    assert json.loads(first.recv(timeout=10))["type"] == "hello"
    second.close()
    wait_until(lambda: handle.viewers is not None and handle.viewers.total == 1, 10,
               "the closed viewer to be released")
    with connect(url, open_timeout=10) as again:
        assert json.loads(again.recv(timeout=10))["type"] == "hello"


@pytest.fixture
def flooded() -> Iterator[tuple[Live, subprocess.Popen[str], str]]:
    stack = NavStack("office", seed=1)
    handle = serve_dashboard(stack, "127.0.0.1", 0, TOKEN, real_time_factor=1.0,
                             security={"max_viewers": 400, "max_viewers_per_client": 400,
                                       "http_burst": 1000},
                             announce=lambda _: None)
    live = Live(handle, httpx.Client(base_url=handle.url, timeout=15.0), Base())
    live.base.install(handle.runner)
    proc = subprocess.Popen([sys.executable, str(FLOOD),
                             handle.url.replace("http://", "ws://") + "ws", "400"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        yield live, proc, proc.stdout.readline().strip()
    finally:
        if proc.stdin is not None:
            proc.stdin.close()
        proc.wait(30)
        live.client.close()
        handle.stop()


def test_estop_under_400_viewers_latches_within_one_cycle_every_time(
        flooded: tuple[Live, subprocess.Popen[str], str]) -> None:
    live, _proc, report = flooded
    assert report == "accepted 400 refused 0"
    assert live.handle.viewers is not None and live.handle.viewers.total == 400
    for _ in range(10):
        r = live.client.post("/api/estop", json={}, headers=live.auth())
        assert r.status_code == 200
        body = r.json()
        assert 0.0 <= body["latched_at"] - body["requested_at"] <= CONTROL_PERIOD + 1e-9
        r = live.client.post("/api/estop/release", headers=live.auth())
        assert r.status_code == 200
    # the viewers still get telemetry at their fair share (400 msgs/s over 400 viewers)
    assert live.handle.viewers.frame_period(0.05) == pytest.approx(1.0)
    assert live.handle.viewers.total == 400


def test_wildcard_host_prints_lan_url_and_warns_without_tls() -> None:
    stack = NavStack("office", seed=1)
    lines: list[str] = []
    handle = serve_dashboard(stack, "0.0.0.0", 0, TOKEN, real_time_factor=None,
                             announce=lines.append)
    try:
        banner = lines[0]
        assert "WARNING: plain HTTP beyond loopback" in banner
        assert "--tls-cert/--tls-key" in banner
        for url in handle.lan_urls:
            assert f"on the network: {url}#token={TOKEN}" in banner
            assert not url.startswith("http://127.")
        assert httpx.get(handle.url + "api/hello", timeout=10).status_code == 200
    finally:
        handle.stop()


@pytest.mark.skipif(shutil.which("openssl") is None, reason="no openssl to make a test cert")
def test_tls_serves_https_without_the_warning(tmp_path: Path) -> None:
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
                    "-subj", "/CN=127.0.0.1", "-keyout", str(key), "-out", str(cert)],
                   check=True, capture_output=True)
    stack = NavStack("office", seed=1)
    lines: list[str] = []
    handle = serve_dashboard(stack, "0.0.0.0", 0, TOKEN, real_time_factor=None,
                             ssl_certfile=str(cert), ssl_keyfile=str(key),
                             announce=lines.append)
    try:
        assert handle.url.startswith("https://") and "WARNING" not in lines[0]
        r = httpx.get(handle.url + "api/auth", verify=False, timeout=10,
                      headers={"Authorization": f"Bearer {TOKEN}"})
        assert r.status_code == 200
        with pytest.raises(httpx.HTTPError):
            httpx.get(handle.url.replace("https://", "http://") + "api/hello", timeout=5)
    finally:
        handle.stop()


def test_token_from_file_or_env_never_on_the_command_line(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    secret = "file-token-9876543210"
    token_file = tmp_path / "token"
    token_file.write_text(secret + "\n")
    token_file.chmod(0o600)
    proc = subprocess.Popen([sys.executable, "-m", "navstack.app", "run", "--web", "--port",
                             "0", "--token-file", str(token_file), "--duration", "60"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert line.startswith("navstack dashboard: http://127.0.0.1:")
        url = line.split()[2].split("#")[0]
        cmdline = Path(f"/proc/{proc.pid}/cmdline").read_bytes()
        assert secret.encode() not in cmdline
        assert httpx.get(url + "api/auth", headers={"Authorization": f"Bearer {secret}"},
                         timeout=10).status_code == 200
    finally:
        proc.terminate()
        proc.wait(30)
    monkeypatch.setenv("NAVSTACK_DASHBOARD_TOKEN", "env-token-5555555")
    handle = serve_dashboard(NavStack("office", seed=1), "127.0.0.1", 0,
                             real_time_factor=None, announce=lambda _: None)
    try:
        assert handle.token == "env-token-5555555"
    finally:
        handle.stop()
    with pytest.raises(Exception, match=r"cannot read the dashboard token from .*missing"):
        serve_dashboard(NavStack("office", seed=1), "127.0.0.1", 0,
                        token_file=str(tmp_path / "missing"), announce=lambda _: None)


def test_unauthorised_release_is_refused_and_recorded(live: Live) -> None:
    assert live.client.post("/api/estop", json={}, headers=live.auth()).status_code == 200
    assert live.client.post("/api/estop/release").status_code == 401
    wait_until(lambda: live.runner.estop.refused_releases == 1, 10, "the refusal record")
    assert live.runner.estop.latched
    assert live.client.post("/api/estop/release", headers=live.auth()).status_code == 200
    assert not live.runner.estop.latched
    kinds = [e["kind"] for e in live.runner.estop.history()]
    assert kinds == ["latch", "refused_release", "release"]
