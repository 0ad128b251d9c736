"""Dashboard HTTP/WebSocket API against a live stack: token, e-stop, goals, images."""

from __future__ import annotations

import io
import json
import math
import time

import numpy as np
from PIL import Image
from websockets.sync.client import connect

from navstack.interfaces.web.server import UNAUTHORIZED
from tests.interfaces.web.conftest import Live, wait_until

COMMANDS = [("POST", "/api/goal", {"x": 2.5, "y": 4.0}),
            ("POST", "/api/waypoints", {"x": 2.5, "y": 4.0}),
            ("DELETE", "/api/waypoints", None),
            ("POST", "/api/waypoints/go", {"mode": "follow_waypoints"}),
            ("POST", "/api/cancel", None),
            ("POST", "/api/estop", {}),
            ("POST", "/api/estop/release", None)]
CONTROL_PERIOD = 0.05  # controller_frequency 20 Hz; the runner's step


def test_commands_need_the_token(live: Live) -> None:
    for method, path, body in COMMANDS:
        for headers in ({}, {"Authorization": "Bearer wrong-token-123"},
                        {"X-Navstack-Token": "wrong"}):
            r = live.client.request(method, path, json=body, headers=headers)
            assert r.status_code == 401, (method, path, headers)
            assert r.json() == {"error": UNAUTHORIZED}
            assert r.headers["www-authenticate"] == "Bearer"
    assert live.state()["nav"]["status"] == "IDLE"  # nothing was executed
    assert live.state()["estop"]["latched"] is False
    assert live.client.get("/api/auth").status_code == 401
    assert live.client.get("/api/auth", headers=live.auth()).status_code == 200
    # with the token: 200, and the commands took effect
    r = live.client.post("/api/waypoints", json={"x": 3.0, "y": 4.0, "theta": 0.5},
                         headers=live.auth())
    assert r.status_code == 200
    assert r.json()["waypoints"] == [[3.0, 4.0, 0.5]]
    r = live.client.delete("/api/waypoints", headers={"X-Navstack-Token": live.handle.token})
    assert (r.status_code, r.json()["waypoints"]) == (200, [])
    r = live.client.post("/api/cancel", headers=live.auth())
    assert (r.status_code, r.json()["canceled"]) == (200, None)
    # read-only routes stay open
    assert live.client.get("/").status_code == 200
    assert live.client.get("/static/app.js").status_code == 200


def test_bad_bodies_are_422_with_the_field_named(live: Live) -> None:
    r = live.client.post("/api/goal", json={"x": 1.0}, headers=live.auth())
    assert r.status_code == 422
    assert r.json()["error"] == "invalid 'goal' command: y: Field required"
    r = live.client.post("/api/goal", content=b'{"x": NaN, "y": 1}',
                         headers={**live.auth(), "Content-Type": "application/json"})
    assert r.status_code == 422
    assert r.json()["error"].startswith("invalid 'goal' command: x: Input should be a finite")
    r = live.client.post("/api/waypoints/go", json={}, headers=live.auth())
    assert r.status_code == 409
    assert r.json()["error"] == ("no waypoints to go to; add waypoints first (waypoint mode, "
                                 "then click the map)")


def test_websocket_streams_state_and_refuses_commands_without_token(live: Live) -> None:
    url = live.handle.url.replace("http://", "ws://") + "ws"
    with connect(url, open_timeout=10) as ws:
        hello = json.loads(ws.recv(timeout=10))
        assert hello["type"] == "hello"
        assert hello["bounds"] == [0.0, 0.0, 20.0, 15.0]
        body = live.runner.stack.body_footprint.polygon  # the robot's body, base_link
        assert np.allclose(hello["footprint"], body, atol=5e-5)
        seen: dict[str, dict[str, object]] = {}
        while not {"layer", "state"} <= seen.keys():
            msg = json.loads(ws.recv(timeout=10))
            seen.setdefault(msg["type"], msg)
        assert seen["layer"]["name"] in ("map", "global_costmap", "local_costmap")
        # the state streams at >= 10 Hz (frame_rate 20), each frame newer than the last
        t0, stamps = time.monotonic(), []
        while time.monotonic() - t0 < 1.0:
            msg = json.loads(ws.recv(timeout=10))
            if msg["type"] == "state":
                stamps.append(msg["t"])
        assert len(stamps) >= 10 and np.all(np.diff(stamps) > 0)
        ws.send(json.dumps({"type": "command", "id": 7, "command": "estop", "args": {}}))
        reply = next(m for m in (json.loads(ws.recv(timeout=10)) for _ in range(200))
                     if m["type"] == "result")
        assert reply == {"type": "result", "id": 7, "status": 401,
                         "body": {"error": UNAUTHORIZED}}
        ws.send(json.dumps({"type": "command", "id": 8, "token": live.handle.token,
                            "command": "estop", "args": {"reason": "ws test"}}))
        reply = next(m for m in (json.loads(ws.recv(timeout=10)) for _ in range(200))
                     if m["type"] == "result")
        assert (reply["id"], reply["status"], reply["body"]["estop"]) == (8, 200, True)
    assert live.runner.estop.latched and live.runner.estop.reason == "ws test"


def test_map_image_is_the_world_grid(live: Live) -> None:
    r = live.client.get("/api/layers/map.png")
    assert r.status_code == 200
    meta = json.loads(r.headers["x-layer-meta"])
    assert (meta["width"], meta["height"], meta["resolution"]) == (400, 300, 0.05)
    img = np.asarray(Image.open(io.BytesIO(r.content)).convert("RGBA"))[:, :, :3]
    grid = live.runner.stack.world.to_occupancy_grid().data
    expected = np.flipud(grid)  # north-up
    assert img.shape == (300, 400, 3)
    assert np.all(img[expected == 100] == 0)        # occupied: black
    assert np.all(img[expected == 0] == 254)        # free: white
    assert np.all(img[expected == -1] == 205)       # unknown: grey
    assert live.client.get("/api/layers/nothing.png").status_code == 404


def test_goal_through_http_is_reached(live: Live) -> None:
    goal = (2.5, 4.0)  # the office world's Goal_1
    r = live.client.post("/api/goal", json={"x": goal[0], "y": goal[1], "theta": 0.0},
                         headers=live.auth())
    assert r.status_code == 200, r.text
    assert r.json()["task"] == "navigate_to_pose"
    st = wait_until(lambda: (s := live.state())["nav"]["status"] in
                    ("SUCCEEDED", "FAILED", "CANCELED") and s, 60, "the goal to finish")
    assert st["nav"]["status"] == "SUCCEEDED", st["nav"]
    x, y, th = st["robot"]
    assert math.hypot(x - goal[0], y - goal[1]) <= 0.25   # xy_goal_tolerance
    assert abs(math.atan2(math.sin(th), math.cos(th))) <= 0.25  # yaw_goal_tolerance
    assert st["health"]["collisions"] == 0
    plan = live.client.get("/api/plan").json()
    assert plan["version"] >= 1 and len(plan["points"]) >= 4
    trail = live.client.get("/api/trail").json()["points"]
    assert math.hypot(trail[0][0] - 1.0, trail[0][1] - 7.5) < 0.05  # starts at the spawn


def test_estop_zeroes_the_base_within_one_control_cycle_until_release(live: Live) -> None:
    base = live.base
    r = live.client.post("/api/goal", json={"x": 18.5, "y": 7.5}, headers=live.auth())
    assert r.status_code == 200
    wait_until(lambda: base.speed() > 0.3, 30, "the robot to drive down the corridor")
    r = live.client.post("/api/estop", json={"reason": "test"}, headers=live.auth())
    assert r.status_code == 200
    latched_at, requested_at = r.json()["latched_at"], r.json()["requested_at"]
    assert 0.0 <= latched_at - requested_at <= CONTROL_PERIOD + 1e-9
    wait_until(lambda: live.runner.now > latched_at + 3.0, 30, "3 s of simulated e-stop")
    assert live.state()["estop"]["latched"] is True
    r = live.client.post("/api/estop/release", headers=live.auth())
    released_at = r.json()["released_at"]
    wait_until(lambda: live.runner.now > released_at + 2.0, 30, "2 s after release")
    rows = np.array(base.rows)
    t = rows[:, 0]
    held = rows[(t > latched_at) & (t <= released_at)]
    assert len(held) > 250
    assert np.all(held[:, 1] == 0.0) and np.all(held[:, 2] == 0.0)  # commanded: zero
    # the base decelerates at its acceleration limit (1 m/s^2) and then stands still
    stopped = held[held[:, 0] > latched_at + 0.6]
    assert np.all(stopped[:, 3] == 0.0)
    assert np.ptp(stopped[:, 4]) == 0.0 and np.ptp(stopped[:, 5]) == 0.0
    assert live.runner.estop.overrides > 10  # the controller kept commanding; gate held
    after = rows[t > released_at + 1.0]
    assert after[:, 1].max() > 0.1  # navigation resumed
    assert after[-1, 4] - stopped[-1, 4] > 0.2


def test_waypoints_followed_in_order(live: Live) -> None:
    for x, y in ((2.5, 5.5), (2.5, 4.0)):  # into the room south-west of the spawn
        r = live.client.post("/api/waypoints", json={"x": x, "y": y}, headers=live.auth())
        assert r.status_code == 200
    expected = r.json()["waypoints"]
    wait_until(lambda: live.state()["waypoints"] == expected, 10,  # the next state frame
               "the waypoints in the state")
    r = live.client.post("/api/waypoints/go", json={"mode": "follow_waypoints"},
                         headers=live.auth())
    assert r.status_code == 200 and r.json()["task"] == "follow_waypoints"
    seen: set[int] = set()

    def finished() -> dict[str, object] | None:
        nav = live.state()["nav"]
        if nav["current_waypoint"] is not None:
            seen.add(nav["current_waypoint"])
        return nav if nav["status"] in ("SUCCEEDED", "FAILED", "CANCELED") else None

    nav = wait_until(finished, 60, "the waypoints to be followed")
    assert nav["status"] == "SUCCEEDED" and nav["waypoint_count"] == 2
    assert seen == {0, 1} and "missed_waypoints" not in nav
    x, y, _ = live.state()["robot"]
    assert math.hypot(x - 2.5, y - 4.0) <= 0.25
    assert live.state()["waypoints"] == []  # the list was consumed by 'go'
