"""The dashboard's fleet view: every robot of a fleet on one map, read-only.

One page for the base station (``navstack fleet --dashboard``): the shared map, and per
robot (one colour each) its pose, its current global plan (``/<robot>/plan``), the trail
it drove, its current goal and distance remaining, goals done and collisions; the fleet's
closest robot-robot approach.  The snapshot is built in the simulation thread after each
mission step (:meth:`FleetView.update`) and swapped in as one reference; the server
thread only reads snapshots, never the stacks.

Routes: ``/`` (the page, ``static/fleet.html``), ``/api/fleet`` (the snapshot as JSON),
``/api/fleet/map.png`` (the map, north up; its placement is in the snapshot).  View only:
no commands, so no token; it listens on loopback unless told otherwise.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
import uvicorn
from fastapi import FastAPI
from fastapi.responses import FileResponse, JSONResponse, Response

from navstack.core.errors import NavstackError
from navstack.core.msgs import Path
from navstack.interfaces.fleet_mission import FleetMission
from navstack.interfaces.web.images import grid_png
from navstack.interfaces.web.server import listening_socket, static_dir
from navstack.runtime.bus import QoS

TRAIL_POINTS = 600
"""Most recent trail points per robot in a snapshot."""
PATH_POINTS = 300
"""A plan is thinned to at most this many points in a snapshot."""


class FleetViewError(NavstackError):
    """The fleet view cannot be served (address in use, server did not start)."""


class FleetView:
    """Snapshots of a running :class:`FleetMission` for the fleet page."""

    def __init__(self, mission: FleetMission) -> None:
        self.mission = mission
        fleet = mission.fleet
        grid = fleet.world.to_occupancy_grid()
        info = grid.info
        self.map_png = grid_png(grid, "map")
        self.map_meta = {"width": info.width, "height": info.height,
                         "resolution": info.resolution,
                         "origin": [info.origin.position.x, info.origin.position.y]}
        self._plans: dict[str, list[list[float]]] = {n: [] for n in fleet.names}
        for name in fleet.names:
            fleet.runtime(name).bus.subscribe("/plan", Path, partial(self._plan, name),
                                              QoS(depth=1))
        self.snapshot: dict[str, Any] = {}
        self.version = 0
        self.update()

    def _plan(self, name: str, path: Path) -> None:
        xy = path.as_array()[:, :2]
        step = max(1, len(xy) // PATH_POINTS)
        pts = xy[::step]
        if len(xy) and (len(pts) == 0 or not np.array_equal(pts[-1], xy[-1])):
            pts = np.vstack([pts, xy[-1:]])
        self._plans[name] = np.round(pts, 3).tolist()

    def update(self) -> None:
        """Build a new snapshot (call from the simulation thread)."""
        m = self.mission
        fleet = m.fleet
        status = m.status()
        robots = []
        for i, (name, run) in enumerate(m.runs.items()):
            sim = fleet.physics.sim(name)
            p = sim.pose
            robots.append({
                "name": name, "colour": i,
                "pose": [round(p.x, 3), round(p.y, 3), round(p.theta, 4)],
                "radius": sim.footprint.circumscribed_radius,
                "path": self._plans[name],
                "trail": [[round(x, 2), round(y, 2)] for x, y, _ in run.trail[-TRAIL_POINTS:]],
                "goals": [{"name": g.name, "x": g.pose[0], "y": g.pose[1],
                           "status": o.status} for g, o in zip(run.spec.route, run.goals,
                                                                strict=True)],
                **status[name],
                "collisions": sim.collisions, "robot_collisions": sim.robot_collisions})
        self.version += 1
        self.snapshot = {"version": self.version, "fleet": fleet.params.name,
                         "world": fleet.params.world, "time": round(fleet.now, 2),
                         "done": m.done, "map": self.map_meta,
                         "min_robot_distance_m": round(fleet.physics.min_separation, 3),
                         "robots": robots}


def fleet_app(view: FleetView) -> FastAPI:
    app = FastAPI(title="navstack fleet", docs_url=None, redoc_url=None, openapi_url=None)

    @app.get("/")
    async def index() -> FileResponse:
        return FileResponse(static_dir() / "fleet.html")

    @app.get("/api/fleet")
    async def snapshot() -> JSONResponse:
        return JSONResponse(view.snapshot, headers={"Cache-Control": "no-store"})

    @app.get("/api/fleet/map.png")
    async def map_png() -> Response:
        return Response(view.map_png, media_type="image/png")

    return app


@dataclass
class FleetViewHandle:
    host: str
    port: int
    _server: uvicorn.Server = field(repr=False)
    _thread: threading.Thread = field(repr=False)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def stop(self, timeout: float = 5.0) -> None:
        self._server.should_exit = True
        self._thread.join(timeout)


def serve_fleet_view(view: FleetView, host: str = "127.0.0.1", port: int = 8080
                     ) -> FleetViewHandle:
    """Serve the fleet page in a thread; returns once it accepts connections (``port``
    0 picks a free one)."""
    sock = listening_socket(host, port, 64, FleetViewError)
    server = uvicorn.Server(uvicorn.Config(fleet_app(view), log_level="warning",
                                           access_log=False, lifespan="off", loop="asyncio"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]},
                              name="navstack-fleet-view", daemon=True)
    thread.start()
    deadline = time.monotonic() + 10.0
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            raise FleetViewError(f"the fleet view on {host}:{port} did not start")
        time.sleep(0.01)
    return FleetViewHandle(host, sock.getsockname()[1], server, thread)
