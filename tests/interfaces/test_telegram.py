"""The Telegram bot against a local fake Bot API server (python-telegram-bot's base_url):
whitelisted location -> goal to the nearest target with its heading, an edited live
location switches target, a non-whitelisted chat is refused and nothing moves, "1" stops
the robot, progress and result replies, the token never reaches a log."""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from navstack.core.errors import ConfigError
from navstack.geo.distance import haversine
from navstack.interfaces.geo_frame import GeoFrame
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack
from navstack.interfaces.telegram import (
    TelegramBot,
    TelegramBotError,
    TelegramParams,
    load_targets,
)
from navstack.interfaces.telegram.fake_api import FakeBotApi
from navstack.interfaces.telegram.targets import nearest_target
from tests.interfaces.web.conftest import Base, wait_until

TOKEN = "123456789:AAFakeTokenForTestsOnly_0123456789abc"
OPERATOR, SECOND, STRANGER = 1001, 1002, 6666


@dataclass
class Setup:
    runner: LiveRunner
    api: FakeBotApi
    bot: TelegramBot
    base: Base
    geo: GeoFrame

    def ll(self, x: float, y: float) -> tuple[float, float]:
        return self.geo.to_ll(x, y)

    def nav(self) -> dict[str, object]:
        return self.runner.call(lambda _s: self.bot.commander.status())


@pytest.fixture
def setup(request: pytest.FixtureRequest, caplog: pytest.LogCaptureFixture,
          navigation_compiled: None) -> Iterator[Setup]:
    """The bot on a live office stack; ``indirect`` parametrisation paces the simulation
    (a real-time factor) where a test needs the drive to outlast wall-clock progress."""
    caplog.set_level(logging.DEBUG)  # everything the libraries log is checked for the token
    stack = NavStack("office", seed=1)
    runner = LiveRunner(stack, real_time_factor=getattr(request, "param", None))
    runner.start()
    base = Base()
    base.install(runner)
    api = FakeBotApi(TOKEN)
    bot = TelegramBot(runner, TOKEN, TelegramParams(allowed_chats=(OPERATOR, SECOND),
                                                    api_url=api.base_url,
                                                    progress_period=1.0, poll_timeout=1))
    bot.start()
    geo = runner.call(GeoFrame.for_stack)
    try:
        yield Setup(runner, api, bot, base, geo)
    finally:
        bot.stop()
        api.stop()
        runner.stop()
    assert TOKEN not in caplog.text
    assert TOKEN.split(":")[1] not in caplog.text
    assert "/bot<token>/getUpdates" in caplog.text  # httpx logged the URLs, redacted


def test_location_sends_the_nearest_target_with_its_heading_and_reports(setup: Setup) -> None:
    api = setup.api
    api.send_text(OPERATOR, "/start")
    assert "Send your location" in api.wait_for_reply(OPERATOR, lambda t: "Targets:" in t).text
    # beside Goal_1 (2.5, 4.0, heading 0), farther from Marker_View (2.2, 5.0)
    lat, lon = setup.ll(2.5, 3.3)
    api.send_location(OPERATOR, lat, lon)
    reply = api.wait_for_reply(OPERATOR, lambda t: t.startswith("Going to"))
    assert reply.text.startswith("Going to Goal_1, the target nearest to you (1 m away), "
                                 "heading 0 deg.")
    nav = setup.nav()
    assert nav["task"] == "navigate_to_pose"
    assert nav["goal"] == [2.5, 4.0, 0.0]
    api.wait_for_reply(OPERATOR, lambda t: t == "Arrived at Goal_1.", timeout=60)
    assert setup.nav()["status"] == "SUCCEEDED"
    x, y, th = setup.runner.call(lambda s: s.sim.sim.pose.as_array())
    assert math.hypot(x - 2.5, y - 4.0) <= 0.25 and abs(th) <= 0.25
    api.send_text(OPERATOR, "/status")
    status = api.wait_for_reply(OPERATOR, lambda t: t.startswith("Robot at")).text
    assert "SUCCEEDED" in status and "your target: Goal_1" in status
    api.send_text(OPERATOR, "/goals")
    goals = api.wait_for_reply(OPERATOR, lambda t: t.startswith("Targets:")).text
    assert goals.count("\n- ") == 6 and "Goal_1 (" in goals and "m from you" in goals


def test_edited_live_location_switches_target(setup: Setup) -> None:
    api = setup.api
    lat, lon = setup.ll(17.2, 3.5)  # near Goal_3 (17.0, 3.0, heading -90 deg)
    api.send_location(OPERATOR, lat, lon, live_period=600)
    api.wait_for_reply(OPERATOR, lambda t: t.startswith("Going to Goal_3,"))
    assert setup.nav()["goal"] == [17.0, 3.0, -1.5708]
    first_goal = setup.nav()["goal_id"]
    lat, lon = setup.ll(17.0, 3.2)  # moved, still nearest to Goal_3: no new goal
    api.send_location(OPERATOR, lat, lon, edit=True)
    lat, lon = setup.ll(18.0, 7.4)  # walked into the corridor: Corridor_East is nearest
    api.send_location(OPERATOR, lat, lon, edit=True)
    reply = api.wait_for_reply(OPERATOR, lambda t: t.startswith("Switching to"))
    assert reply.text.startswith("Switching to Corridor_East, the target nearest to you")
    nav = setup.nav()
    assert nav["goal"] == [18.5, 7.5, 0.0] and nav["goal_id"] != first_goal
    assert setup.bot.stats.goals == 2  # the in-between update did not re-send the goal
    api.send_text(OPERATOR, "/cancel")
    api.wait_for_reply(OPERATOR, lambda t: t == "Canceled the running goal.")
    wait_until(lambda: setup.nav()["status"] == "CANCELED", 10, "the cancel")


def test_stranger_is_refused_and_nothing_moves(setup: Setup) -> None:
    api = setup.api
    lat, lon = setup.ll(2.5, 4.0)
    api.send_location(STRANGER, lat, lon)
    api.send_text(STRANGER, "1")
    api.send_text(STRANGER, "/release")
    refusal = api.wait_for_reply(STRANGER, lambda t: "not allowed" in t)
    assert refusal.text == ("This chat (id 6666) is not allowed to command the robot. Ask its "
                            "operator to add it to the whitelist (--allow 6666).")
    wait_until(lambda: len(api.sent(STRANGER)) == 3, 10, "the three refusals")
    assert setup.bot.stats.refused == 3
    assert all("not allowed" in m.text for m in api.sent(STRANGER))
    assert setup.nav()["task"] is None and setup.bot.stats.goals == 0
    assert not setup.runner.estop.latched
    assert max(abs(r[3]) for r in setup.base.rows) == 0.0  # the base never moved


# Progress replies are wall-clock periodic; an unpaced simulation can arrive first.
@pytest.mark.parametrize("setup", [4.0], indirect=True, ids=["rtf4"])
def test_one_latches_the_estop_and_only_that_chat_releases(setup: Setup) -> None:
    api = setup.api
    lat, lon = setup.ll(18.0, 7.4)
    api.send_location(OPERATOR, lat, lon)  # Corridor_East: a long drive
    api.wait_for_reply(OPERATOR, lambda t: t.startswith("Going to Corridor_East"))
    wait_until(lambda: setup.base.speed() > 0.3, 30, "the robot to drive")
    progress = api.wait_for_reply(OPERATOR, lambda t: t.startswith("On the way"), timeout=30)
    assert re.fullmatch(r"On the way to Corridor_East: \d+ m to go, about \d+ s\.",
                        progress.text), progress.text
    api.send_text(OPERATOR, "1")
    api.wait_for_reply(OPERATOR, lambda t: t.startswith("E-STOP LATCHED"))
    gate = setup.runner.estop
    assert gate.latched and gate.holder == f"telegram:{OPERATOR}"
    event = gate.history()[0]
    assert event["kind"] == "latch" and event["source"] == f"telegram:{OPERATOR}"
    assert 0.0 <= event["time"] - event["requested_at"] <= 0.05 + 1e-9  # one control cycle
    latched_at = gate.latched_at
    assert latched_at is not None
    wait_until(lambda: setup.runner.now > latched_at + 2.0, 30, "2 s of e-stop")
    api.send_text(SECOND, "/release")  # whitelisted, but not the chat that latched
    refused = api.wait_for_reply(SECOND, lambda t: t.startswith("Release refused"))
    assert refused.text == (f"Release refused: the e-stop is held by 'telegram:{OPERATOR}', "
                            f"not by 'telegram:{SECOND}'; release it there.")
    wait_until(lambda: setup.runner.now > latched_at + 3.0, 30, "3 s of e-stop")
    assert gate.latched
    rows = [r for r in setup.base.rows if r[0] > latched_at]
    assert rows and all(r[1] == 0.0 and r[2] == 0.0 for r in rows)  # commanded zero
    api.send_text(OPERATOR, "/release")
    api.wait_for_reply(OPERATOR, lambda t: t == "E-stop released.")
    assert not gate.latched
    wait_until(lambda: setup.base.speed() > 0.1, 30, "the robot to drive again")


def test_bad_token_whitelist_and_targets_are_reported(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"allowed_chats"):
        TelegramParams.from_mapping({"allowed_chats": []}, key_path="telegram")
    stack = NavStack("office", seed=1)
    runner = LiveRunner(stack, real_time_factor=None)
    api = FakeBotApi("999:AAOtherTokenOtherTokenOtherToken")
    params = TelegramParams(allowed_chats=(OPERATOR,), api_url=api.base_url, poll_timeout=1)
    try:
        with pytest.raises(TelegramBotError, match="does not look like a Telegram token") as e:
            TelegramBot(runner, "not-a-token", params)
        assert "not-a-token" not in str(e.value)
        bot = TelegramBot(runner, TOKEN, params)
        with pytest.raises(TelegramBotError) as refused:
            bot.start()
        assert str(refused.value) == ("the Bot API refused the bot token (401 Unauthorized); "
                                      "check the token file or $NAVSTACK_TELEGRAM_TOKEN")
    finally:
        api.stop()
    geo = GeoFrame.from_datum(38.4, -110.8)
    lat, lon = geo.to_ll(30.0, 40.0)
    f = tmp_path / "targets.yaml"
    f.write_text(f"targets:\n  - {{name: Library, latitude: {lat}, longitude: {lon}, "
                 "yaw: 1.5708}\n  - {name: Lab, latitude: 38.4, longitude: -110.8, yaw: 0.0,"
                 " x: 1.0, y: 2.0}\n")
    targets = load_targets(f, geo)
    assert targets[0].name == "Library" and abs(targets[0].x - 30.0) < 1e-6
    assert (targets[1].x, targets[1].y) == (1.0, 2.0)
    here = geo.to_ll(29.0, 38.0)
    target, d = nearest_target(targets, *here)
    assert target.name == "Library"
    assert d == pytest.approx(float(haversine(*here, lat, lon)))
    assert abs(d - math.hypot(1.0, 2.0)) < 0.02  # haversine vs the ENU plane: < 1 %
    f.write_text("targets:\n  - {name: Lab, latitude: 95, longitude: 0, yaw: 0}\n")
    with pytest.raises(ConfigError, match=r"targets\[0\]\.latitude: Input should be less "
                                          r"than or equal to 90"):
        load_targets(f, geo)


def test_cli_runs_the_bot_with_the_token_from_the_environment() -> None:
    import os
    import subprocess
    import sys

    from typer.testing import CliRunner

    from navstack.app import app

    result = CliRunner().invoke(app, ["telegram", "--duration", "1"])
    assert result.exit_code == 2
    assert "error: no chat is allowed: give --allow CHAT_ID" in result.output
    api = FakeBotApi(TOKEN)
    env = {**os.environ, "NAVSTACK_TELEGRAM_TOKEN": TOKEN}
    proc = subprocess.Popen([sys.executable, "-m", "navstack.app", "telegram", "--allow",
                             str(OPERATOR), "--api-url", api.base_url, "--rate", "5",
                             "--duration", "300"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert proc.stdout is not None
        # the kernels are warmed before the bot answers (navstack.interfaces.warm_up)
        warming, warm, line = (proc.stdout.readline() for _ in range(3))
        assert warming.startswith("navstack: warming up navigation")
        assert re.fullmatch(r"navstack: navigation warm in \d+\.\d s\n", warm), warm
        assert line.startswith("telegram bot running: 1 allowed chat(s), targets: Goal_1")
        api.send_text(OPERATOR, "/help")
        assert "Targets: Goal_1" in api.wait_for_reply(OPERATOR, lambda t: "/estop" in t).text
    finally:
        proc.terminate()
        out = proc.communicate(timeout=30)[0]
        api.stop()
    assert TOKEN not in warming + warm + line + out


def test_a_goal_the_stack_refuses_is_reported_in_the_chat() -> None:
    from navstack.interfaces.telegram import Target

    stack = NavStack("office", seed=1)
    runner = LiveRunner(stack, real_time_factor=None)
    runner.start()
    api = FakeBotApi(TOKEN)
    geo = runner.call(GeoFrame.for_stack)
    lat, lon = geo.to_ll(100.0, 5.0)
    bot = TelegramBot(runner, TOKEN, TelegramParams(allowed_chats=(OPERATOR,),
                                                    api_url=api.base_url, poll_timeout=1),
                      targets=[Target("Far", lat, lon, 100.0, 5.0, 0.0)])
    try:
        bot.start()
        api.send_location(OPERATOR, lat, lon)
        reply = api.wait_for_reply(OPERATOR, lambda t: t.startswith("Sorry"))
        assert reply.text == ("Sorry, that did not work: x=100 is outside the map: x must lie "
                              "in [0, 20] m (map frame)")
        assert bot.chats[OPERATOR].goal_id is None
    finally:
        bot.stop()
        api.stop()
        runner.stop()
