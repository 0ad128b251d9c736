"""The fleet page in headless Chromium: it draws every robot, in its colour, where it is."""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from navstack.interfaces.fleet import Fleet, load_fleet
from navstack.interfaces.fleet_mission import FleetMission
from navstack.interfaces.web.fleet_view import FleetView, serve_fleet_view
from tests.interfaces.web.cdp import Browser, chromium_binary

BINARY = chromium_binary()
pytestmark = pytest.mark.skipif(
    BINARY is None, reason="no Chromium binary (install chromium or set NAVSTACK_CHROMIUM)")
COLOURS = [(0x1F, 0x77, 0xB4), (0xFF, 0x7F, 0x0E), (0x2C, 0xA0, 0x2C)]


def test_fleet_page_draws_each_robot_where_it_is():
    mission = FleetMission(Fleet(load_fleet(), robots=3))
    while mission.fleet.now < 2.0:
        mission.step()
    view = FleetView(mission)  # the mission is paused: the snapshot stays as it is
    handle = serve_fleet_view(view, port=0)
    assert BINARY is not None
    browser = Browser(BINARY, 1000, 800)
    try:
        browser.navigate(handle.url)
        browser.wait_for("document.querySelectorAll('#robots tbody tr').length === 3", 30,
                         "the fleet table with three robots")
        rows = browser.eval("[...document.querySelectorAll('#robots tbody tr')]"
                            ".map(r => r.children[1].textContent)")
        assert rows == ["/robot1", "/robot2", "/robot3"]
        rect = browser.eval("(() => { const r = document.getElementById('map')"
                            ".getBoundingClientRect(); return [r.left, r.top, r.width, "
                            "r.height]; })()")
        img = np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("RGB"))
        meta = view.snapshot["map"]
        scale = rect[2] / (meta["width"] * meta["resolution"])
        for robot, colour in zip(view.snapshot["robots"], COLOURS, strict=True):
            x, y = robot["pose"][:2]
            u = round(rect[0] + (x - meta["origin"][0]) * scale)
            v = round(rect[1] + rect[3] - (y - meta["origin"][1]) * scale)
            patch = img[v - 3:v + 4, u - 3:u + 4].astype(int)
            hits = np.all(np.abs(patch - np.array(colour)) <= 6, axis=-1)
            assert hits.sum() >= 10, (robot["name"], patch[3, 3])
    finally:
        browser.close()
        handle.stop()
