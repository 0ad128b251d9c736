"""Foxglove live: a client speaking the SDK's subprotocol sees the stack's channels with
Foxglove schemas and receives the map, scan and TF as the stack has them."""

from __future__ import annotations

import json
import math
import struct
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from navstack.interfaces.foxglove_live import SUBPROTOCOL, FoxgloveHandle, start_foxglove
from navstack.interfaces.stack import NavStack

EXPECTED = {"/map": "foxglove.Grid", "/global_costmap/costmap": "foxglove.Grid",
            "/local_costmap/costmap": "foxglove.Grid", "/scan": "foxglove.LaserScan",
            "/tf": "foxglove.FrameTransforms", "/tf_static": "foxglove.FrameTransforms",
            "/odom": "foxglove.Odometry", "/plan": "foxglove.PosesInFrame",
            "/local_plan": "foxglove.PosesInFrame", "/footprint": "foxglove.SceneUpdate",
            "/markers": "foxglove.SceneUpdate", "/explore/frontiers": "foxglove.SceneUpdate",
            "/aruco/marker_map/markers": "foxglove.SceneUpdate"}
JSON_CHANNELS = {"/mission/state"}


def _varint(buf: bytes, i: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        b = buf[i]
        i += 1
        value |= (b & 0x7F) << shift
        shift += 7
        if b < 0x80:
            return value, i


def protobuf_fields(buf: bytes) -> dict[int, list[Any]]:
    """Top-level fields of a protobuf message: number -> values (ints or bytes)."""
    out: dict[int, list[Any]] = {}
    i = 0
    while i < len(buf):
        key, i = _varint(buf, i)
        number, wire = key >> 3, key & 7
        value: Any
        if wire == 0:
            value, i = _varint(buf, i)
        elif wire == 1:
            value, i = buf[i:i + 8], i + 8
        elif wire == 5:
            value, i = buf[i:i + 4], i + 4
        elif wire == 2:
            n, i = _varint(buf, i)
            value, i = buf[i:i + n], i + n
        else:
            raise ValueError(f"unexpected wire type {wire}")
        out.setdefault(number, []).append(value)
    return out


@pytest.fixture
def fox() -> Iterator[tuple[NavStack, FoxgloveHandle]]:
    stack = NavStack("office", seed=1)
    handle = start_foxglove(stack, "127.0.0.1", 0, real_time_factor=4.0)
    try:
        yield stack, handle
    finally:
        handle.stop()


def test_client_gets_channels_and_map_scan_tf(fox: tuple[NavStack, FoxgloveHandle]) -> None:
    stack, handle = fox
    assert handle.port > 0 and handle.url == f"ws://127.0.0.1:{handle.port}"
    with connect(handle.url, subprotocols=[SUBPROTOCOL], open_timeout=10,
                 max_size=2**24) as ws:
        assert ws.subprotocol == "foxglove.sdk.v1"
        info = json.loads(ws.recv(timeout=10))
        assert (info["op"], info["name"], info["capabilities"]) == ("serverInfo", "navstack",
                                                                     ["time"])
        channels: dict[str, dict[str, Any]] = {}
        while set(channels) != set(EXPECTED) | JSON_CHANNELS:
            msg = json.loads(ws.recv(timeout=10))
            if msg["op"] == "advertise":
                channels.update({c["topic"]: c for c in msg["channels"]})
        assert {t: c["schemaName"] for t, c in channels.items()
                if t not in JSON_CHANNELS} == EXPECTED
        assert {c["encoding"] for t, c in channels.items() if t not in JSON_CHANNELS} == {
            "protobuf"}
        assert {channels[t]["encoding"] for t in JSON_CHANNELS} == {"json"}

        topics = {1: "/map", 2: "/scan", 3: "/tf"}
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": sid, "channelId": channels[t]["id"]} for sid, t in topics.items()]}))
        got: dict[int, tuple[int, bytes]] = {}
        deadline = time.monotonic() + 15.0
        while len(got) < 3 and time.monotonic() < deadline:
            msg = ws.recv(timeout=10)
            if isinstance(msg, bytes) and msg[0] == 1:  # opcode 1: message data
                sid, log_time = struct.unpack_from("<IQ", msg, 1)
                got.setdefault(sid, (log_time, msg[13:]))
    assert set(got) == set(topics)

    # the map: foxglove.Grid (column_count = field 4, data = field 9) == the world grid
    grid = stack.world.to_occupancy_grid()
    fields = protobuf_fields(got[1][1])
    assert struct.unpack("<I", fields[4][0])[0] == grid.info.width == 400
    assert fields[2] == [b"map"]
    assert fields[9][0] == np.ascontiguousarray(grid.data, np.int8).tobytes()

    # the scan: frame "laser", 360 ranges within the lidar's limits, stamped in sim time
    fields = protobuf_fields(got[2][1])
    assert fields[2] == [b"laser"]
    ranges = np.frombuffer(fields[6][0], "<f8")
    assert len(ranges) == 360
    finite = ranges[np.isfinite(ranges)]
    assert len(finite) > 300 and finite.min() >= 0.1 and finite.max() <= 20.0
    log_time = got[2][0] / 1e9
    assert 0.0 < log_time <= stack.now + 1e-6
    assert math.isclose(log_time * 10, round(log_time * 10), abs_tol=1e-6)  # 10 Hz lidar

    # TF: a FrameTransforms whose transforms (field 1) include odom -> base_link
    transforms = [protobuf_fields(t) for t in protobuf_fields(got[3][1])[1]]
    pairs = {(t[2][0], t[3][0]) for t in transforms}
    assert (b"odom", b"base_link") in pairs


def test_other_subprotocols_are_refused(fox: tuple[NavStack, FoxgloveHandle]) -> None:
    _, handle = fox
    with pytest.raises(InvalidStatus) as err, connect(
            handle.url, subprotocols=["foxglove.websocket.v1"], open_timeout=10):
        pass
    assert err.value.response.status_code == 400
