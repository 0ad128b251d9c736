"""Protections of the dashboard server: host/origin allow-list, rate limits, viewer caps,
bounded request bodies and JSON.

Each answers a finding of a probe against the first dashboard (issue 18, part 7):

* **Host / Origin allow-list** (:class:`GuardMiddleware`): a request whose ``Host`` is not
  one of the server's own names gets 403 (DNS rebinding: a foreign site resolving its
  name to the robot); a request or WebSocket handshake carrying an ``Origin`` other than
  the server's own gets 403 (a foreign page reading the telemetry over WebSocket, which
  browsers do not restrict by CORS, or posting commands).  Requests without ``Origin``
  (curl, scripts, phones' HTTP clients) are not browsers acting for another site and pass.
* **Per-client rate limits**: a token bucket per client address for HTTP requests (429
  with ``Retry-After``; an authenticated e-stop is never limited) and one per WebSocket
  connection for incoming messages (close 1008).
* **Viewer caps** (:class:`ViewerRegistry`): at most ``max_viewers`` WebSocket viewers,
  ``max_viewers_per_client`` per address; others get close code 1013 (try again later).
* **Telemetry fair share** (:meth:`ViewerRegistry.frame_period`): viewers together get at
  most ``telemetry_budget`` messages per second, so many viewers lower each one's frame
  rate instead of starving the event loop that also serves commands.
* **Bodies**: at most ``max_body_bytes`` (413) and ``max_json_depth`` levels of nesting
  (422) -- a deeply nested body used to end in a RecursionError and HTTP 500.

Frame-size limits on WebSockets are enforced below the application, in
:mod:`navstack.interfaces.web.transport`.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import math
import re
import socket
import time
from collections.abc import Awaitable, Callable, MutableMapping
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

from pydantic import Field

from navstack.core.params import Params

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

WILDCARD_HOSTS = ("0.0.0.0", "::", "")
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")


class WebSecurityParams(Params):
    """Limits of the dashboard server (no Nav2 counterpart).

    ``allowed_hosts``/``allowed_origins`` add names the server answers to beyond its own
    (a DNS name, a reverse proxy); the defaults cover loopback, the bound address and,
    on ``0.0.0.0``, the machine's LAN addresses and host name."""

    allowed_hosts: tuple[str, ...] = ()
    allowed_origins: tuple[str, ...] = ()
    max_viewers: int = Field(100, ge=1, le=10000)
    max_viewers_per_client: int = Field(16, ge=1, le=10000)
    http_rate: float = Field(50.0, gt=0.0)
    http_burst: int = Field(100, ge=1)
    ws_rate: float = Field(10.0, gt=0.0)
    ws_burst: int = Field(20, ge=1)
    telemetry_budget: float = Field(400.0, gt=0.0)
    max_body_bytes: int = Field(65536, ge=256, le=1 << 20)
    max_json_depth: int = Field(16, ge=2, le=256)
    max_ws_message_bytes: int = Field(16384, ge=1024, le=65536)
    read_chunk_bytes: int = Field(16384, ge=1024, le=65536)
    send_timeout: float = Field(10.0, gt=0.0)


class BodyError(ValueError):
    """A request body that cannot be accepted; ``status`` is the HTTP status to answer."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKETS = re.compile(rb"[\[\]{}]")


def json_depth(raw: bytes) -> int:
    """Deepest nesting of ``[``/``{`` in a JSON text (strings skipped), without parsing."""
    depth = deepest = 0
    for ch in _BRACKETS.findall(_STRING.sub(b"", raw)):
        if ch in (b"[", b"{"):
            depth += 1
            deepest = max(deepest, depth)
        else:
            depth -= 1
    return deepest


def parse_json(raw: bytes | str, max_bytes: int, max_depth: int) -> Any:
    """Parse a request body or WebSocket message; :class:`BodyError` (413 / 422) when it is
    too large, nested deeper than ``max_depth`` or not JSON."""
    data = raw.encode() if isinstance(raw, str) else raw
    if len(data) > max_bytes:
        raise BodyError(413, f"body of {len(data)} bytes is larger than {max_bytes} bytes")
    depth = json_depth(data)
    if depth > max_depth:
        raise BodyError(422, f"body is not JSON within the limits: nested {depth} levels "
                             f"deep; at most {max_depth} allowed")
    try:
        return json.loads(data) if data.strip() else None
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise BodyError(422, f"body is not JSON: {exc}") from None


# --- rate limits -----------------------------------------------------------------------------
@dataclass
class TokenBucket:
    """``rate`` tokens per second up to ``burst``; :meth:`take` says how long to wait (0 = ok)."""

    rate: float
    burst: float
    tokens: float = -1.0
    stamp: float = field(default_factory=time.monotonic)

    def take(self, now: float | None = None) -> float:
        now = time.monotonic() if now is None else now
        if self.tokens < 0.0:
            self.tokens = self.burst
        self.tokens = min(self.burst, self.tokens + (now - self.stamp) * self.rate)
        self.stamp = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return 0.0
        return (1.0 - self.tokens) / self.rate


class RateLimiter:
    """One :class:`TokenBucket` per key (client address); idle buckets are forgotten."""

    def __init__(self, rate: float, burst: int, max_keys: int = 4096) -> None:
        self.rate, self.burst, self.max_keys = rate, float(burst), max_keys
        self._buckets: dict[str, TokenBucket] = {}
        self.refused = 0

    def take(self, key: str) -> float:
        bucket = self._buckets.get(key)
        if bucket is None:
            if len(self._buckets) >= self.max_keys:
                self._forget_full()
            bucket = self._buckets[key] = TokenBucket(self.rate, self.burst)
        wait = bucket.take()
        if wait > 0.0:
            self.refused += 1
        return wait

    def _forget_full(self) -> None:
        now = time.monotonic()
        full = [k for k, b in self._buckets.items()
                if b.tokens + (now - b.stamp) * b.rate >= b.burst]
        for k in full or list(self._buckets)[: self.max_keys // 2]:
            del self._buckets[k]


# --- viewers ---------------------------------------------------------------------------------
class ViewerRegistry:
    """WebSocket viewers by client address: the caps and the telemetry fair share."""

    def __init__(self, params: WebSecurityParams) -> None:
        self.params = params
        self.by_client: dict[str, int] = {}
        self.total = 0
        self.refused = 0

    def acquire(self, client: str) -> str:
        """Register a viewer; returns "" or why it is refused."""
        p = self.params
        if self.total >= p.max_viewers:
            self.refused += 1
            return f"too many viewers ({p.max_viewers}); try again later"
        if self.by_client.get(client, 0) >= p.max_viewers_per_client:
            self.refused += 1
            return (f"too many viewers from {client} ({p.max_viewers_per_client}); "
                    "close other tabs")
        self.by_client[client] = self.by_client.get(client, 0) + 1
        self.total += 1
        return ""

    def release(self, client: str) -> None:
        n = self.by_client.get(client, 0) - 1
        if n > 0:
            self.by_client[client] = n
        else:
            self.by_client.pop(client, None)
        self.total = max(0, self.total - 1)

    def frame_period(self, base_period: float) -> float:
        """Seconds between frames for each viewer: the configured period, stretched so all
        viewers together stay within ``telemetry_budget`` messages per second."""
        return max(base_period, self.total / self.params.telemetry_budget)


# --- host / origin ---------------------------------------------------------------------------
def lan_addresses() -> list[str]:
    """IPv4 addresses of this machine other than loopback (best effort, no traffic sent)."""
    found: list[str] = []
    with contextlib.suppress(OSError):
        for info in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET):
            found.append(str(info[4][0]))
    with contextlib.suppress(OSError), socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.connect(("10.255.255.255", 1))  # UDP connect: picks the route, sends nothing
        found.insert(0, s.getsockname()[0])
    return [a for i, a in enumerate(found)
            if a not in found[:i] and not ipaddress.ip_address(a).is_loopback]


def allowed_host_names(bind_host: str, extra: tuple[str, ...] = ()) -> set[str]:
    """Host names the server answers to: loopback, the bound address, and on a wildcard
    bind the LAN addresses and host name; plus ``extra``."""
    names = set(LOOPBACK_NAMES)
    if bind_host in WILDCARD_HOSTS:
        names.update(lan_addresses())
        hostname = socket.gethostname()
        names.update({hostname, f"{hostname}.local"})
    else:
        names.add(bind_host)
    names.update(extra)
    return {n.lower().strip("[]") for n in names if n}


def split_host(value: str) -> tuple[str, int | None]:
    """``host[:port]`` (IPv6 in brackets) -> (lower-case host, port or None)."""
    value = value.strip().lower()
    if value.startswith("["):
        host, _, rest = value[1:].partition("]")
        port = rest[1:] if rest.startswith(":") else ""
    elif value.count(":") == 1:
        host, _, port = value.partition(":")
    else:
        host, port = value, ""
    return host, int(port) if port.isdigit() else None


class HostOriginPolicy:
    """Decides whether a request's ``Host`` and ``Origin`` belong to this server."""

    def __init__(self, bind_host: str, port: int, scheme: str,
                 params: WebSecurityParams) -> None:
        self.hosts = allowed_host_names(bind_host, params.allowed_hosts)
        self.port = port
        self.scheme = scheme
        self.origins = {o.rstrip("/").lower() for o in params.allowed_origins}

    def check(self, host_header: str | None, origin: str | None) -> str:
        """"" if allowed, else the reason."""
        if host_header is None:
            return "request without a Host header"
        host, _ = split_host(host_header)
        if host not in self.hosts:
            return (f"Host '{host}' is not one of this server's names; add it with "
                    f"allowed_hosts if it is yours")
        if origin is None:
            return ""
        if origin.rstrip("/").lower() in self.origins:
            return ""
        parts = urlsplit(origin)
        try:
            oport = parts.port
        except ValueError:
            return f"malformed Origin '{origin}'"
        default = 443 if parts.scheme == "https" else 80
        if (parts.scheme in ("http", "https") and (parts.hostname or "") in self.hosts
                and (oport or default) == self.port):
            return ""
        return f"cross-site request from Origin '{origin}' refused"


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", ()):
        if key == name:
            return str(value.decode("latin-1"))
    return None


def client_address(scope: Scope) -> str:
    client = scope.get("client")
    return str(client[0]) if client else "?"


class GuardMiddleware:
    """ASGI middleware: host/origin policy and per-address HTTP rate limit and body size.

    ``exempt(scope)`` returns True for requests never rate-limited (an authenticated
    e-stop)."""

    def __init__(self, app: ASGIApp, policy: HostOriginPolicy, params: WebSecurityParams,
                 exempt: Callable[[Scope], bool]) -> None:
        self.app = app
        self.policy = policy
        self.params = params
        self.exempt = exempt
        self.limiter = RateLimiter(params.http_rate, params.http_burst)
        self.refused_origin = 0

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        problem = self.policy.check(_header(scope, b"host"), _header(scope, b"origin"))
        if problem:
            self.refused_origin += 1
            await _refuse(kind, receive, send, 403, problem)
            return
        if not self.exempt(scope):
            wait = self.limiter.take(client_address(scope))
            if wait > 0.0:
                await _refuse(kind, receive, send, 429,
                              f"too many requests from {client_address(scope)}; retry in "
                              f"{math.ceil(wait)} s", {"retry-after": str(math.ceil(wait))})
                return
        length = _header(scope, b"content-length")
        if kind == "http" and length is not None and length.isdigit() and (
                int(length) > self.params.max_body_bytes):
            await _refuse(kind, receive, send, 413,
                          f"body of {length} bytes is larger than "
                          f"{self.params.max_body_bytes} bytes")
            return
        await self.app(scope, receive, send)


async def _refuse(kind: str, receive: Receive, send: Send, status: int, reason: str,
                  headers: dict[str, str] | None = None) -> None:
    if kind == "websocket":
        await receive()  # websocket.connect
        # closing before accepting: the server answers the handshake with HTTP 403
        await send({"type": "websocket.close", "code": 1008, "reason": reason[:120]})
        return
    if status != 413:
        await _drain_body(receive, limit=1 << 20)
    body = json.dumps({"error": reason}).encode()
    hdrs = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
            (b"connection", b"close")]
    hdrs += [(k.encode(), v.encode()) for k, v in (headers or {}).items()]
    await send({"type": "http.response.start", "status": status, "headers": hdrs})
    await send({"type": "http.response.body", "body": body})


async def _drain_body(receive: Receive, limit: int) -> None:
    """Read up to ``limit`` bytes of the request body before refusing it.

    Closing a connection whose request body is still unread makes the kernel send a TCP
    reset, and the client sees "connection reset" instead of the 429 it was sent."""
    read = 0
    while read <= limit:
        message = await receive()
        if message["type"] != "http.request" or not message.get("more_body", False):
            return
        read += len(message.get("body", b""))
