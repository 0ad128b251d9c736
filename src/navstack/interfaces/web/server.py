"""The dashboard's HTTP/WebSocket server: a FastAPI app served by uvicorn in a thread.

Read-only routes (no token): ``GET /`` (the page), ``/static/*``, ``/api/hello``,
``/api/state`` (latest snapshot), ``/api/layers/{map,global_costmap,local_costmap}.png``,
``/api/plan``, ``/api/trail?since=N`` and the WebSocket ``/ws``, which pushes the state at
``frame_rate`` (>= 10 Hz) plus images, plan and trajectory points when they change.

Command routes need the token (``Authorization: Bearer <token>`` or ``X-Navstack-Token``)
and answer HTTP 401 without it: ``POST /api/goal``, ``POST /api/waypoints``,
``DELETE /api/waypoints``, ``POST /api/waypoints/go``, ``POST /api/cancel``,
``POST /api/estop``, ``POST /api/estop/release`` (and ``GET /api/auth`` to check a token).
WebSocket ``{"type": "command", "token": ..., "command": ..., "args": {...}}`` messages are
checked the same way and refused with ``status`` 401.  Every command is executed in the
simulation thread (:meth:`LiveRunner.submit`); the HTTP handler awaits its result, so a
reply means the command has taken effect (the e-stop reply carries the simulated time at
which the base was commanded to zero, ``requested_at`` the simulated time at which the
request was queued: they differ by at most one step, one control cycle).
"""

from __future__ import annotations

import asyncio
import base64
import json
import secrets
from collections.abc import Callable
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
from navstack.interfaces.web.commands import CommandRejected, GoMode, NavCommander
from navstack.interfaces.web.model import LAYERS, DashboardModel

COMMAND_TIMEOUT = 10.0
"""Wall seconds a command may wait for the simulation thread."""
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
MAX_BODY_BYTES = 64 * 1024
"""Largest command body accepted (a waypoint list of MAX_WAYPOINTS poses is ~10 KB)."""


def static_dir() -> Path:
    return Path(str(resources.files("navstack.interfaces.web") / "static"))


class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid")


class PoseRequest(_Body):
    """A goal or waypoint in ``map``; ``theta`` omitted: face along the direction of travel."""

    x: Coordinate
    y: Coordinate
    theta: FiniteFloat | None = None


class GoRequest(_Body):
    mode: GoMode = "follow_waypoints"


class EStopRequest(_Body):
    reason: str = Field("", max_length=200)


class _Empty(_Body):
    pass


def _commands(commander: NavCommander, runner: LiveRunner
              ) -> dict[str, tuple[type[_Body], Callable[[Any], dict[str, Any]]]]:
    """Command name -> (body model, function run in the simulation thread)."""
    gate = runner.estop

    def estop(b: EStopRequest) -> dict[str, Any]:
        t = gate.latch(b.reason or "dashboard e-stop")
        return {"estop": True, "latched_at": t}

    def release(_: _Empty) -> dict[str, Any]:
        return {"estop": False, "released_at": gate.release()}

    return {
        "goal": (PoseRequest, lambda b: commander.go_to(b.x, b.y, b.theta)),
        "add_waypoint": (PoseRequest, lambda b: commander.add_waypoint(b.x, b.y, b.theta)),
        "clear_waypoints": (_Empty, lambda _: commander.clear_waypoints()),
        "go": (GoRequest, lambda b: commander.go(b.mode)),
        "cancel": (_Empty, lambda _: commander.cancel()),
        "estop": (EStopRequest, estop),
        "release": (_Empty, release),
    }


def token_matches(expected: str, presented: str | None) -> bool:
    """Constant-time token check."""
    return presented is not None and secrets.compare_digest(presented.encode(),
                                                            expected.encode())


def _presented(request: Request) -> str | None:
    auth = request.headers.get("authorization", "")
    if auth.lower().startswith("bearer "):
        return auth[7:].strip()
    return request.headers.get("x-navstack-token")


UNAUTHORIZED = ("missing or wrong token: commands need the token printed when the dashboard "
                "started (send 'Authorization: Bearer <token>', or open the printed URL "
                "with #token=...)")


def create_app(runner: LiveRunner, model: DashboardModel, commander: NavCommander,
               token: str) -> FastAPI:
    """The dashboard app for a running stack (see module docstring for the routes)."""
    app = FastAPI(title="navstack dashboard", docs_url=None, redoc_url=None,
                  openapi_url=None)
    commands = _commands(commander, runner)
    page = static_dir()

    async def execute(name: str, payload: Any) -> tuple[int, dict[str, Any]]:
        body_cls, fn = commands[name]
        try:
            body = body_cls.model_validate(payload if payload is not None else {})
        except ValidationError as exc:
            problems = "; ".join(f"{'.'.join(str(p) for p in e['loc']) or 'body'}: {e['msg']}"
                                 for e in exc.errors())
            return 422, {"error": f"invalid '{name}' command: {problems}"}
        try:
            requested_at = runner.now
            fut = runner.submit(lambda _stack: fn(body))
            result = await asyncio.wait_for(asyncio.wrap_future(fut), COMMAND_TIMEOUT)
            return 200, {**result, "requested_at": requested_at}
        except CommandRejected as exc:
            return 409, {"error": str(exc)}
        except RunnerError as exc:
            return 503, {"error": str(exc)}
        except TimeoutError:
            return 504, {"error": f"the simulation did not run '{name}' within "
                                  f"{COMMAND_TIMEOUT:.0f} s; is it overloaded or stopped?"}
        except NavstackError as exc:
            return 409, {"error": str(exc)}

    async def http_command(name: str, request: Request) -> JSONResponse:
        if not token_matches(token, _presented(request)):
            return JSONResponse({"error": UNAUTHORIZED}, 401,
                                headers={"WWW-Authenticate": "Bearer"})
        raw = await request.body()
        if len(raw) > MAX_BODY_BYTES:
            return JSONResponse({"error": f"body of {len(raw)} bytes is larger than "
                                          f"{MAX_BODY_BYTES} bytes"}, 413)
        try:
            payload = json.loads(raw) if raw.strip() else None
        except json.JSONDecodeError as exc:
            return JSONResponse({"error": f"body is not JSON: {exc}"}, 422)
        except RecursionError:
            return JSONResponse({"error": "body is not JSON: nested too deeply"}, 422)
        status, body = await execute(name, payload)
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
        if not token_matches(token, _presented(request)):
            return JSONResponse({"error": UNAUTHORIZED}, 401,
                                headers={"WWW-Authenticate": "Bearer"})
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

    @app.websocket("/ws")
    async def ws(socket: WebSocket) -> None:
        await socket.accept()
        lock = asyncio.Lock()

        async def send(obj: dict[str, Any] | str) -> None:
            async with lock:
                await socket.send_text(obj if isinstance(obj, str) else json.dumps(obj))

        await send(model.hello())
        sender = asyncio.create_task(_push(model, send))
        try:
            while True:
                msg = await socket.receive_json()
                await send(await _ws_command(msg, token, execute))
        except (WebSocketDisconnect, RuntimeError):
            pass
        except json.JSONDecodeError:
            await send({"type": "error", "status": 400, "error": "messages must be JSON"})
        finally:
            sender.cancel()

    app.mount("/static", StaticFiles(directory=page), name="static")
    return app


async def _ws_command(msg: Any, token: str,
                      execute: Callable[[str, Any], Any]) -> dict[str, Any]:
    if not isinstance(msg, dict) or msg.get("type") != "command":
        return {"type": "error", "status": 400,
                "error": "send {'type': 'command', 'token': ..., 'command': ..., 'args': {...}}"}
    cid = msg.get("id")
    presented = msg.get("token")
    if not token_matches(token, presented if isinstance(presented, str) else None):
        return {"type": "result", "id": cid, "status": 401, "body": {"error": UNAUTHORIZED}}
    name = msg.get("command")
    if name not in ("goal", "add_waypoint", "clear_waypoints", "go", "cancel", "estop",
                    "release"):
        return {"type": "result", "id": cid, "status": 400,
                "body": {"error": f"unknown command {name!r}; known: goal, add_waypoint, "
                                  "clear_waypoints, go, cancel, estop, release"}}
    status, body = await execute(name, msg.get("args"))
    return {"type": "result", "id": cid, "status": status, "body": body}


async def _push(model: DashboardModel, send: Callable[[Any], Any]) -> None:
    """Send each new state snapshot, plus images / plan / trail points the client lacks."""
    known: dict[str, int] = {}
    plan_version = -1
    trail_index = 0
    last_seq = -1
    period = model.frame_period / 2.0
    while True:
        seq, text = model.frame
        if seq != last_seq:
            last_seq = seq
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
                await send({"type": "trail", "start": start,
                            "points": [v for p in trail for v in p]})
            await send(text)
        await asyncio.sleep(period)
