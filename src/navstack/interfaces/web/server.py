"""The dashboard's HTTP/WebSocket server: a FastAPI app served by uvicorn in a thread.

Read-only routes (no token): ``GET /`` (the page), ``/static/*``, ``/api/hello``,
``/api/state`` (latest snapshot), ``/api/layers/{map,global_costmap,local_costmap}.png``,
``/api/plan``, ``/api/trail?since=N`` and the WebSocket ``/ws``, which pushes the state at
``frame_rate`` (>= 10 Hz; lowered for everyone when many viewers share the telemetry
budget) plus images, plan and trajectory points when they change.

Command routes need the token (``Authorization: Bearer <token>`` or ``X-Navstack-Token``)
and answer HTTP 401 without it: ``POST /api/goal``, ``POST /api/waypoints``,
``DELETE /api/waypoints``, ``POST /api/waypoints/go``, ``POST /api/cancel``,
``POST /api/estop``, ``POST /api/estop/release`` (and ``GET /api/auth`` to check a token).
WebSocket ``{"type": "command", "token": ..., "command": ..., "args": {...}}`` messages are
checked the same way and refused with ``status`` 401.  Every command is executed in the
simulation thread (:meth:`LiveRunner.submit`; the e-stop ahead of everything else); the
handler awaits its result, so a reply means the command has taken effect (the e-stop
reply carries the simulated time at which the base was commanded to zero, ``requested_at``
the simulated time at which the request was queued: they differ by at most one step, one
control cycle).  Protections (host/origin allow-list, rate limits, caps, body and frame
limits) are in :mod:`~navstack.interfaces.web.guard` and
:mod:`~navstack.interfaces.web.transport`.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import random
import secrets
import socket
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

from fastapi import FastAPI, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from navstack.core.errors import NavstackError
from navstack.core.geometry import MAX_COORDINATE
from navstack.interfaces.live_runner import LiveRunner, RunnerError
from navstack.interfaces.web.commands import (
    CommandRejected,
    GoalOutOfBounds,
    GoMode,
    NavCommander,
)
from navstack.interfaces.web.guard import (
    BodyError,
    Scope,
    TokenBucket,
    ViewerRegistry,
    WebSecurityParams,
    client_address,
    parse_json,
)
from navstack.interfaces.web.model import LAYERS, DashboardModel

COMMAND_TIMEOUT = 10.0
"""Wall seconds a command may wait for the simulation thread."""
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Heading = Annotated[float, Field(allow_inf_nan=False, ge=-1000.0, le=1000.0)]
COMMAND_NAMES = ("goal", "add_waypoint", "clear_waypoints", "go", "cancel", "estop", "release")


def static_dir() -> Path:
    return Path(str(resources.files("navstack.interfaces.web") / "static"))


class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid")


class PoseRequest(_Body):
    """A goal or waypoint in ``map``; ``theta`` omitted: face along the direction of travel."""

    x: Coordinate
    y: Coordinate
    theta: Heading | None = None


class GoRequest(_Body):
    mode: GoMode = "follow_waypoints"


class EStopRequest(_Body):
    reason: str = Field("", max_length=200)


class _Empty(_Body):
    pass


Handler = Callable[[Any, str], dict[str, Any]]
"""A command run in the simulation thread: (validated body, source) -> reply."""


def _commands(commander: NavCommander, runner: LiveRunner
              ) -> dict[str, tuple[type[_Body], Handler]]:
    """Command name -> (body model, function run in the simulation thread).  The e-stop is
    not here: it goes through :meth:`LiveRunner.request_estop` (urgent)."""
    gate = runner.estop
    return {
        "goal": (PoseRequest, lambda b, _: commander.go_to(b.x, b.y, b.theta)),
        "add_waypoint": (PoseRequest, lambda b, _: commander.add_waypoint(b.x, b.y, b.theta)),
        "clear_waypoints": (_Empty, lambda _b, _: commander.clear_waypoints()),
        "go": (GoRequest, lambda b, _: commander.go(b.mode)),
        "cancel": (_Empty, lambda _b, _: commander.cancel()),
        "estop": (EStopRequest, lambda _b, _: {}),
        "release": (_Empty, lambda _b, src: {"estop": False, "released_at": gate.release(src)}),
    }


def token_matches(expected: str, presented: str | None) -> bool:
    """Constant-time token check."""
    return presented is not None and secrets.compare_digest(presented.encode(),
                                                            expected.encode())


def presented_token(headers: Any) -> str | None:
    """The token of a request: ``Authorization: Bearer`` or ``X-Navstack-Token``."""
    auth = headers.get("authorization", "")
    if auth.lower().startswith("bearer "):
        return str(auth[7:].strip())
    value = headers.get("x-navstack-token")
    return str(value) if value is not None else None


UNAUTHORIZED = ("missing or wrong token: commands need the token printed when the dashboard "
                "started (send 'Authorization: Bearer <token>', or open the printed URL "
                "with #token=...)")


def unauthorized() -> JSONResponse:
    return JSONResponse({"error": UNAUTHORIZED}, 401, headers={"WWW-Authenticate": "Bearer"})


def _problems(exc: ValidationError) -> str:
    return "; ".join(f"{'.'.join(str(p) for p in e['loc']) or 'body'}: {e['msg']}"
                     for e in exc.errors())


@dataclass
class Executor:
    """Validates and runs commands in the simulation thread; shared by HTTP, WebSocket
    and the phone routes."""

    runner: LiveRunner
    commands: dict[str, tuple[type[_Body], Handler]]
    timeouts: int = 0
    log: list[str] = field(default_factory=list)

    async def run(self, name: str, payload: Any, source: str = "web"
                  ) -> tuple[int, dict[str, Any]]:
        body_cls, fn = self.commands[name]
        try:
            body = body_cls.model_validate(payload if payload is not None else {})
        except ValidationError as exc:
            return 422, {"error": f"invalid '{name}' command: {_problems(exc)}"}
        if name == "estop":
            reason = getattr(body, "reason", "") or f"{source} e-stop"
            async def latch() -> dict[str, Any]:
                requested_at, fut = self.runner.estop_request(source, reason)
                latched_at = await self.wait(fut)
                return {"estop": True, "latched_at": latched_at, "requested_at": requested_at}

            return await self._mapped(name, latch())
        return await self.run_fn(name, lambda: fn(body, source))

    async def run_fn(self, name: str, fn: Callable[[], dict[str, Any]]
                     ) -> tuple[int, dict[str, Any]]:
        """Run ``fn()`` in the simulation thread; errors become HTTP statuses."""
        requested_at = self.runner.now

        async def call() -> dict[str, Any]:
            result = await self.wait(self.runner.submit(lambda _s: fn()))
            return {**result, "requested_at": requested_at}

        return await self._mapped(name, call())

    async def _mapped(self, name: str, work: Awaitable[dict[str, Any]]
                      ) -> tuple[int, dict[str, Any]]:
        try:
            return 200, await work
        except GoalOutOfBounds as exc:
            return 422, {"error": f"invalid '{name}' command: {exc.field}: {exc}"}
        except CommandRejected as exc:
            return 409, {"error": str(exc)}
        except RunnerError as exc:
            return 503, {"error": str(exc)}
        except TimeoutError:
            self.timeouts += 1
            return 504, {"error": f"the simulation did not run '{name}' within "
                                  f"{COMMAND_TIMEOUT:.0f} s; is it overloaded or stopped?"}
        except NavstackError as exc:
            return 409, {"error": str(exc)}

    async def wait(self, fut: Any) -> Any:
        return await asyncio.wait_for(asyncio.wrap_future(fut), COMMAND_TIMEOUT)

    def refuse_release(self, source: str) -> None:
        """Record an unauthenticated release attempt in the e-stop audit trail."""
        gate = self.runner.estop
        if self.runner.running:
            self.runner.submit(lambda _s: gate.refuse_release(source, "missing or wrong token"))


def is_authenticated_estop(token: str) -> Callable[[Scope], bool]:
    """For the rate limiter: an authenticated e-stop request is never limited."""
    def check(scope: Scope) -> bool:
        if scope.get("type") != "http" or scope.get("path") != "/api/estop":
            return False
        headers = {k.decode("latin-1"): v.decode("latin-1")
                   for k, v in scope.get("headers", ())}
        return token_matches(token, presented_token(headers))
    return check


def create_app(runner: LiveRunner, model: DashboardModel, commander: NavCommander,
               token: str, security: WebSecurityParams | None = None,
               viewers: ViewerRegistry | None = None) -> FastAPI:
    """The dashboard app for a running stack (see module docstring for the routes)."""
    params = security or WebSecurityParams()
    viewers = viewers or ViewerRegistry(params)
    app = FastAPI(title="navstack dashboard", docs_url=None, redoc_url=None,
                  openapi_url=None)
    executor = Executor(runner, _commands(commander, runner))
    app.state.executor = executor
    app.state.viewers = viewers
    page = static_dir()

    async def http_command(name: str, request: Request) -> JSONResponse:
        if not token_matches(token, presented_token(request.headers)):
            if name == "release":
                executor.refuse_release(f"web {client_address(request.scope)}")
            return unauthorized()
        try:
            payload = parse_json(await request.body(), params.max_body_bytes,
                                 params.max_json_depth)
        except BodyError as exc:
            return JSONResponse({"error": str(exc)}, exc.status)
        status, body = await executor.run(name, payload, "web")
        return JSONResponse(body, status)

    for path, method, name in (("/api/goal", "POST", "goal"),
                               ("/api/waypoints", "POST", "add_waypoint"),
                               ("/api/waypoints", "DELETE", "clear_waypoints"),
                               ("/api/waypoints/go", "POST", "go"),
                               ("/api/cancel", "POST", "cancel"),
                               ("/api/estop", "POST", "estop"),
                               ("/api/estop/release", "POST", "release")):
        async def route(request: Request, _name: str = name) -> JSONResponse:
            return await http_command(_name, request)
        app.add_api_route(path, route, methods=[method], name=f"command_{name}_{method}")

    @app.get("/api/auth")
    async def auth(request: Request) -> JSONResponse:
        if not token_matches(token, presented_token(request.headers)):
            return unauthorized()
        return JSONResponse({"ok": True})

    no_store = {"Cache-Control": "no-store"}

    @app.get("/")
    async def index() -> FileResponse:
        return FileResponse(page / "index.html", headers=no_store)

    @app.get("/api/hello")
    async def hello() -> JSONResponse:
        return JSONResponse(model.hello())

    @app.get("/api/state")
    async def state() -> Response:
        return Response(model.frame[1], media_type="application/json", headers=no_store)

    @app.get("/api/layers/{name}.png")
    async def layer_png(name: str) -> Response:
        layer = model.layers.get(name)
        if layer is None:
            known = ", ".join(LAYERS)
            return JSONResponse({"error": f"no image for layer '{name}' yet (layers: {known})"},
                                404)
        return Response(layer.png, media_type="image/png",
                        headers={**no_store, "X-Layer-Version": str(layer.version),
                                 "X-Layer-Meta": json.dumps(layer.meta())})

    @app.get("/api/plan")
    async def plan() -> JSONResponse:
        version, points = model.plan
        return JSONResponse({"version": version, "points": points})

    @app.get("/api/trail")
    async def trail(since: int = 0) -> JSONResponse:
        start, points = model.trail_since(max(since, 0))
        return JSONResponse({"start": start, "points": points})

    clock = FrameClock(model)

    @app.websocket("/ws")
    async def ws(socket: WebSocket) -> None:
        client = client_address(socket.scope)
        refusal = viewers.acquire(client)
        await socket.accept()
        if refusal:
            await socket.close(code=1013, reason=refusal[:120])
            return

        async def send(obj: dict[str, Any] | str) -> None:
            text = obj if isinstance(obj, str) else json.dumps(obj)
            async with asyncio.timeout(params.send_timeout):  # a reader that stalls is dropped
                await socket.send_text(text)

        sender: asyncio.Task[None] | None = None
        try:
            await send(model.hello())
            sender = asyncio.create_task(_push(model, clock, send, viewers, socket))
            await _receive_commands(socket, send, token, executor, params)
        except (WebSocketDisconnect, RuntimeError, TimeoutError):
            pass
        finally:
            if sender is not None:
                sender.cancel()
            viewers.release(client)

    app.mount("/static", StaticFiles(directory=page), name="static")
    return app


async def _close(socket: WebSocket, code: int, reason: str) -> None:
    with contextlib.suppress(RuntimeError):  # already closed by the peer
        await socket.close(code=code, reason=reason.encode()[:120].decode(errors="ignore"))


async def _receive_commands(socket: WebSocket, send: Callable[[Any], Awaitable[None]],
                            token: str, executor: Executor,
                            params: WebSecurityParams) -> None:
    """Read command messages until the peer leaves; malformed input gets a close frame."""
    bucket = TokenBucket(params.ws_rate, params.ws_burst)
    while True:
        message = await socket.receive()
        if message["type"] == "websocket.disconnect":
            return
        text = message.get("text")
        if text is None:
            await _close(socket, 1003, "binary frames are not accepted; send JSON text")
            return
        try:
            msg = parse_json(text, params.max_ws_message_bytes, params.max_json_depth)
        except BodyError as exc:
            await send({"type": "error", "status": exc.status,
                        "error": f"messages must be JSON: {exc}"})
            await _close(socket, 1007, f"malformed JSON: {exc}")
            return
        urgent = (isinstance(msg, dict) and msg.get("command") == "estop"
                  and token_matches(token, msg.get("token") if isinstance(
                      msg.get("token"), str) else None))
        if not urgent and bucket.take() > 0.0:
            await _close(socket, 1008, f"more than {params.ws_rate:g} messages per second")
            return
        await send(await _ws_command(msg, token, executor))


async def _ws_command(msg: Any, token: str, executor: Executor) -> dict[str, Any]:
    if not isinstance(msg, dict) or msg.get("type") != "command":
        return {"type": "error", "status": 400,
                "error": "send {'type': 'command', 'token': ..., 'command': ..., 'args': {...}}"}
    cid = msg.get("id")
    presented = msg.get("token")
    name = msg.get("command")
    if not token_matches(token, presented if isinstance(presented, str) else None):
        if name == "release":
            executor.refuse_release("web (websocket)")
        return {"type": "result", "id": cid, "status": 401, "body": {"error": UNAUTHORIZED}}
    if name not in COMMAND_NAMES:
        return {"type": "result", "id": cid, "status": 400,
                "body": {"error": f"unknown command {name!r}; known: "
                                  f"{', '.join(COMMAND_NAMES)}"}}
    status, body = await executor.run(name, msg.get("args"), "web")
    return {"type": "result", "id": cid, "status": status, "body": body}


class FrameClock:
    """One poller per server tells every viewer when the model has a new frame (instead
    of each viewer polling on its own)."""

    def __init__(self, model: DashboardModel) -> None:
        self.model = model
        self._event: asyncio.Event | None = None
        self._task: asyncio.Task[None] | None = None

    async def wait_newer(self, seq: int) -> None:
        if self._task is None or self._task.done():
            self._event = asyncio.Event()
            self._task = asyncio.create_task(self._poll())
        while self.model.frame[0] == seq:
            assert self._event is not None
            await self._event.wait()

    async def _poll(self) -> None:
        last = self.model.frame[0]
        period = self.model.frame_period / 2.0
        while True:
            await asyncio.sleep(period)
            seq = self.model.frame[0]
            if seq != last and self._event is not None:
                last = seq
                event, self._event = self._event, asyncio.Event()
                event.set()


async def _push(model: DashboardModel, clock: FrameClock, send: Callable[[Any], Any],
                viewers: ViewerRegistry, socket: WebSocket) -> None:
    """Push telemetry until the viewer leaves or stalls (then close it)."""
    try:
        await _push_frames(model, clock, send, viewers)
    except (WebSocketDisconnect, RuntimeError, TimeoutError, OSError):
        await _close(socket, 1008, "telemetry not read in time")


async def _push_frames(model: DashboardModel, clock: FrameClock, send: Callable[[Any], Any],
                       viewers: ViewerRegistry) -> None:
    """Send each new state snapshot, plus images / plan / trail points the client lacks, at
    this viewer's fair share of the telemetry budget.  Each viewer starts at a random
    phase of its period, so many viewers do not wake in one burst that a command would
    queue behind."""
    loop = asyncio.get_running_loop()
    known: dict[str, int] = {}
    plan_version = -1
    trail_index = 0
    last_seq = -1
    await asyncio.sleep(random.uniform(0.0, viewers.frame_period(model.frame_period)))
    while True:
        await clock.wait_newer(last_seq)
        started = loop.time()
        last_seq, text = model.frame
        for name, layer in list(model.layers.items()):
            if known.get(name) != layer.version:
                known[name] = layer.version
                await send({"type": "layer", **layer.meta(),
                            "png": base64.b64encode(layer.png).decode("ascii")})
        version, points = model.plan
        if version != plan_version:
            plan_version = version
            await send({"type": "plan", "version": version, "points": points})
        start, trail = model.trail_since(trail_index)
        if trail:
            trail_index = start + len(trail)
            await send({"type": "trail", "start": start, "points": [v for p in trail for v in p]})
        await send(text)
        period = viewers.frame_period(model.frame_period)
        await asyncio.sleep(max(0.0, period - (loop.time() - started)))


def listening_socket(host: str, port: int, backlog: int,
                     error: type[Exception]) -> socket.socket:
    """A non-blocking socket listening on ``host:port`` (IPv6 when ``host`` has a colon;
    port 0 picks a free one) for uvicorn; a port in use raises ``error`` naming it and
    the fix."""
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET,
                         socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise error(f"cannot listen on {host}:{port} ({exc.strerror}); choose another port "
                    f"(--port, 0 picks a free one) or stop the program using it") from None
    sock.listen(backlog)
    sock.setblocking(False)
    return sock
