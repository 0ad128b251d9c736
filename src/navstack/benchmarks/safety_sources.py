"""The e-stop sources of ``navstack bench safety``: how each one latches, tries an
unauthorised release, and releases with authority.

Every source drives the one twist_mux lock (``docs/command_path.md``) through its own
interface, exactly as an operator would: HTTP to the dashboard API, a click on the page's
E-STOP button in headless Chromium, a "1" in a Telegram chat served by the local fake
Bot API, the phone endpoint's "Stop" message, a raw ``true`` on the lock topic, and the
joystick's e-stop button (``sensor_msgs/Joy`` into the teleop node).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import httpx

from navstack.benchmarks.cdp import Browser
from navstack.core.msgs import Bool, Joy
from navstack.interfaces.estop import LOCK_TOPIC
from navstack.interfaces.telegram.fake_api import FakeBotApi
from navstack.interfaces.web import DashboardHandle
from navstack.nodes.teleop import TeleopNode, TeleopNodeParams

OPERATOR_CHAT, OTHER_CHAT, STRANGER_CHAT = 1001, 1002, 6666


@dataclass
class Outcome:
    """What one step of a source did: ok, a wall time [s] and a note."""

    ok: bool
    wall_s: float | None = None
    note: str = ""


@dataclass
class Source:
    """One e-stop source: ``latch`` returns the wall round trip (None: not applicable),
    ``refuse`` tries an unauthorised release (True: it was refused), ``release`` releases
    with authority."""

    name: str
    latch: Callable[[], Outcome]
    refuse: Callable[[], Outcome]
    release: Callable[[], Outcome]
    skip: str = ""


@dataclass
class Clients:
    """The interfaces under test, shared by the sources."""

    handle: DashboardHandle
    http: httpx.Client
    api: FakeBotApi
    browser: Browser | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def auth(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.handle.token}"}


def _wait(predicate: Callable[[], Any], timeout: float = 20.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.002)
    return False


def web_api(c: Clients) -> Source:
    def latch() -> Outcome:
        t0 = time.monotonic()
        r = c.http.post("/api/estop", json={"reason": "bench"}, headers=c.auth)
        return Outcome(r.status_code == 200, time.monotonic() - t0)

    def refuse() -> Outcome:
        r = c.http.post("/api/estop/release")  # no token
        return Outcome(r.status_code == 401, note=f"HTTP {r.status_code} without the token")

    def release() -> Outcome:
        r = c.http.post("/api/estop/release", headers=c.auth)
        return Outcome(r.status_code == 200)

    return Source("web API", latch, refuse, release)


def web_page(c: Clients) -> Source:
    b = c.browser
    gate = c.handle.runner.estop
    if b is None:
        none = lambda: Outcome(False)  # noqa: E731
        return Source("web page button", none, none, none,
                      skip="no Chromium (install chromium or set NAVSTACK_CHROMIUM)")

    def latch() -> Outcome:
        assert b is not None
        t0 = time.monotonic()
        b.click_element("estop")
        ok = _wait(lambda: gate.latched)
        return Outcome(ok, time.monotonic() - t0)

    def refuse() -> Outcome:
        assert b is not None
        status = b.eval("fetch('/api/estop/release', {method: 'POST'}).then(r => r.status)")
        return Outcome(status == 401, note=f"page without the token: HTTP {status}")

    def release() -> Outcome:
        assert b is not None
        b.wait_for("!document.getElementById('release').disabled", 10, "Release enabled")
        b.click_element("release")
        return Outcome(_wait(lambda: not gate.latched))

    return Source("web page button", latch, refuse, release)


def telegram(c: Clients) -> Source:
    api = c.api
    gate = c.handle.runner.estop

    def latch() -> Outcome:
        n = len(api.sent(OPERATOR_CHAT))
        t0 = time.monotonic()
        api.send_text(OPERATOR_CHAT, "1")
        reply = api.wait_for_reply(OPERATOR_CHAT, lambda t: t.startswith("E-STOP LATCHED"),
                                   after=n)
        return Outcome(gate.latched, reply.time - t0)

    def refuse() -> Outcome:
        n_s, n_o = len(api.sent(STRANGER_CHAT)), len(api.sent(OTHER_CHAT))
        api.send_text(STRANGER_CHAT, "/release")
        api.send_text(OTHER_CHAT, "/release")
        api.wait_for_reply(STRANGER_CHAT, lambda t: "not allowed" in t, after=n_s)
        api.wait_for_reply(OTHER_CHAT, lambda t: t.startswith("Release refused"), after=n_o)
        return Outcome(gate.latched, note="a stranger's and another whitelisted chat's "
                                          "/release")

    def release() -> Outcome:
        n = len(api.sent(OPERATOR_CHAT))
        api.send_text(OPERATOR_CHAT, "/release")
        api.wait_for_reply(OPERATOR_CHAT, lambda t: t == "E-stop released.", after=n)
        return Outcome(not gate.latched)

    return Source("Telegram", latch, refuse, release)


def phone(c: Clients) -> Source:
    def latch() -> Outcome:
        t0 = time.monotonic()
        r = c.http.post("/api/phone/message", json={"text": "Stop"}, headers=c.auth)
        return Outcome(r.status_code == 200, time.monotonic() - t0)

    def refuse() -> Outcome:
        r1 = c.http.post("/api/phone/release")  # no token
        r2 = c.http.post("/api/estop/release", headers=c.auth)  # the dashboard's authority
        return Outcome(r1.status_code == 401 and r2.status_code == 409,
                       note=f"no token: HTTP {r1.status_code}; dashboard: HTTP "
                            f"{r2.status_code}")

    def release() -> Outcome:
        r = c.http.post("/api/phone/release", headers=c.auth)
        return Outcome(r.status_code == 200)

    return Source("phone endpoint", latch, refuse, release)


def lock_topic(c: Clients) -> Source:
    runner = c.handle.runner
    pub: list[Any] = []

    def publish(value: bool) -> None:
        def go(stack: Any) -> None:
            if not pub:
                pub.append(stack.runtime.bus.publisher(LOCK_TOPIC, Bool))
            pub[0].publish(Bool(value))
        runner.call(go)

    def latch() -> Outcome:
        publish(True)
        return Outcome(_wait(lambda: runner.estop.latched))

    def refuse() -> Outcome:
        r = c.http.post("/api/estop/release", headers=c.auth)
        return Outcome(r.status_code == 409, note="dashboard release of a switch latch: "
                                                  f"HTTP {r.status_code}")

    def release() -> Outcome:
        publish(False)
        return Outcome(_wait(lambda: not runner.estop.latched))

    return Source("lock topic", latch, refuse, release)


def joystick(c: Clients) -> Source:
    """The rover's joystick node (``TeleopNode``) in autonomy mode on ``/joy``: its e-stop
    button latches as authority ``joystick``; enable + release buttons release."""
    runner = c.handle.runner
    gate = runner.estop
    params = TeleopNodeParams.from_mapping({"start_mode": "auto"}, key_path="teleop")
    state: dict[str, Any] = {}

    def setup(stack: Any) -> None:
        node = TeleopNode(stack.runtime, params, name="bench_joystick")
        node.configure()
        node.activate()
        state["pub"] = stack.runtime.bus.publisher(params.joy_topic, Joy)

    runner.call(setup)
    width = max(params.estop_button, params.release_button, params.joy.enable_button) + 1

    def press(*buttons: int) -> None:
        pressed = tuple(1 if i in buttons else 0 for i in range(width))
        runner.call(lambda _s: state["pub"].publish(Joy(axes=(0.0,) * 4, buttons=pressed)))
        runner.call(lambda _s: state["pub"].publish(Joy(axes=(0.0,) * 4,
                                                        buttons=(0,) * width)))

    def latch() -> Outcome:
        press(params.estop_button)
        return Outcome(_wait(lambda: gate.latched))

    def refuse() -> Outcome:
        press(params.release_button)  # without the enable button held
        r = c.http.post("/api/estop/release", headers=c.auth)  # another authority
        ok = _wait(lambda: gate.latched, 1.0) and r.status_code == 409
        return Outcome(ok, note=f"release button without enable; dashboard: HTTP "
                                f"{r.status_code}")

    def release() -> Outcome:
        press(params.joy.enable_button, params.release_button)
        return Outcome(_wait(lambda: not gate.latched))

    return Source("joystick button", latch, refuse, release)


SOURCES: tuple[Callable[[Clients], Source], ...] = (web_api, web_page, telegram, phone,
                                                    joystick, lock_topic)
