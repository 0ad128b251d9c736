"""``TelegramBot``: the golf cart's Telegram bot on python-telegram-bot, for a live stack.

Behaviour (issue 18 part 5; the original bot in FIELD-ROBOTS.md):

* **Whitelist, required.**  Only chats in ``allowed_chats`` command the robot; there is no
  open default (an empty list is a configuration error).  Any other chat gets one refusal
  naming its chat id and nothing else happens.
* **Location -> goal.**  A location message selects the predefined target nearest to it
  (haversine) and sends NavigateToPose to that target's pose *with the target's heading*.
  A live location arrives as a location message and then as *edited* messages while it
  moves; each update re-selects the nearest target and re-sends the goal only when the
  target changes.
* **Commands.**  ``/start`` and ``/help`` (usage and targets), ``/status`` (pose, task,
  distance, e-stop), ``/goals`` (the targets, with distances from the chat's last
  location), ``/cancel`` (the running task).
* **E-stop.**  The text ``1`` (as in the original) or ``/estop`` latches the stack's shared
  e-stop with authority ``telegram:<chat_id>``; ``/release`` releases it -- from a
  whitelisted chat, and only the authority that latched (``docs/command_path.md``).
* **Progress and result.**  While a chat's goal runs, the bot reports the distance left
  every ``progress_period`` seconds, and the result (arrived / failed with the reason /
  canceled / replaced by another command) once.
* **Token** from ``$NAVSTACK_TELEGRAM_TOKEN`` or a file (never a command-line value), and
  never logged: the bot redacts it from every log record of python-telegram-bot, httpx
  and navstack while it runs (the Bot API puts the token in every URL).

The bot runs python-telegram-bot's ``Application`` with long polling in its own thread and
event loop; every stack access goes through :meth:`LiveRunner.submit` (the e-stop through
:meth:`LiveRunner.request_estop`, ahead of other work).  ``api_url`` is
python-telegram-bot's ``base_url`` -- the real API, a local Bot API server, or
:class:`~navstack.interfaces.telegram.fake_api.FakeBotApi` in tests.
"""

from __future__ import annotations

import asyncio
import logging
import math
import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from pydantic import Field, field_validator

from navstack.core.errors import NavstackError
from navstack.core.params import Params
from navstack.geo.distance import haversine
from navstack.interfaces.geo_frame import GeoFrame
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.telegram.redact import TokenRedactor
from navstack.interfaces.telegram.targets import Target, nearest_target, targets_from_waypoints
from navstack.interfaces.web.commands import NavCommander
from navstack.nodes.estop import EStopReleaseRefused

__all__ = ["TelegramBot", "TelegramBotError", "TelegramParams"]

T = TypeVar("T")
TOKEN_ENV = "NAVSTACK_TELEGRAM_TOKEN"
_TOKEN = re.compile(r"^\d{1,20}:[A-Za-z0-9_-]{20,}$")
_log = logging.getLogger("navstack.telegram")
TERMINAL = ("SUCCEEDED", "FAILED", "CANCELED", "ABORTED", "REJECTED")
HELP = ("navstack robot bot.\n"
        "Send your location (or share a live location) and I drive to the nearest target.\n"
        "/goals - the targets\n/status - where the robot is and what it does\n"
        "/cancel - cancel the running goal\n"
        "1 or /estop - EMERGENCY STOP (latched)\n/release - release the e-stop you latched\n"
        "/help - this text")


class TelegramBotError(NavstackError):
    """The bot cannot start or run (no whitelist, bad token, API unreachable)."""


class TelegramParams(Params):
    """Bot settings.  ``allowed_chats``: the chat ids that may command the robot
    (required, no open default); ``api_url``: python-telegram-bot's ``base_url``;
    ``progress_period``: wall seconds between progress replies; ``poll_timeout``: the
    getUpdates long-poll timeout [s]."""

    allowed_chats: tuple[int, ...] = Field(min_length=1)
    api_url: str = "https://api.telegram.org/bot"
    progress_period: float = Field(15.0, gt=0.0)
    poll_timeout: int = Field(10, ge=0, le=50)

    @field_validator("allowed_chats")
    @classmethod
    def _unique(cls, v: tuple[int, ...]) -> tuple[int, ...]:
        if len(set(v)) != len(v):
            raise ValueError("chat ids must be unique")
        return v


@dataclass
class _Chat:
    """What the bot remembers about one whitelisted chat."""

    location: tuple[float, float] | None = None
    target: Target | None = None
    goal_id: Any = None
    last_progress: float = 0.0


@dataclass
class BotStats:
    updates: int = 0
    refused: int = 0
    goals: int = 0
    estops: int = 0
    replies: int = 0
    errors: list[str] = field(default_factory=list)


def check_token(token: str) -> str:
    """The token, stripped; TelegramBotError (without echoing it) if it is malformed."""
    token = token.strip()
    if not _TOKEN.match(token):
        raise TelegramBotError("the bot token does not look like a Telegram token "
                               "('<digits>:<35 letters>' from @BotFather); check the token "
                               f"file or ${TOKEN_ENV}")
    return token


class TelegramBot:
    """The bot for ``runner``'s stack (module docstring).  :meth:`start`, :meth:`stop`."""

    def __init__(self, runner: LiveRunner, token: str, params: TelegramParams,
                 targets: list[Target] | None = None,
                 commander: NavCommander | None = None) -> None:
        self.runner = runner
        self.params = params
        self._token = check_token(token)
        self.allowed = frozenset(params.allowed_chats)
        self.commander = commander or runner.call(NavCommander)
        if targets is None:
            def default(stack: Any) -> list[Target]:
                return targets_from_waypoints(stack.world.waypoints, GeoFrame.for_stack(stack))
            targets = runner.call(default)
        if not targets:
            raise TelegramBotError("the bot has no targets: give a targets file or use a "
                                   "world with named waypoints")
        self.targets = targets
        self.stats = BotStats()
        self.chats: dict[int, _Chat] = {}
        self._redactor = TokenRedactor(self._token)
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._failure: BaseException | None = None

    # --- lifecycle -------------------------------------------------------------------------
    def start(self, timeout: float = 30.0) -> None:
        """Connect (``getMe``), start long polling, return once updates are fetched."""
        if self._thread is not None:
            raise TelegramBotError("the bot was already started")
        self._redactor.install()
        self._thread = threading.Thread(target=self._run, name="navstack-telegram",
                                        daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            self.stop()
            raise TelegramBotError(f"the bot did not start within {timeout:.0f} s "
                                   f"(Bot API at {self._redactor.redact(self.params.api_url)})")
        if self._failure is not None:
            self._redactor.uninstall()
            raise TelegramBotError(str(self._failure)) from None

    def stop(self, timeout: float = 15.0) -> None:
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(stop.set)
        if self._thread is not None:
            self._thread.join(timeout)
        self._redactor.uninstall()

    def _run(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as exc:  # reported through start()
            self._failure = exc
            self._ready.set()

    async def _main(self) -> None:
        from telegram.error import InvalidToken, NetworkError, TelegramError

        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        app = self._build()
        try:
            await app.initialize()
        except InvalidToken:
            self._failure = TelegramBotError(
                "the Bot API refused the bot token (401 Unauthorized); check the token file "
                f"or ${TOKEN_ENV}")
            self._ready.set()
            return
        except (NetworkError, TelegramError) as exc:
            self._failure = TelegramBotError(
                f"cannot reach the Bot API at {self._redactor.redact(self.params.api_url)}: "
                f"{self._redactor.redact(str(exc))}")
            self._ready.set()
            return
        try:
            await app.start()
            assert app.updater is not None
            await app.updater.start_polling(poll_interval=0.0,
                                            timeout=self.params.poll_timeout,
                                            allowed_updates=["message", "edited_message"])
            progress = asyncio.create_task(self._progress_loop(app))
            self._ready.set()
            _log.info("telegram bot polling; %d whitelisted chats, %d targets",
                      len(self.allowed), len(self.targets))
            await self._stop.wait()
            progress.cancel()
            await app.updater.stop()
            await app.stop()
        finally:
            await app.shutdown()

    def _build(self) -> Any:
        from telegram import Update
        from telegram.ext import (
            ApplicationBuilder,
            ApplicationHandlerStop,
            CommandHandler,
            ContextTypes,
            MessageHandler,
            TypeHandler,
            filters,
        )

        base = self.params.api_url.rstrip("/")
        app = (ApplicationBuilder().token(self._token).base_url(base)
               .base_file_url(base.replace("/bot", "/file/bot"))
               .get_updates_read_timeout(self.params.poll_timeout + 10.0).build())

        async def gate(update: Update, context: ContextTypes.DEFAULT_TYPE) -> None:
            self.stats.updates += 1
            chat = update.effective_chat
            if chat is not None and chat.id in self.allowed:
                return
            self.stats.refused += 1
            if chat is not None:
                _log.warning("refused an update from chat %s (not whitelisted)", chat.id)
                await self._say(context.bot, chat.id,
                                f"This chat (id {chat.id}) is not allowed to command the "
                                "robot. Ask its operator to add it to the whitelist "
                                f"(--allow {chat.id}).")
            raise ApplicationHandlerStop

        def on(fn: Callable[[int, Any, Any], Any]) -> Callable[[Update, Any], Any]:
            async def handler(update: Update, context: ContextTypes.DEFAULT_TYPE) -> None:
                chat = update.effective_chat
                assert chat is not None
                try:
                    await fn(chat.id, update, context.bot)
                except NavstackError as exc:  # a refused goal, a stopped simulation...
                    await self._say(context.bot, chat.id, f"Sorry, that did not work: {exc}")
            return handler

        app.add_handler(TypeHandler(Update, gate), group=-1)
        for names, fn in ((("start", "help"), self._help), (("status",), self._status),
                          (("goals",), self._goals), (("cancel",), self._cancel),
                          (("estop",), self._estop), (("release",), self._release)):
            app.add_handler(CommandHandler(list(names), on(fn)))
        app.add_handler(MessageHandler(filters.Regex(r"^\s*1\s*$"), on(self._estop)))
        app.add_handler(MessageHandler(filters.LOCATION, on(self._location)))
        app.add_handler(MessageHandler(filters.ALL, on(self._unknown)))

        async def on_error(_update: object, context: ContextTypes.DEFAULT_TYPE) -> None:
            text = self._redactor.redact(f"{type(context.error).__name__}: {context.error}")
            self.stats.errors.append(text)
            _log.error("telegram handler failed: %s", text)

        app.add_error_handler(on_error)
        return app

    # --- helpers ---------------------------------------------------------------------------
    async def _sim(self, fn: Callable[[Any], T]) -> T:
        return await asyncio.wrap_future(self.runner.submit(fn))

    async def _say(self, bot: Any, chat_id: int, text: str) -> None:
        await bot.send_message(chat_id, text)
        self.stats.replies += 1

    def _chat(self, chat_id: int) -> _Chat:
        return self.chats.setdefault(chat_id, _Chat())

    # --- handlers --------------------------------------------------------------------------
    async def _help(self, chat_id: int, _update: Any, bot: Any) -> None:
        names = ", ".join(t.name for t in self.targets)
        await self._say(bot, chat_id, f"{HELP}\nTargets: {names}")

    async def _unknown(self, chat_id: int, _update: Any, bot: Any) -> None:
        await self._say(bot, chat_id, "I did not understand that. Send your location, 1 "
                                      "for an emergency stop, or /help.")

    async def _goals(self, chat_id: int, _update: Any, bot: Any) -> None:
        here = self._chat(chat_id).location
        lines = []
        for t in self.targets:
            line = f"- {t.describe()}"
            if here is not None:
                line += f": {float(haversine(here[0], here[1], t.latitude, t.longitude)):.0f}" \
                        " m from you"
            lines.append(line)
        await self._say(bot, chat_id, "Targets:\n" + "\n".join(lines))

    async def _status(self, chat_id: int, _update: Any, bot: Any) -> None:
        commander, gate = self.commander, self.runner.estop

        def read(_s: Any) -> tuple[Any, dict[str, Any], dict[str, Any]]:
            return commander.robot_pose(), commander.status(), gate.state()

        pose, nav, estop = await self._sim(read)
        where = ("unknown" if pose is None else
                 f"x={pose.x:.1f} y={pose.y:.1f} heading {math.degrees(pose.theta):.0f} deg")
        text = f"Robot at {where}. Task: {nav['task'] or 'none'}, {nav['status']}"
        if nav["distance_remaining"] is not None:
            text += f", {nav['distance_remaining']:.1f} m to go"
        target = self._chat(chat_id).target
        if target is not None:
            text += f" (your target: {target.name})"
        text += "." + (f" E-STOP LATCHED by {estop['holder'] or 'the lock topic'}."
                       if estop["latched"] else "")
        await self._say(bot, chat_id, text)

    async def _cancel(self, chat_id: int, _update: Any, bot: Any) -> None:
        out = await self._sim(lambda _s: self.commander.cancel())
        self._chat(chat_id).goal_id = None
        await self._say(bot, chat_id, "Canceled the running goal." if out["canceled"]
                        else "Nothing to cancel.")

    async def _estop(self, chat_id: int, _update: Any, bot: Any) -> None:
        self.stats.estops += 1
        latched_at = await asyncio.wrap_future(self.runner.request_estop(
            f"telegram:{chat_id}", "Telegram emergency stop"))
        await self._say(bot, chat_id, f"E-STOP LATCHED (t={latched_at:.2f} s). The robot is "
                                      "stopped. Send /release to release it.")

    async def _release(self, chat_id: int, _update: Any, bot: Any) -> None:
        gate = self.runner.estop
        try:
            await self._sim(lambda _s: gate.release(f"telegram:{chat_id}"))
        except EStopReleaseRefused as exc:
            await self._say(bot, chat_id, f"Release refused: {exc}.")
            return
        await self._say(bot, chat_id, "E-stop released.")

    async def _location(self, chat_id: int, update: Any, bot: Any) -> None:
        edited = update.edited_message is not None
        loc = update.effective_message.location
        chat = self._chat(chat_id)
        chat.location = (loc.latitude, loc.longitude)
        target, distance = nearest_target(self.targets, loc.latitude, loc.longitude)
        if edited and chat.target == target and chat.goal_id is not None:
            return  # the live location moved, the nearest target did not change
        t = target
        out = await self._sim(lambda _s: self.commander.go_to(t.x, t.y, t.yaw))
        self.stats.goals += 1
        switched = edited and chat.target is not None and chat.target != target
        chat.target, chat.goal_id, chat.last_progress = target, out["goal_id"], time.monotonic()
        verb = "Switching to" if switched else "Going to"
        await self._say(bot, chat_id, f"{verb} {target.name}, the target nearest to you "
                                      f"({distance:.0f} m away), heading "
                                      f"{math.degrees(target.yaw):.0f} deg.")

    # --- progress ----------------------------------------------------------------------------
    async def _progress_loop(self, app: Any) -> None:
        while True:
            await asyncio.sleep(min(1.0, self.params.progress_period))
            active = {cid: c for cid, c in self.chats.items() if c.goal_id is not None}
            if not active:
                continue
            try:
                nav = await self._sim(lambda _s: self.commander.status())
                for cid, chat in active.items():
                    await self._report(app.bot, cid, chat, nav)
            except Exception as exc:  # a lost reply must not end the reports
                self.stats.errors.append(self._redactor.redact(str(exc)))
                _log.warning("progress report failed: %s", self._redactor.redact(str(exc)))

    async def _report(self, bot: Any, chat_id: int, chat: _Chat, nav: dict[str, Any]) -> None:
        name = chat.target.name if chat.target is not None else "the goal"
        if nav.get("goal_id") != chat.goal_id:
            chat.goal_id = None
            await self._say(bot, chat_id, f"Your goal to {name} was replaced by another "
                                          "command.")
            return
        status = nav["status"]
        if status in TERMINAL:
            chat.goal_id = None
            text = {"SUCCEEDED": f"Arrived at {name}.",
                    "CANCELED": f"The goal to {name} was canceled."}.get(
                status, f"Could not reach {name}: {nav['reason'] or status}.")
            await self._say(bot, chat_id, text)
            return
        now = time.monotonic()
        if now - chat.last_progress >= self.params.progress_period:
            chat.last_progress = now
            left = nav["distance_remaining"]
            eta = nav["eta"]
            text = f"On the way to {name}"
            if left is not None:
                text += f": {left:.0f} m to go"
            if eta is not None:
                text += f", about {eta:.0f} s"
            await self._say(bot, chat_id, text + ".")
