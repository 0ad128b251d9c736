"""The dashboard page in headless Chromium at phone size (390 x 844): it renders the map and
the robot, a click on the map sets a goal the robot reaches, the e-stop button stops the
robot until Release is clicked, and requests without the token get 401."""

from __future__ import annotations

import io
import math
from collections.abc import Iterator

import numpy as np
import pytest
from PIL import Image

from tests.interfaces.web.cdp import Browser, chromium_binary
from tests.interfaces.web.conftest import Live, start_live, wait_until

BINARY = chromium_binary()
pytestmark = pytest.mark.skipif(
    BINARY is None, reason="no Chromium binary (install chromium or set NAVSTACK_CHROMIUM)")
BACKGROUND = (0x20, 0x24, 0x2B)
ROBOT = (0, 160, 255)
GOAL = (1.5, 10.0)  # the office world's Goal_4, in the room north of the spawn


@pytest.fixture
def page() -> Iterator[tuple[Live, Browser]]:
    lv = start_live(5.0)  # 5x real time: fast, yet the e-stop hold stays short in sim time
    assert BINARY is not None
    browser = Browser(BINARY, 390, 844)
    try:
        yield lv, browser
    finally:
        browser.close()
        lv.client.close()
        lv.handle.stop()


def _pixels(png: bytes, rect: list[float]) -> np.ndarray:
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(np.int16)
    x0, y0, w, h = (round(v) for v in rect)
    return img[y0:y0 + h, x0:x0 + w]


def _near(px: np.ndarray, rgb: tuple[int, int, int], tol: int = 3) -> np.ndarray:
    return np.all(np.abs(px - np.array(rgb)) <= tol, axis=-1)


def test_page_map_goal_click_estop_and_token(page: tuple[Live, Browser]) -> None:
    live, b = page
    b.navigate(live.handle.control_url)
    b.wait_for("window.navstack && navstack.ready() && navstack.authorized()", 30,
               "the page to draw the map with control access")
    assert b.eval("document.documentElement.scrollWidth") <= 390  # no sideways scrolling

    # --- it renders: map pixels and the robot, where the robot is ---------------------------
    rect = b.eval("(() => { const r = document.getElementById('map').getBoundingClientRect();"
                  " return [r.left, r.top, r.width, r.height]; })()")
    assert rect[2] >= 380 and rect[3] >= 250
    robot = b.eval("navstack.state().robot")
    px = _pixels(b.screenshot(), rect)
    assert (~_near(px, BACKGROUND)).mean() > 0.5
    ys, xs = np.nonzero(_near(px, ROBOT))
    assert len(xs) >= 15
    cx, cy = b.eval(f"navstack.worldToClient({robot[0]}, {robot[1]})")
    assert math.hypot(xs.mean() + rect[0] - cx, ys.mean() + rect[1] - cy) < 4.0

    # --- a click on the map sets the goal -----------------------------------------------------
    gx, gy = b.eval(f"navstack.worldToClient({GOAL[0]}, {GOAL[1]})")
    b.click(gx, gy)
    nav = wait_until(lambda: (n := live.state()["nav"])["task"] and n, 10, "the goal")
    assert nav["task"] == "navigate_to_pose"
    assert math.hypot(nav["goal"][0] - GOAL[0], nav["goal"][1] - GOAL[1]) < 0.06  # one pixel
    wait_until(lambda: live.base.speed() > 0.25, 30, "the robot to move")

    # --- the e-stop button stops it until Release --------------------------------------------
    b.click_element("estop")
    wait_until(lambda: live.runner.estop.latched, 10, "the e-stop to latch")
    latched_at = live.runner.estop.latched_at
    assert latched_at is not None
    b.wait_for("document.getElementById('estop').classList.contains('latched') && "
               "!document.getElementById('release').disabled", 10, "the latched e-stop UI")
    wait_until(lambda: live.runner.now > latched_at + 4.0, 30, "4 s of simulated e-stop")
    b.click_element("estop")  # pressing it again does not release it
    rows = np.array(live.base.rows)
    held = rows[rows[:, 0] > latched_at]
    assert np.all(held[:, 1:3] == 0.0)
    still = held[held[:, 0] > latched_at + 0.6]
    assert np.ptp(still[:, 4]) == 0.0 and np.ptp(still[:, 5]) == 0.0
    assert live.runner.estop.latched
    b.click_element("release")
    wait_until(lambda: not live.runner.estop.latched, 10, "the release")

    st = wait_until(lambda: (s := live.state())["nav"]["status"] in
                    ("SUCCEEDED", "FAILED", "CANCELED") and s, 60, "the goal to finish")
    assert st["nav"]["status"] == "SUCCEEDED", st["nav"]
    assert math.hypot(st["robot"][0] - GOAL[0], st["robot"][1] - GOAL[1]) <= 0.25
    assert st["health"]["collisions"] == 0

    # --- without the token: 401, and the page is read-only -----------------------------------
    status = b.eval("fetch('/api/estop', {method: 'POST', headers: {'Content-Type': "
                    "'application/json'}, body: '{}'}).then(r => r.status)")
    assert status == 401
    assert not live.runner.estop.latched
    b.eval("sessionStorage.clear()")
    b.navigate(live.handle.url)
    b.wait_for("window.navstack && navstack.ready()", 30, "the read-only page")
    b.wait_for("document.getElementById('access').textContent === 'read-only'", 10,
               "the read-only badge")
    assert b.eval("document.getElementById('estop').disabled") is True
    assert b.eval("document.getElementById('token-box').classList.contains('hidden')") is False
