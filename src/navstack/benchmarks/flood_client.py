"""Read-only WebSocket flood for the hardening tests, run in its own process.

``python flood_client.py URL N`` opens N viewers on URL at once; each reads and discards
everything the server pushes.  Prints ``accepted A refused R`` once every handshake has
been answered (refused: HTTP error or a close frame right after the handshake), then
holds the connections until its standard input closes.
"""

from __future__ import annotations

import asyncio
import sys

from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed, InvalidStatus


async def viewer(url: str, ready: asyncio.Queue[bool]) -> None:
    try:
        async with connect(url, open_timeout=30, max_size=None) as ws:
            first = await ws.recv()  # hello, or the close frame of a refusal
            await ready.put(bool(first))
            await drain(ws)
    except (InvalidStatus, ConnectionClosed, OSError, TimeoutError):
        await ready.put(False)


async def drain(ws: ClientConnection) -> None:
    try:
        async for _ in ws:
            pass
    except ConnectionClosed:
        pass


async def main(url: str, n: int) -> None:
    ready: asyncio.Queue[bool] = asyncio.Queue()
    tasks = [asyncio.create_task(viewer(url, ready)) for _ in range(n)]
    results = [await ready.get() for _ in range(n)]
    print(f"accepted {sum(results)} refused {n - sum(results)}", flush=True)
    loop = asyncio.get_running_loop()
    await loop.run_in_executor(None, sys.stdin.read)
    for t in tasks:
        t.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], int(sys.argv[2])))
