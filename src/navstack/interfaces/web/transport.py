"""uvicorn protocol classes that bound what an unauthenticated peer makes the server read.

The probe's finding: a 16 MiB WebSocket frame was read and parsed before any token check
(uvicorn's default ``ws_max_size`` is 16 MiB).  Three measures, all below the ASGI app:

* ``ws_max_size`` = ``max_ws_message_bytes`` (16 KiB by default; dashboard commands are
  well under 1 KiB): the WebSocket parser (``websockets``' sans-I/O protocol) checks the
  length in the frame *header* and fails the connection with close code 1009 before
  reading the payload;
* the socket is read in chunks of ``read_chunk_bytes`` (16 KiB) instead of asyncio's
  256 KiB, from the first byte of the HTTP request on, so the header check happens after
  at most one chunk of payload has been pulled into the process;
* every WebSocket connection counts the bytes it read (:class:`ReadStats`), so the bound
  is measured, not assumed: a refused 16 MiB frame costs the server a few chunks, and
  the rest of it is discarded by the kernel when the connection closes.

The chunk size applies to asyncio's selector transports (plain HTTP); under TLS the
bytes are read by asyncio's SSL protocol in its own buffer, and the frame-header check
is the remaining bound.
"""

from __future__ import annotations

import asyncio
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from uvicorn.protocols.http.auto import AutoHTTPProtocol
from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol


@dataclass(frozen=True)
class ClosedConnection:
    """A finished WebSocket connection: peer, bytes read, close code sent (None: none)."""

    peer: str
    bytes_read: int
    close_code: int | None


@dataclass
class ReadStats:
    """Recent finished WebSocket connections (shared by all connections of one server)."""

    closed: deque[ClosedConnection] = field(default_factory=lambda: deque(maxlen=1000))

    def refused(self, code: int) -> list[ClosedConnection]:
        return [c for c in self.closed if c.close_code == code]


def _limit_reads(transport: Any, chunk: int) -> None:
    # asyncio's selector transport reads ``max_size`` bytes per recv(); an instance
    # attribute overrides the 256 KiB class default
    if hasattr(transport, "max_size"):
        transport.max_size = chunk


def guarded_protocols(stats: ReadStats, read_chunk: int) -> tuple[type[asyncio.Protocol],
                                                                   type[asyncio.Protocol]]:
    """(HTTP protocol class, WebSocket protocol class) for ``uvicorn.Config``."""

    class GuardedHTTP(AutoHTTPProtocol):  # type: ignore[misc, valid-type]
        def connection_made(self, transport: asyncio.BaseTransport) -> None:
            _limit_reads(transport, read_chunk)
            super().connection_made(transport)

    class GuardedWebSocket(WebSocketsSansIOProtocol):
        bytes_read = 0

        def connection_made(self, transport: asyncio.BaseTransport) -> None:
            _limit_reads(transport, read_chunk)
            super().connection_made(transport)

        def data_received(self, data: bytes) -> None:
            self.bytes_read += len(data)
            super().data_received(data)

        def connection_lost(self, exc: Exception | None) -> None:
            close = self.conn.close_sent
            peer = f"{self.client[0]}:{self.client[1]}" if self.client else "?"
            stats.closed.append(ClosedConnection(peer, self.bytes_read,
                                                 close.code if close is not None else None))
            super().connection_lost(exc)

    return GuardedHTTP, GuardedWebSocket
