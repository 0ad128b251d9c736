"""The phone interface (issue 18, part 6): token-guarded location -> NavSatFix on /fix, the
golf cart's routes, "Stop" -> e-stop held by the phone, and the phone page in headless
Chromium with a geolocation override: /fix carries the given lat/lon and "come to me"
sends a goal at the navsat-converted position."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from navstack.core.msgs import NavSatFix
from navstack.geo.conversions import LocalCartesian
from navstack.interfaces.stack import NavStack
from navstack.runtime.bus import QoS
from navstack.sim.gnss import world_to_enu
from tests.interfaces.web.cdp import Browser, chromium_binary
from tests.interfaces.web.conftest import Live, start_live, wait_until

BINARY = chromium_binary()
TARGET = (2.5, 4.0)  # the office world's Goal_1, in the room south-west of the spawn


def _fixes(live: Live) -> list[NavSatFix]:
    got: list[NavSatFix] = []

    def setup(stack: NavStack) -> None:
        stack.runtime.bus.subscribe("/fix", NavSatFix, got.append, QoS(depth=50))

    live.runner.call(setup)
    return got


def _lat_lon(stack: NavStack, x: float, y: float) -> tuple[float, float]:
    """Where the simulator puts map point (x, y) on the Earth (its GNSS model's frame)."""
    geo = stack.robot.sensors.georeference
    east, north = world_to_enu(x, y, geo.world_yaw)
    lat, lon, _ = LocalCartesian(geo.latitude, geo.longitude, geo.altitude).reverse(
        east, north, 0.0)
    return float(lat), float(lon)


def test_phone_routes_need_the_token_and_publish_fixes(live: Live) -> None:
    fixes = _fixes(live)
    body = {"lat": 38.4065, "lon": -110.7918, "alt": 1381.5, "accuracy": 4.8954}
    for method, path in (("POST", "/api/phone/location"), ("POST", "/location"),
                         ("GET", "/api/phone/location"), ("GET", "/get_location"),
                         ("POST", "/api/phone/message"), ("POST", "/message"),
                         ("POST", "/api/phone/come"), ("POST", "/api/phone/release")):
        r = live.client.request(method, path, json=body if method == "POST" else None)
        assert r.status_code == 401, (method, path)
    assert live.client.get("/get_location", headers=live.auth()).status_code == 404
    r = live.client.post("/api/phone/come", headers=live.auth())
    assert r.status_code == 409
    assert r.json()["error"] == "no phone location yet: share the location first"
    r = live.client.post("/location", json=body, headers=live.auth())
    assert r.status_code == 200 and r.json()["published"] == "/fix"
    wait_until(lambda: fixes, 10, "the fix on /fix")
    fix = fixes[-1]
    assert (fix.latitude, fix.longitude, fix.altitude) == (38.4065, -110.7918, 1381.5)
    assert fix.header.frame_id == "phone" and fix.status.status == 0
    assert fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    assert fix.position_covariance[0, 0] == pytest.approx(4.0, rel=1e-4)  # (4.8954/2.4477)^2
    got = live.client.get("/api/phone/location", headers=live.auth()).json()["location"]
    assert (got["lat"], got["lon"], got["alt"], got["accuracy"]) == (38.4065, -110.7918,
                                                                     1381.5, 4.8954)
    r = live.client.post("/api/phone/location", json={"latitude": 91.0, "longitude": 0.0},
                         headers=live.auth())
    assert r.status_code == 422
    assert r.json()["error"] == ("invalid LocationRequest: latitude: Input should be less "
                                 "than or equal to 90")
    # "Stop" latches the e-stop, held by the phone: the dashboard cannot release it
    r = live.client.post("/message", json={"text": " Stop "}, headers=live.auth())
    assert r.status_code == 200 and r.json()["estop"] is True
    assert live.runner.estop.latched and live.runner.estop.holder == "phone"
    r = live.client.post("/api/estop/release", headers=live.auth())
    assert r.status_code == 409
    assert r.json()["error"] == ("the e-stop is held by 'phone', not by 'web'; release it "
                                 "there")
    assert live.runner.estop.latched
    r = live.client.post("/api/phone/message", json={"text": "go"}, headers=live.auth())
    assert r.status_code == 422
    r = live.client.post("/api/phone/release", headers=live.auth())
    assert r.status_code == 200 and not live.runner.estop.latched


@pytest.fixture
def phone_page() -> Iterator[tuple[Live, Browser]]:
    if BINARY is None:
        pytest.skip("no Chromium binary (install chromium or set NAVSTACK_CHROMIUM)")
    lv = start_live(5.0)
    browser = Browser(BINARY, 390, 844)
    try:
        yield lv, browser
    finally:
        browser.close()
        lv.client.close()
        lv.handle.stop()


def test_phone_page_sends_geolocation_and_comes_to_me(phone_page: tuple[Live, Browser]
                                                      ) -> None:
    live, b = phone_page
    fixes = _fixes(live)
    lat, lon = _lat_lon(live.runner.stack, *TARGET)
    origin = live.handle.url.rstrip("/")
    b.set_geolocation(origin, lat, lon, 3.0)
    b.navigate(f"{live.handle.url}phone#token={live.handle.token}")
    b.wait_for("window.navstackPhone !== undefined", 30, "the phone page")
    b.click_element("share")
    wait_until(lambda: fixes, 20, "the phone's fix on /fix")
    assert (fixes[-1].latitude, fixes[-1].longitude) == (lat, lon)
    assert fixes[-1].position_covariance[0, 0] == pytest.approx((3.0 / 2.4477) ** 2)
    b.click_element("come")
    b.wait_for("document.getElementById('msg').textContent !== ''", 20, "the page's reply")
    assert b.eval("document.getElementById('msg').textContent").startswith("coming to "), \
        b.eval("document.getElementById('msg').textContent")
    nav = wait_until(lambda: (n := live.state()["nav"])["task"] and n, 20, "the goal")
    assert nav["task"] == "navigate_to_pose"
    gx, gy, _ = nav["goal"]
    assert math.hypot(gx - TARGET[0], gy - TARGET[1]) <= 0.5
    assert math.hypot(gx - TARGET[0], gy - TARGET[1]) < 0.01  # the conversion is exact
    st = wait_until(lambda: (s := live.state())["nav"]["status"] in
                    ("SUCCEEDED", "FAILED", "CANCELED") and s, 60, "the goal to finish")
    assert st["nav"]["status"] == "SUCCEEDED"
    assert math.hypot(st["robot"][0] - TARGET[0], st["robot"][1] - TARGET[1]) <= 0.25
    # STOP on the page latches the e-stop, held by the phone; Release releases it
    b.click_element("stop")
    wait_until(lambda: live.runner.estop.latched, 10, "the phone's e-stop")
    assert live.runner.estop.holder == "phone"
    b.click_element("release")
    wait_until(lambda: not live.runner.estop.latched, 10, "the phone's release")
    # without the token the phone routes answer 401
    status = b.eval("fetch('/api/phone/location', {method: 'POST', headers: {'Content-Type': "
                    "'application/json'}, body: JSON.stringify({lat: 1, lon: 2})})"
                    ".then(r => r.status)")
    assert status == 401
