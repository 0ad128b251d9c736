"""``navstack bench safety``: e-stop latency from every operator source, and the dashboard
under a flood of viewers (issue 18, acceptance 2 and 7).

One live office stack in (scaled) real time serves the dashboard (API, page, phone
routes) and the Telegram bot (against the local fake Bot API).  For each source in turn
the robot is driving a goal; the source latches the e-stop; the bench then checks at the
base (every ``/cmd_vel`` message the simulated base receives, and its held command sampled
every 10 ms of simulated time):

* ``handled->zero``: simulated time from the moment the source's message was handled (its
  request reached the simulation queue, or its lock message was delivered) to the first
  zero command -- it must be within one control cycle (0.05 s);
* ``zero until release``: every instant between the latch and the authorised release the
  base holds zero;
* ``unauthorised release refused``: the source's unauthorised release attempt (no token,
  a stranger's chat, another authority) leaves the latch in place;
* ``round trip``: wall seconds from sending to the source's acknowledgement (HTTP reply,
  the bot's reply, the page showing the latch).

Then 400 read-only WebSocket viewers connect (a separate process) and the e-stop round
trip is measured again (p50/p95/max over ``flood_samples`` latch+release pairs), and a
16 MiB unauthenticated WebSocket frame is sent to record how many bytes the server read
before refusing it.
"""

from __future__ import annotations

import base64
import logging
import os
import socket
import statistics
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx

from navstack.benchmarks import flood_client
from navstack.benchmarks.cdp import Browser, chromium_binary
from navstack.benchmarks.common import BenchResult
from navstack.benchmarks.safety_sources import (
    OPERATOR_CHAT,
    OTHER_CHAT,
    SOURCES,
    Clients,
    Source,
)
from navstack.core.msgs import Twist
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack
from navstack.interfaces.telegram import TelegramBot, TelegramParams
from navstack.interfaces.telegram.fake_api import FakeBotApi
from navstack.interfaces.web import serve_dashboard
from navstack.runtime.bus import QoS

CONTROL_PERIOD = 0.05
TOKEN = "bench-dashboard-token-0123456789"
BOT_TOKEN = "123456789:AABenchTokenBenchTokenBenchToken0"
FAR_GOALS = ((18.5, 7.5), (1.0, 7.5))  # the office corridor, end to end


class BaseLog:
    """What the simulated base received: every /cmd_vel message and its held command every
    10 ms of simulated time (appended in the simulation thread)."""

    def __init__(self, runner: LiveRunner) -> None:
        self.msgs: list[tuple[float, float, float]] = []
        self.held: list[tuple[float, float, float, float]] = []

        def setup(stack: NavStack) -> None:
            sim = stack.sim.sim
            stack.runtime.bus.subscribe("/cmd_vel", Twist, lambda m: self.msgs.append(
                (stack.now, m.linear.x, m.angular.z)), QoS(depth=100))

            def sample() -> None:
                stack.sim.advance()
                self.held.append((stack.now, sim.command.vx, sim.command.wz, sim.state.vx))

            stack.runtime.scheduler.create_timer(0.01, sample)

        runner.call(setup)

    def speed(self) -> float:
        return abs(self.held[-1][3]) if self.held else 0.0


def _drive(runner: LiveRunner, http: httpx.Client, auth: dict[str, str], base: BaseLog) -> bool:
    """Make sure a far goal runs and the robot moves; False if it does not within 30 s."""
    nav = http.get("/api/state").json()["nav"]
    if nav["status"] not in ("ACCEPTED", "EXECUTING"):
        x, y = runner.call(lambda s: s.sim.sim.pose.as_array()[:2])
        gx, gy = max(FAR_GOALS, key=lambda g: (g[0] - x) ** 2 + (g[1] - y) ** 2)
        http.post("/api/goal", json={"x": gx, "y": gy}, headers=auth)
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        if base.speed() > 0.2:
            return True
        time.sleep(0.02)
    return False


def _sleep_sim(runner: LiveRunner, seconds: float) -> None:
    end = runner.now + seconds
    while runner.now < end and runner.running:
        time.sleep(0.01)


def _measure(src: Source, c: Clients, base: BaseLog, hold: float) -> dict[str, Any]:
    runner = c.handle.runner
    gate = runner.estop
    row: dict[str, Any] = {"source": src.name}
    if src.skip:
        return {**row, "handled_to_zero_s": None, "within_one_cycle": None,
                "zero_until_release": None, "unauthorised_release_refused": None,
                "round_trip_s": None, "note": src.skip}
    moving = _drive(runner, c.http, c.auth, base)
    n_events = len(gate.events)
    latched = src.latch()
    if not latched.ok or not gate.latched:
        return {**row, "note": "the e-stop did not latch", "within_one_cycle": False}
    deadline = time.monotonic() + 10.0
    while (event := next((e for e in list(gate.events)[n_events:] if e.kind == "latch"),
                         None)) is None and time.monotonic() < deadline:
        time.sleep(0.005)  # the latch is visible a moment before its audit record
    if event is None:
        return {**row, "note": "the latch left no audit record", "within_one_cycle": False}
    handled = event.requested_at if event.requested_at is not None else event.time
    _sleep_sim(runner, hold)
    refused = src.refuse()
    still = gate.latched
    _sleep_sim(runner, hold / 2.0)
    released_ok = src.release().ok
    released_at = gate.released_at if released_ok and gate.released_at else runner.now
    msgs = runner.call(lambda _s: list(base.msgs))
    held = runner.call(lambda _s: list(base.held))
    zero_at = next((t for t, vx, wz in msgs if t >= handled - 1e-9 and vx == 0.0 and wz == 0.0),
                   None)
    last: dict[float, tuple[float, float]] = {}
    for t, vx, wz in msgs:
        if event.time - 1e-9 <= t < released_at - 1e-9:
            last[round(t, 6)] = (vx, wz)
    samples = [(vx, wz) for t, vx, wz, _ in held if event.time + 1e-9 < t < released_at - 1e-9]
    zero_held = (all(v == (0.0, 0.0) for v in last.values())
                 and all(v == (0.0, 0.0) for v in samples) and len(samples) > 0)
    latency = None if zero_at is None else round(zero_at - handled, 6)
    return {**row, "handled_to_zero_s": latency,
            "within_one_cycle": latency is not None and latency <= CONTROL_PERIOD + 1e-9,
            "zero_until_release": zero_held,
            "unauthorised_release_refused": refused.ok and still,
            "round_trip_s": None if latched.wall_s is None else round(latched.wall_s, 4),
            "note": "; ".join(x for x in (refused.note, "" if moving else
                                          "robot was not moving", "" if released_ok
                                          else "authorised release failed") if x)}


def _oversize_frame(port: int, stats: Any) -> int | None:
    """Send a 16 MiB frame without a token; bytes the server read before refusing it."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    size, sent, chunk = 16 * 2**20, 0, os.urandom(65536)
    try:
        sock.sendall(bytes([0x81, 0xFF]) + struct.pack(">Q", size) + os.urandom(4))
        while sent < size:
            sock.sendall(chunk)
            sent += len(chunk)
    except OSError:
        pass
    sock.close()
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:
        refused = stats.refused(1009)
        if refused:
            return int(refused[-1].bytes_read)
        time.sleep(0.05)
    return None


def _flood(c: Clients, viewers: int, samples: int) -> dict[str, float]:
    url = c.handle.url.replace("http://", "ws://") + "ws"
    proc = subprocess.Popen([sys.executable, str(Path(flood_client.__file__)), url,
                             str(viewers)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout is not None
        report = proc.stdout.readline().split()
        accepted = int(report[1]) if len(report) >= 2 else 0
        time.sleep(2.0)  # the viewers' first images and states go out
        rtts = []
        for _ in range(samples):
            t0 = time.monotonic()
            r = c.http.post("/api/estop", json={}, headers=c.auth)
            rtts.append(time.monotonic() - t0)
            if r.status_code != 200:
                break
            while c.http.post("/api/estop/release", headers=c.auth).status_code == 429:
                time.sleep(0.2)
            time.sleep(0.05)
    finally:
        if proc.stdin is not None:
            proc.stdin.close()
        proc.wait(30)
    rtts.sort()
    return {"flood_viewers_connected": float(accepted),
            "flood_estop_rtt_p50_s": round(statistics.median(rtts), 4),
            "flood_estop_rtt_p95_s": round(rtts[max(0, int(0.95 * len(rtts)) - 1)], 4),
            "flood_estop_rtt_max_s": round(rtts[-1], 4)}


def run(quick: bool, data_dir: Path) -> BenchResult:
    """Every e-stop source, then the flood (module docstring)."""
    del data_dir
    result = BenchResult("safety", show_cases=True)
    stack = NavStack("office", seed=1)
    runner = LiveRunner(stack, real_time_factor=1.0)  # operators act in real time
    base = BaseLog(runner)
    handle = serve_dashboard(runner, "127.0.0.1", 0, TOKEN, announce=lambda _: None,
                             security={"max_viewers": 450, "max_viewers_per_client": 450,
                                       "http_burst": 2000})
    api = FakeBotApi(BOT_TOKEN)
    http = httpx.Client(base_url=handle.url, timeout=30.0)
    binary = chromium_binary()
    browser = Browser(binary, 1000, 800) if binary else None
    bot = TelegramBot(runner, BOT_TOKEN, TelegramParams(
        allowed_chats=(OPERATOR_CHAT, OTHER_CHAT), api_url=api.base_url, poll_timeout=1))
    clients = Clients(handle, http, api, browser)
    bot_log = logging.getLogger("navstack.telegram")
    level = bot_log.level
    bot_log.setLevel(logging.ERROR)  # the stranger's refusals are expected here
    try:
        runner.start()
        bot.start()
        if browser is not None:
            browser.navigate(handle.control_url)
            browser.wait_for("window.navstack && navstack.ready() && navstack.authorized()",
                             60, "the dashboard page")
        for make in SOURCES:
            result.cases.append(_measure(make(clients), clients, base, 1.0 if quick else 2.0))
        if browser is not None:  # the flood is measured on the server alone
            browser.close()
            browser = None
        result.metrics.update(_flood(clients, 400, 40 if quick else 100))
        read = _oversize_frame(handle.port, handle.read_stats)
        if read is not None:
            result.metrics["oversize_frame_bytes_read"] = float(read)
    finally:
        bot_log.setLevel(level)
        bot.stop()
        if browser is not None:
            browser.close()
        http.close()
        handle.stop()
        runner.stop()
        api.stop()
    measured = [c for c in result.cases if c.get("handled_to_zero_s") is not None]
    result.metrics["sources_measured"] = float(len(measured))
    result.metrics["sources_within_one_cycle"] = float(
        sum(bool(c["within_one_cycle"]) for c in measured))
    result.metrics["max_handled_to_zero_s"] = max(
        (float(c["handled_to_zero_s"]) for c in measured), default=float("nan"))
    result.metrics["all_zero_until_release"] = float(
        all(c["zero_until_release"] for c in measured))
    result.metrics["all_unauthorised_releases_refused"] = float(
        all(c["unauthorised_release_refused"] for c in measured))
    for c in result.cases:
        if str(c.get("note", "")).startswith("needs"):
            result.notes.append(f"{c['source']}: {c['note']}")
    return result
