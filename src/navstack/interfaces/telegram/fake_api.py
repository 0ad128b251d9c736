"""A local Telegram Bot API server: the few methods python-telegram-bot calls, over HTTP.

For tests, benchmarks and offline demos of the bot (ARCHITECTURE.md §7: operator
interfaces are tested against real software on the other side).  The bot talks to it
exactly as to ``api.telegram.org``: ``ApplicationBuilder().base_url(f"{url}/bot")``; the
server answers ``/bot<token>/<method>`` with the Bot API's JSON envelope
``{"ok": true, "result": ...}`` (or ``{"ok": false, "error_code": 401, ...}`` for a wrong
token), parses the form-encoded parameters python-telegram-bot sends (non-string values
JSON-encoded), and implements:

* ``getMe``, ``deleteWebhook``, ``getWebhookInfo``, ``setMyCommands``, ``getMyCommands``,
  ``close``, ``logOut``;
* ``getUpdates`` with ``offset`` (confirms earlier updates), ``limit`` and long polling
  (``timeout`` seconds);
* ``sendMessage`` (recorded; replies are what a test reads).

The test side plays the users: :meth:`FakeBotApi.send_text`, :meth:`send_location`
(``edit=True`` makes it an ``edited_message``, which is how Telegram delivers live-location
updates), :meth:`wait_for_reply`.  Updates carry the fields the Bot API documents for
``Message`` (``message_id``, ``date``, ``chat``, ``from``, ``text`` + ``entities`` for
commands, ``location`` with ``live_period`` for live locations).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import parse_qsl, urlsplit

__all__ = ["FakeBotApi", "SentMessage"]

_STRING_PARAMS = {"text", "parse_mode", "url", "secret_token", "scope", "language_code"}
BOT_USER = {"id": 4242, "is_bot": True, "first_name": "navstack", "username": "navstack_bot",
            "can_join_groups": False, "can_read_all_group_messages": False,
            "supports_inline_queries": False}


@dataclass(frozen=True)
class SentMessage:
    """A message the bot sent (``sendMessage``), with the wall time it arrived."""

    chat_id: int
    text: str
    time: float


@dataclass
class _State:
    updates: list[dict[str, Any]] = field(default_factory=list)
    sent: list[SentMessage] = field(default_factory=list)
    calls: list[str] = field(default_factory=list)
    next_update: int = 1
    next_message: int = 1
    live: dict[tuple[int, int], int] = field(default_factory=dict)  # (chat, user) -> msg id


class FakeBotApi:
    """A Bot API server on ``127.0.0.1`` (free port) for the bot with ``token``."""

    def __init__(self, token: str, host: str = "127.0.0.1", port: int = 0) -> None:
        self.token = token
        self._state = _State()
        self._cond = threading.Condition()
        api = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args: Any) -> None:  # keep tokens out of stderr
                return

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                self._answer(self.rfile.read(length) if length else b"")

            def do_GET(self) -> None:
                self._answer(urlsplit(self.path).query.encode())

            def _answer(self, raw: bytes) -> None:
                status, body = api._dispatch(urlsplit(self.path).path, raw,
                                             self.headers.get("Content-Type", ""))
                data = json.dumps(body).encode()
                try:
                    self.send_response(status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    self.close_connection = True  # the bot went away mid-poll

        self._server = ThreadingHTTPServer((host, port), Handler)
        self._server.daemon_threads = True
        self._thread = threading.Thread(target=self._server.serve_forever,
                                        name="fake-bot-api", daemon=True)
        self._thread.start()

    # --- the server side -------------------------------------------------------------------
    @property
    def url(self) -> str:
        host, port = self._server.server_address[:2]
        return f"http://{host!s}:{port}"

    @property
    def base_url(self) -> str:
        """What to give ``ApplicationBuilder().base_url(...)``."""
        return f"{self.url}/bot"

    def _dispatch(self, path: str, raw: bytes, content_type: str) -> tuple[int, dict[str, Any]]:
        prefix = f"/bot{self.token}/"
        if not path.startswith(prefix):
            return 401, {"ok": False, "error_code": 401, "description": "Unauthorized"}
        method = path[len(prefix):]
        params = _params(raw, content_type)
        with self._cond:
            self._state.calls.append(method)
        handler: Callable[[dict[str, Any]], Any] | None = {
            "getMe": lambda _p: BOT_USER,
            "deleteWebhook": lambda _p: True,
            "getWebhookInfo": lambda _p: {"url": "", "has_custom_certificate": False,
                                          "pending_update_count": len(self._state.updates)},
            "setMyCommands": lambda _p: True,
            "getMyCommands": lambda _p: [],
            "close": lambda _p: True,
            "logOut": lambda _p: True,
            "getUpdates": self._get_updates,
            "sendMessage": self._send_message,
        }.get(method)
        if handler is None:
            return 404, {"ok": False, "error_code": 404, "description": "Not Found: method "
                                                                        f"{method} unknown"}
        try:
            return 200, {"ok": True, "result": handler(params)}
        except (KeyError, ValueError, TypeError) as exc:
            return 400, {"ok": False, "error_code": 400, "description": f"Bad Request: {exc}"}

    def _get_updates(self, p: dict[str, Any]) -> list[dict[str, Any]]:
        offset = int(p.get("offset", 0) or 0)
        limit = int(p.get("limit", 100) or 100)
        deadline = time.monotonic() + float(p.get("timeout", 0) or 0)
        with self._cond:
            st = self._state
            if offset:
                st.updates = [u for u in st.updates if u["update_id"] >= offset]
            while not st.updates and (left := deadline - time.monotonic()) > 0:
                self._cond.wait(min(left, 0.5))
            return st.updates[:limit]

    def _send_message(self, p: dict[str, Any]) -> dict[str, Any]:
        chat_id, text = int(p["chat_id"]), str(p["text"])
        with self._cond:
            st = self._state
            st.sent.append(SentMessage(chat_id, text, time.monotonic()))
            mid = st.next_message
            st.next_message += 1
            self._cond.notify_all()
        return {"message_id": mid, "date": int(time.time()), "text": text,
                "chat": {"id": chat_id, "type": "private"},
                "from": {k: BOT_USER[k] for k in ("id", "is_bot", "first_name", "username")}}

    def stop(self) -> None:
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(5)

    # --- the users' side ---------------------------------------------------------------------
    def _push(self, chat_id: int, body: dict[str, Any], edit_of: int | None = None) -> int:
        with self._cond:
            st = self._state
            mid = edit_of if edit_of is not None else st.next_message
            if edit_of is None:
                st.next_message += 1
            msg = {"message_id": mid, "date": int(time.time()),
                   "chat": {"id": chat_id, "type": "private", "first_name": "operator"},
                   "from": {"id": chat_id, "is_bot": False, "first_name": "operator"}, **body}
            kind = "message"
            if edit_of is not None:
                msg["edit_date"] = int(time.time())
                kind = "edited_message"
            st.updates.append({"update_id": st.next_update, kind: msg})
            st.next_update += 1
            self._cond.notify_all()
            return int(mid)

    def send_text(self, chat_id: int, text: str) -> int:
        """A user in private chat ``chat_id`` sends ``text`` (``/cmd`` gets a bot_command
        entity, as Telegram adds it); returns the message id."""
        body: dict[str, Any] = {"text": text}
        if text.startswith("/"):
            body["entities"] = [{"type": "bot_command", "offset": 0,
                                 "length": len(text.split()[0])}]
        return self._push(chat_id, body)

    def send_location(self, chat_id: int, latitude: float, longitude: float, *,
                      live_period: int | None = None, edit: bool = False,
                      accuracy: float | None = None) -> int:
        """A location message; ``live_period`` makes it a live location, and ``edit=True``
        sends it as the update of the chat's running live location (an edited message of
        the same id, as Telegram does)."""
        loc: dict[str, Any] = {"latitude": latitude, "longitude": longitude}
        if live_period is not None:
            loc["live_period"] = live_period
        if accuracy is not None:
            loc["horizontal_accuracy"] = accuracy
        key = (chat_id, chat_id)
        with self._cond:
            previous = self._state.live.get(key)
        if edit and previous is None:
            raise ValueError(f"chat {chat_id} has no live location to update; send one first")
        mid = self._push(chat_id, {"location": loc}, previous if edit else None)
        if live_period is not None and not edit:
            with self._cond:
                self._state.live[key] = mid
        return mid

    def sent(self, chat_id: int | None = None) -> list[SentMessage]:
        with self._cond:
            return [m for m in self._state.sent if chat_id is None or m.chat_id == chat_id]

    def calls(self) -> list[str]:
        with self._cond:
            return list(self._state.calls)

    def pending_updates(self) -> int:
        with self._cond:
            return len(self._state.updates)

    def wait_for_reply(self, chat_id: int, predicate: Callable[[str], bool],
                       timeout: float = 20.0, after: int = 0) -> SentMessage:
        """The first message to ``chat_id`` (from index ``after`` of that chat's messages)
        whose text satisfies ``predicate``; TimeoutError naming what was sent otherwise."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                mine = [m for m in self._state.sent if m.chat_id == chat_id][after:]
                for m in mine:
                    if predicate(m.text):
                        return m
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"no matching reply to chat {chat_id} within "
                                       f"{timeout:.0f} s; it got: {[m.text for m in mine]}")
                self._cond.wait(min(left, 0.5))


def _params(raw: bytes, content_type: str) -> dict[str, Any]:
    """The Bot API accepts query strings, form data and JSON; python-telegram-bot sends
    form fields whose non-string values are JSON-encoded."""
    if "application/json" in content_type:
        data = json.loads(raw or b"{}")
        return dict(data) if isinstance(data, dict) else {}
    out: dict[str, Any] = {}
    for key, value in parse_qsl(raw.decode("utf-8"), keep_blank_values=True):
        if key in _STRING_PARAMS:
            out[key] = value
            continue
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out
