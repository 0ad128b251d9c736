"""``serve_dashboard``: start the web dashboard for a stack; ``DashboardHandle`` stops it.

uvicorn runs the FastAPI app in its own thread on a socket bound here (so ``port=0``
picks a free port and a busy port is reported at once, with a fix).  The token that
guards every command is generated with :func:`secrets.token_urlsafe` unless given, and
the printed URL carries it in the fragment (``/#token=...``): fragments never reach the
server, so the token does not appear in access logs; the page keeps it in
``sessionStorage``.  Without the token the page is read-only.
"""

from __future__ import annotations

import secrets
import socket
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import uvicorn
from pydantic import Field

from navstack.core.errors import NavstackError
from navstack.core.params import Params
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack
from navstack.interfaces.web.commands import NavCommander
from navstack.interfaces.web.model import DashboardModel
from navstack.interfaces.web.server import create_app


class DashboardError(NavstackError):
    """The dashboard could not start (port busy, bad host, server failed)."""


class DashboardParams(Params):
    """Dashboard settings.  ``port`` 0 picks a free port; ``token`` ``None`` generates
    one; ``frame_rate`` is the state push rate [Hz] (>= 10 for a live view)."""

    host: str = "127.0.0.1"
    port: int = Field(8080, ge=0, le=65535)
    token: str | None = Field(None, min_length=8)
    frame_rate: float = Field(20.0, ge=10.0, le=60.0)
    ssl_certfile: str | None = None
    ssl_keyfile: str | None = None


@dataclass
class DashboardHandle:
    """A running dashboard: its address, token, and :meth:`stop`."""

    host: str
    port: int
    token: str
    runner: LiveRunner
    model: DashboardModel
    commander: NavCommander
    _server: uvicorn.Server = field(repr=False)
    _thread: threading.Thread = field(repr=False)
    _owns_runner: bool = field(default=False, repr=False)
    scheme: str = "http"

    @property
    def url(self) -> str:
        """Read-only address of the page."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "") else self.host
        return f"{self.scheme}://{host}:{self.port}/"

    @property
    def control_url(self) -> str:
        """Address with the token: opening it enables the commands."""
        return f"{self.url}#token={self.token}"

    def banner(self) -> str:
        return (f"navstack dashboard: {self.control_url}\n"
                f"  read-only view: {self.url}   (commands need the token: {self.token})")

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the server (and the runner when this call created it)."""
        self._server.should_exit = True
        self._thread.join(timeout)
        self.model.detach()
        if self._owns_runner:
            self.runner.stop(timeout)


def _bind(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise DashboardError(f"cannot listen on {host}:{port} ({exc.strerror}); choose "
                             f"another port (--port, 0 picks a free one) or stop the program "
                             f"using it") from None
    sock.listen(64)
    sock.setblocking(False)
    return sock


def serve_dashboard(target: NavStack | LiveRunner, host: str = "127.0.0.1", port: int = 8080,
                    token: str | None = None, *, real_time_factor: float | None = 1.0,
                    frame_rate: float = 20.0, ssl_certfile: str | None = None,
                    ssl_keyfile: str | None = None,
                    announce: Callable[[str], None] | None = None) -> DashboardHandle:
    """Serve the dashboard for ``target`` and return once it accepts connections.

    Given a :class:`NavStack`, a :class:`LiveRunner` at ``real_time_factor`` is created,
    started, and stopped again by :meth:`DashboardHandle.stop`.  Given a runner (to share
    it with Foxglove or other clients) it is used as is; start it yourself.  ``announce``
    receives the banner with the URLs and token (default: printed to stdout).  With
    ``ssl_certfile``/``ssl_keyfile`` (PEM) the page is served over HTTPS/WSS, which is
    what keeps the token private when the dashboard listens beyond loopback.
    """
    p = DashboardParams.from_mapping({"host": host, "port": port, "token": token,
                                      "frame_rate": frame_rate, "ssl_certfile": ssl_certfile,
                                      "ssl_keyfile": ssl_keyfile}, key_path="dashboard")
    owns = isinstance(target, NavStack)
    runner = LiveRunner(target, real_time_factor=real_time_factor) if isinstance(
        target, NavStack) else target
    secret = p.token or secrets.token_urlsafe(24)
    commander = runner.call(NavCommander)
    model = DashboardModel(runner, commander, p.frame_rate)
    model.attach()
    try:
        sock = _bind(p.host, p.port)
    except DashboardError:
        model.detach()
        raise
    app = create_app(runner, model, commander, secret)
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", access_log=False,
                                           lifespan="off", ws_ping_interval=None,
                                           ssl_certfile=p.ssl_certfile,
                                           ssl_keyfile=p.ssl_keyfile))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]},
                              name="navstack-dashboard", daemon=True)
    thread.start()
    deadline = time.monotonic() + 10.0
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            model.detach()
            raise DashboardError(f"the dashboard server on {p.host}:{p.port} did not start; "
                                 f"see the log above")
        time.sleep(0.01)
    handle = DashboardHandle(p.host, sock.getsockname()[1], secret, runner, model, commander,
                             server, thread, owns,
                             "https" if p.ssl_certfile else "http")
    if owns:
        runner.start()
    (announce or (lambda s: print(s, file=sys.stdout, flush=True)))(handle.banner())
    return handle
