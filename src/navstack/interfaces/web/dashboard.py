"""``serve_dashboard``: start the web dashboard for a stack; ``DashboardHandle`` stops it.

uvicorn runs the FastAPI app in its own thread on a socket bound here (so ``port=0``
picks a free port and a busy port is reported at once, with a fix).  The token that
guards every command is given (Python), read from ``$NAVSTACK_DASHBOARD_TOKEN`` or a
file, or generated with :func:`secrets.token_urlsafe`; the printed URL carries it in the
fragment (``/#token=...``): fragments never reach the server, so the token does not
appear in access logs; the page keeps it in ``sessionStorage``.  Without the token the
page is read-only.  Listening on all interfaces prints the LAN address(es) and, without
TLS, a warning.
"""

from __future__ import annotations

import secrets
import socket
import sys
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import uvicorn
from pydantic import Field

from navstack.core.errors import NavstackError
from navstack.core.params import Params
from navstack.interfaces.credentials import read_secret
from navstack.interfaces.live_runner import LiveRunner
from navstack.interfaces.stack import NavStack
from navstack.interfaces.web.commands import NavCommander
from navstack.interfaces.web.guard import (
    WILDCARD_HOSTS,
    GuardMiddleware,
    HostOriginPolicy,
    ViewerRegistry,
    WebSecurityParams,
    lan_addresses,
)
from navstack.interfaces.web.model import DashboardModel
from navstack.interfaces.web.phone import PhoneBridge, register_phone_routes
from navstack.interfaces.web.server import (
    create_app,
    is_authenticated_estop,
    listening_socket,
)
from navstack.interfaces.web.transport import ReadStats, guarded_protocols

TOKEN_ENV = "NAVSTACK_DASHBOARD_TOKEN"
"""Environment variable read for the command token when none is given."""


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
    token_file: str | None = None
    phone_fix_topic: str = "/fix"
    security: WebSecurityParams = Field(default_factory=WebSecurityParams)


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
    viewers: ViewerRegistry | None = None
    phone: PhoneBridge | None = None
    read_stats: ReadStats | None = None
    guard: GuardMiddleware | None = None

    @property
    def url(self) -> str:
        """Read-only address of the page on this machine."""
        host = "127.0.0.1" if self.host in WILDCARD_HOSTS else self.host
        if ":" in host:
            host = f"[{host}]"
        return f"{self.scheme}://{host}:{self.port}/"

    @property
    def lan_urls(self) -> list[str]:
        """Addresses other machines on the network use (listening on all interfaces)."""
        if self.host not in WILDCARD_HOSTS:
            return []
        return [f"{self.scheme}://{a}:{self.port}/" for a in lan_addresses()]

    @property
    def control_url(self) -> str:
        """Address with the token: opening it enables the commands."""
        return f"{self.url}#token={self.token}"

    def banner(self) -> str:
        lines = [f"navstack dashboard: {self.control_url}",
                 f"  read-only view: {self.url}   (commands need the token: {self.token})",
                 f"  phone page: {self.url}phone#token={self.token}"]
        for url in self.lan_urls:
            lines.append(f"  on the network: {url}#token={self.token}")
        if self.host in WILDCARD_HOSTS and not self.lan_urls:
            lines.append("  on the network: no LAN address found; use this machine's address")
        if self.host not in ("127.0.0.1", "localhost", "::1") and self.scheme == "http":
            lines.append("  WARNING: plain HTTP beyond loopback: anyone on the network can read "
                         "the token and the telemetry; give --tls-cert/--tls-key (PEM) or "
                         "listen on 127.0.0.1")
        return "\n".join(lines)

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the server (and the runner when this call created it)."""
        self._server.should_exit = True
        self._thread.join(timeout)
        self.model.detach()
        if self._owns_runner:
            self.runner.stop(timeout)


def _bind(host: str, port: int) -> socket.socket:
    return listening_socket(host, port, 512, DashboardError)


def serve_dashboard(target: NavStack | LiveRunner, host: str = "127.0.0.1", port: int = 8080,
                    token: str | None = None, *, real_time_factor: float | None = 1.0,
                    frame_rate: float = 20.0, ssl_certfile: str | None = None,
                    ssl_keyfile: str | None = None, token_file: str | None = None,
                    security: WebSecurityParams | Mapping[str, Any] | None = None,
                    announce: Callable[[str], None] | None = None) -> DashboardHandle:
    """Serve the dashboard for ``target`` and return once it accepts connections.

    Given a :class:`NavStack`, a :class:`LiveRunner` at ``real_time_factor`` is created,
    started, and stopped again by :meth:`DashboardHandle.stop`.  Given a runner (to share
    it with Foxglove or other clients) it is used as is; start it yourself.  ``announce``
    receives the banner with the URLs and token (default: printed to stdout).  With
    ``ssl_certfile``/``ssl_keyfile`` (PEM) the page is served over HTTPS/WSS, which is
    what keeps the token private when the dashboard listens beyond loopback.  The token:
    ``token``, else the first line of ``token_file``, else ``$NAVSTACK_DASHBOARD_TOKEN``,
    else a new random one.  ``security`` sets the server's limits
    (:class:`~navstack.interfaces.web.guard.WebSecurityParams`).
    """
    if (ssl_certfile is None) != (ssl_keyfile is None):
        raise DashboardError("TLS needs both a certificate and its key (--tls-cert and "
                             "--tls-key, PEM files)")
    sec = security.model_dump() if isinstance(security, WebSecurityParams) else (security or {})
    p = DashboardParams.from_mapping({"host": host, "port": port, "token": token,
                                      "frame_rate": frame_rate, "ssl_certfile": ssl_certfile,
                                      "ssl_keyfile": ssl_keyfile, "token_file": token_file,
                                      "security": sec}, key_path="dashboard")
    owns = isinstance(target, NavStack)
    runner = LiveRunner(target, real_time_factor=real_time_factor) if isinstance(
        target, NavStack) else target
    secret = (read_secret("dashboard token", value=p.token, file=p.token_file, env=TOKEN_ENV)
              or secrets.token_urlsafe(24))
    if len(secret) < 8:
        raise DashboardError("the dashboard token must have at least 8 characters")
    commander = runner.call(NavCommander)
    model = DashboardModel(runner, commander, p.frame_rate)
    model.attach()
    try:
        sock = _bind(p.host, p.port)
    except DashboardError:
        model.detach()
        raise
    scheme = "https" if p.ssl_certfile else "http"
    viewers = ViewerRegistry(p.security)
    app = create_app(runner, model, commander, secret, p.security, viewers)
    phone = runner.call(lambda _s: PhoneBridge(runner, commander, p.phone_fix_topic))
    register_phone_routes(app, phone, app.state.executor, secret, p.security)
    guard = GuardMiddleware(app, HostOriginPolicy(p.host, sock.getsockname()[1], scheme,
                                                  p.security),
                            p.security, is_authenticated_estop(secret))
    stats = ReadStats()
    http_cls, ws_cls = guarded_protocols(stats, p.security.read_chunk_bytes)
    try:
        config = uvicorn.Config(guard, log_level="warning", access_log=False, lifespan="off",
                                ws_ping_interval=None, loop="asyncio", http=http_cls,
                                ws=ws_cls, ws_max_size=p.security.max_ws_message_bytes,
                                ssl_certfile=p.ssl_certfile, ssl_keyfile=p.ssl_keyfile)
        server = uvicorn.Server(config)
        config.load()  # reads the TLS files now: a bad path is reported here
    except (OSError, ValueError) as exc:
        sock.close()
        model.detach()
        raise DashboardError(f"cannot use the TLS certificate/key ({p.ssl_certfile}, "
                             f"{p.ssl_keyfile}): {exc}; give PEM files") from None
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
                             server, thread, owns, scheme, viewers, phone, stats, guard)
    if owns:
        runner.start()
    (announce or (lambda s: print(s, file=sys.stdout, flush=True)))(handle.banner())
    return handle
