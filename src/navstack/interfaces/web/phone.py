"""The golf cart's phone interface on the dashboard server, behind the dashboard's token.

The original (FIELD-ROBOTS.md) had a phone app post ``POST /location`` with JSON
lat/lon/alt (published as a ``sensor_msgs/NavSatFix``), ``GET /get_location``, and a
message "Stop" for the emergency stop -- with no authentication, through a public
tunnel.  Here every route needs the token (401 otherwise):

* ``POST /api/phone/location`` (alias ``/location``), body ``{lat, lon, alt?, accuracy?,
  altitude_accuracy?}``: a NavSatFix of the phone on ``/fix``;
* ``GET /api/phone/location`` (alias ``/get_location``): the last location and its age;
* ``POST /api/phone/message`` (alias ``/message``), body ``{text}``: "Stop" latches the
  e-stop (authority ``phone``);
* ``POST /api/phone/come``: NavigateToPose to the phone's last position;
* ``POST /api/phone/release``: releases an e-stop the phone latched.

``GET /phone`` serves a page that sends the browser's Geolocation position (the W3C
Geolocation API's ``watchPosition``) and offers "come to me", STOP and Release.

The fix: latitude/longitude/altitude as given (WGS84; browsers report the altitude above
the ellipsoid where they know it), ``header.frame_id`` ``phone``, status FIX.  The
Geolocation API's ``accuracy`` is the radius of 95 % confidence [m], so the horizontal
standard deviation is ``accuracy / 2.4477`` (the 95 % radius of a circular 2-D normal);
without ``accuracy`` the covariance type is UNKNOWN (navsat_transform then refuses the fix,
as it should).  "Come to me" converts the last position to the map frame through the
navsat transform (:class:`~navstack.interfaces.geo_frame.GeoFrame`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np
from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse
from pydantic import AliasChoices, Field, ValidationError

from navstack.core.msgs import Header, NavSatFix, NavSatStatus
from navstack.interfaces.geo_frame import GeoFrame
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.web.commands import CommandRejected, NavCommander
from navstack.interfaces.web.guard import BodyError, WebSecurityParams, client_address, parse_json
from navstack.interfaces.web.server import (
    Executor,
    _Body,
    _problems,
    presented_token,
    static_dir,
    token_matches,
    unauthorized,
)
from navstack.runtime.bus import QoS

__all__ = ["PHONE_AUTHORITY", "PhoneBridge", "register_phone_routes"]

PHONE_AUTHORITY = "phone"
CONFIDENCE_95_2D = 2.4477
"""Radius of the 95 % region of a circular 2-D normal, in standard deviations."""
Finite = Annotated[float, Field(allow_inf_nan=False)]


class LocationRequest(_Body):
    """A phone position (WGS84 degrees, metres); ``lat``/``lon``/``alt`` as the golf
    cart's app sent them, or the full names."""

    lat: Annotated[float, Field(ge=-90.0, le=90.0, allow_inf_nan=False,
                                validation_alias=AliasChoices("lat", "latitude"))]
    lon: Annotated[float, Field(ge=-180.0, le=180.0, allow_inf_nan=False,
                                validation_alias=AliasChoices("lon", "longitude"))]
    alt: Annotated[float, Field(ge=-1.0e4, le=1.0e5, allow_inf_nan=False,
                                validation_alias=AliasChoices("alt", "altitude"))] = 0.0
    accuracy: Annotated[float, Field(gt=0.0, le=1.0e5, allow_inf_nan=False)] | None = None
    altitude_accuracy: Annotated[float, Field(gt=0.0, le=1.0e5,
                                              allow_inf_nan=False)] | None = None


class MessageRequest(_Body):
    text: str = Field(max_length=200)


@dataclass(frozen=True)
class PhoneLocation:
    lat: float
    lon: float
    alt: float
    accuracy: float | None
    stamp: float
    """Simulated time it was published [s]."""
    received: float
    """Wall time it arrived (``time.time()``)."""


class PhoneBridge:
    """Publishes the phone's fixes and drives its goals; simulation thread only."""

    def __init__(self, runner: LiveRunner, commander: NavCommander,
                 fix_topic: str = "/fix") -> None:
        self.runner = runner
        self.commander = commander
        self.fix_topic = fix_topic
        self._pub = runner.stack.runtime.bus.publisher(fix_topic, NavSatFix, QoS(depth=10))
        self.location: PhoneLocation | None = None
        self.published = 0
        self._geo: GeoFrame | None = None

    def geo(self) -> GeoFrame:
        if self._geo is None or not self._geo.transform.transform_good:
            self._geo = GeoFrame.for_stack(self.runner.stack)
        return self._geo

    def publish(self, req: LocationRequest) -> dict[str, Any]:
        now = self.runner.stack.now
        cov = np.zeros((3, 3))
        kind = NavSatFix.COVARIANCE_TYPE_UNKNOWN
        if req.accuracy is not None:
            var_h = (req.accuracy / CONFIDENCE_95_2D) ** 2
            alt_acc = req.altitude_accuracy if req.altitude_accuracy is not None else (
                2.0 * req.accuracy)
            cov = np.diag([var_h, var_h, (alt_acc / 1.96) ** 2])
            kind = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
        fix = NavSatFix(Header(now, "phone"), NavSatStatus(NavSatStatus.STATUS_FIX),
                        req.lat, req.lon, req.alt, cov, kind)
        self._pub.publish(fix)
        self.published += 1
        self.location = PhoneLocation(req.lat, req.lon, req.alt, req.accuracy, now,
                                      time.time())
        return {"published": self.fix_topic, "stamp": now}

    def come_to_me(self) -> dict[str, Any]:
        """NavigateToPose to the phone's last position (heading along robot -> phone)."""
        loc = self.location
        if loc is None:
            raise CommandRejected("no phone location yet: share the location first")
        x, y = self.geo().to_map(loc.lat, loc.lon, loc.alt)
        out = self.commander.go_to(x, y, None)
        return {**out, "target": [x, y], "from": [loc.lat, loc.lon]}

    def state(self) -> dict[str, Any]:
        loc = self.location
        if loc is None:
            return {"location": None}
        return {"location": {"lat": loc.lat, "lon": loc.lon, "alt": loc.alt,
                             "accuracy": loc.accuracy, "stamp": loc.stamp,
                             "age_s": round(time.time() - loc.received, 3)},
                "published": self.published, "topic": self.fix_topic}


def register_phone_routes(app: FastAPI, bridge: PhoneBridge, executor: Executor, token: str,
                          params: WebSecurityParams) -> None:
    """Add the phone routes (module docstring) to the dashboard app."""
    runner = bridge.runner
    gate = runner.estop

    async def body_of(request: Request, model: type[_Body]) -> _Body | JSONResponse:
        try:
            payload = parse_json(await request.body(), params.max_body_bytes,
                                 params.max_json_depth)
            return model.model_validate(payload if payload is not None else {})
        except BodyError as exc:
            return JSONResponse({"error": str(exc)}, exc.status)
        except ValidationError as exc:
            return JSONResponse({"error": f"invalid {model.__name__}: {_problems(exc)}"}, 422)

    def authorized(request: Request) -> bool:
        return token_matches(token, presented_token(request.headers))

    async def location_post(request: Request) -> JSONResponse:
        if not authorized(request):
            return unauthorized()
        body = await body_of(request, LocationRequest)
        if isinstance(body, JSONResponse):
            return body
        assert isinstance(body, LocationRequest)
        return JSONResponse(await executor.wait(runner.submit(lambda _s: bridge.publish(body))))

    async def location_get(request: Request) -> JSONResponse:
        if not authorized(request):
            return unauthorized()
        st = bridge.state()
        if st["location"] is None:
            return JSONResponse({"error": "no phone location yet"}, 404)
        return JSONResponse(st)

    async def message(request: Request) -> JSONResponse:
        if not authorized(request):
            return unauthorized()
        body = await body_of(request, MessageRequest)
        if isinstance(body, JSONResponse):
            return body
        assert isinstance(body, MessageRequest)
        text = body.text.strip()
        if text.lower() != "stop":
            return JSONResponse({"error": f"unknown message {text!r}: send 'Stop' for the "
                                          "emergency stop"}, 422)
        status, out = await executor.run("estop", {"reason": "phone message 'Stop'"},
                                         PHONE_AUTHORITY)
        return JSONResponse(out, status)

    async def come(request: Request) -> JSONResponse:
        if not authorized(request):
            return unauthorized()
        status, out = await executor.run_fn("come", lambda: bridge.come_to_me())
        return JSONResponse(out, status)

    async def release(request: Request) -> JSONResponse:
        if not authorized(request):
            executor.refuse_release(f"phone {client_address(request.scope)}")
            return unauthorized()
        status, out = await executor.run_fn(
            "release", lambda: {"estop": False, "released_at": gate.release(PHONE_AUTHORITY)})
        return JSONResponse(out, status)

    for paths, method, fn in ((("/api/phone/location", "/location"), "POST", location_post),
                              (("/api/phone/location", "/get_location"), "GET", location_get),
                              (("/api/phone/message", "/message"), "POST", message),
                              (("/api/phone/come",), "POST", come),
                              (("/api/phone/release",), "POST", release)):
        for path in paths:
            app.add_api_route(path, fn, methods=[method], name=f"phone_{path}_{method}")

    no_store = {"Cache-Control": "no-store"}

    @app.get("/phone")
    async def phone_page() -> FileResponse:
        return FileResponse(static_dir() / "phone.html", headers=no_store)
