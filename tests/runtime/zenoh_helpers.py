"""Two Zenoh links on loopback inside one test process, each with its own runtime."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable
from typing import Any

from navstack.runtime.node import Runtime
from navstack.runtime.scheduler import Scheduler
from navstack.runtime.transports.config import TransportSection
from navstack.runtime.transports.zenoh_link import ZenohLink


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def link_pair(robot_kw: dict[str, Any] | None = None, base_kw: dict[str, Any] | None = None,
              robot_offset: float = 0.0) -> tuple[ZenohLink, ZenohLink]:
    """Robot (listening) and base (connecting) links on a free loopback port."""
    port = free_port()
    r = TransportSection.from_mapping({"kind": "zenoh", "name": "robot", "peers": ["base"],
                                       "listen": [f"tcp/127.0.0.1:{port}"],
                                       **(robot_kw or {})})
    b = TransportSection.from_mapping({"kind": "zenoh", "name": "base", "peers": ["robot"],
                                       "connect": [f"tcp/127.0.0.1:{port}"],
                                       **(base_kw or {})})
    robot = ZenohLink(Runtime(Scheduler("wall", clock_offset=robot_offset)), r, peers=["base"])
    base = ZenohLink(Runtime(Scheduler("wall")), b, peers=["robot"])
    return robot, base


def run_both(a: ZenohLink, b: ZenohLink, seconds: float,
             until: Callable[[], bool] | None = None) -> None:
    """Run ``a``'s loop in a thread and ``b``'s here, for ``seconds`` (or ``until``)."""
    stop = threading.Event()

    def loop_a() -> None:
        sched = a.scheduler
        t_end = sched.now + seconds
        while sched.now < t_end and not stop.is_set():
            sched.run_for(0.05)

    thread = threading.Thread(target=loop_a, daemon=True)
    thread.start()
    try:
        b.scheduler.run_for(seconds, until=until)
    finally:
        stop.set()
        thread.join(timeout=5.0)
