"""Dashboard building blocks with known answers: palettes and PNGs, goal headings, topic
rates, command validation, settings and a busy port."""

from __future__ import annotations

import io
import math
import socket

import numpy as np
import pytest
from PIL import Image

from navstack.core.errors import ConfigError
from navstack.core.msgs import Header, MapMetaData, OccupancyGrid, Pose2D
from navstack.interfaces.stack import NavStack
from navstack.interfaces.web import DashboardError, DashboardParams, serve_dashboard
from navstack.interfaces.web.commands import CommandRejected, NavCommander, goal_heading
from navstack.interfaces.web.images import grid_png, palette
from navstack.interfaces.web.model import TopicRates


def test_palettes_follow_rviz_schemes() -> None:
    rgb, alpha = palette("map")
    assert rgb[0].tolist() == [254] * 3 and rgb[100].tolist() == [0] * 3
    assert rgb[50].tolist() == [127] * 3 and rgb[255].tolist() == [205] * 3
    assert np.all(alpha == 255)
    rgb, alpha = palette("costmap")
    assert alpha[0] == 0 and alpha[255] == 0  # free and unknown: transparent
    assert rgb[1].tolist() == [0, 0, 255] and rgb[99].tolist() == [255, 0, 0]
    assert rgb[100].tolist() == [200, 0, 200] and alpha[100] == 150


def test_grid_png_is_north_up_with_exact_colours() -> None:
    data = np.array([[0, 100, -1], [50, 0, 100]], np.int8)  # row 0 = lowest y
    grid = OccupancyGrid(Header(0.0, "map"), MapMetaData(0.0, 0.1, 3, 2), data)
    img = np.asarray(Image.open(io.BytesIO(grid_png(grid, "map"))).convert("RGBA"))
    assert img.shape == (2, 3, 4)
    assert img[1, :, 0].tolist() == [254, 0, 205]  # bottom image row = grid row 0
    assert img[0, :, 0].tolist() == [127, 254, 0]
    img = np.asarray(Image.open(io.BytesIO(grid_png(grid, "costmap"))).convert("RGBA"))
    assert img[1, :, 3].tolist() == [0, 150, 0]
    assert img[0, 2].tolist() == [200, 0, 200, 150]


def test_goal_heading_faces_along_travel() -> None:
    assert goal_heading(Pose2D(1.0, 1.0, 2.0), 2.0, 2.0) == pytest.approx(math.pi / 4)
    assert goal_heading(Pose2D(0.0, 0.0), -1.0, 0.0) == pytest.approx(math.pi)
    assert goal_heading(None, 3.0, 4.0) == 0.0
    assert goal_heading(Pose2D(3.0, 4.0, 1.0), 3.0, 4.0) == 0.0


def test_topic_rates_over_a_sliding_window() -> None:
    rates = TopicRates(("/a", "/b"), window=2.0)
    out = {}
    for k in range(61):  # 3 s sampled at 20 Hz: /a at 10 Hz, /b at 50 Hz
        t = k * 0.05
        out = rates.sample(t, (math.floor(t * 10), math.floor(t * 50)))
    # the window spans [1.0, 3.0]: /a went 10 -> 30, /b 50 -> 150
    assert out == {"/a": 10.0, "/b": 50.0}
    for k in range(1, 42):  # the topics go silent: after one window, 0 Hz
        out = rates.sample(3.0 + k * 0.05, (30, 150))
    assert out == {"/a": 0.0, "/b": 0.0}


def test_commander_validates_and_orients_waypoints() -> None:
    stack = NavStack("office", seed=1).start()
    nav = NavCommander(stack)
    with pytest.raises(CommandRejected, match=r"^goal \(nan, 1.0, None\) is not finite"):
        nav.go_to(float("nan"), 1.0)
    with pytest.raises(CommandRejected, match=r"^no waypoints to go to"):
        nav.go()
    nav.add_waypoint(1.0, 9.5)  # robot spawns at (1, 7.5): faces north
    nav.add_waypoint(1.0, 9.5 - 2.0)  # from the previous waypoint: faces south
    assert nav.waypoint_list()["waypoints"] == [[1.0, 9.5, pytest.approx(math.pi / 2)],
                                                [1.0, 7.5, pytest.approx(-math.pi / 2)]]
    with pytest.raises(CommandRejected, match=r"^unknown mode 'zigzag'"):
        nav.go("zigzag")  # type: ignore[arg-type]
    out = nav.go("navigate_through_poses")
    assert out["task"] == "navigate_through_poses" and nav.waypoints == []
    status = nav.status()
    assert status["status"] == "EXECUTING" and status["waypoint_count"] == 2
    assert nav.cancel()["canceled"] == "navigate_through_poses"
    stack.run_for(0.2)
    assert nav.status()["status"] == "CANCELED"


def test_settings_and_busy_port_are_reported() -> None:
    with pytest.raises(ConfigError, match=r"dashboard\.frame_rate"):
        DashboardParams.from_mapping({"frame_rate": 5.0}, key_path="dashboard")
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        with pytest.raises(DashboardError, match=rf"^cannot listen on 127.0.0.1:{port} "
                                                 r"\(Address already in use\); choose another "
                                                 r"port"):
            serve_dashboard(NavStack("office", seed=1), port=port, announce=lambda _: None)
