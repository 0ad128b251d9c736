"""The ``transport`` section of a stack file (issue 21).

::

    transport:
      kind: zenoh                 # "local" (default): the in-process bus only
      name: robot1                # this process on the link (robot name or "base")
      namespace: /robot1          # prefix of this process's topics on the wire
      mode: peer                  # or "client" (through a zenoh router)
      listen: ["tcp/0.0.0.0:7447"]
      connect: ["tcp/192.168.1.10:7447"]
      peers: [base]               # processes whose clocks and liveness this one tracks
      domain_id: 0
      multicast_scouting: false   # explicit endpoints by default
      clock: {offset: 0.0, compensate: true, rate: 1.0, sync_period: 0.1}
      link_timeout: 0.3           # robot stops when nothing is heard for this long
      impairments: {delay: 0.0, loss: 0.0, blackouts: [[20.0, 2.0]], seed: 0}
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from navstack.core.params import Params
from navstack.runtime.transports.impairments import LinkImpairments


class ClockSection(Params):
    """``offset`` [s]: simulated error of this process's clock (tests); ``compensate``:
    shift received stamps by the estimated offset; ``rate``: accelerated wall clock
    (both processes must agree; 1 = real time); ``sync_period`` [s] between exchanges and
    heartbeats; ``mode``: ``wall`` (hardware, real time) or ``lockstep`` (simulation:
    stepped time shared by robot and base, reproducible under load, ``quantum`` apart at
    most -- :mod:`navstack.runtime.transports.lockstep`)."""

    mode: Literal["wall", "lockstep"] = "wall"
    quantum: float = Field(0.005, gt=0.0, le=0.1)
    offset: float = Field(0.0, ge=-86400.0, le=86400.0)
    compensate: bool = True
    rate: float = Field(1.0, gt=0.0, le=20.0)
    sync_period: float = Field(0.1, gt=0.0, le=10.0)
    tolerance: float = Field(0.005, gt=0.0)


class TransportSection(Params):
    """How this process reaches the others (see module docstring)."""

    kind: Literal["local", "zenoh"] = "local"
    name: str = "robot"
    namespace: str = ""
    mode: Literal["peer", "client"] = "peer"
    listen: list[str] = Field(default_factory=list)
    connect: list[str] = Field(default_factory=list)
    peers: list[str] = Field(default_factory=list)
    domain_id: int = Field(0, ge=0, le=232)
    multicast_scouting: bool = False
    clock: ClockSection = ClockSection()
    link_timeout: float = Field(0.3, gt=0.0, le=30.0)
    impairments: LinkImpairments = LinkImpairments()

    @field_validator("listen", "connect")
    @classmethod
    def _check_endpoints(cls, value: list[str]) -> list[str]:
        for ep in value:
            proto, sep, rest = ep.partition("/")
            if not sep or proto not in ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream") \
                    or not rest:
                raise ValueError(f"endpoint '{ep}' is not '<protocol>/<address>' "
                                 f"(e.g. 'tcp/127.0.0.1:7447')")
        return value

    @field_validator("name")
    @classmethod
    def _check_name(cls, value: str) -> str:
        if not value or not all(c.isalnum() or c == "_" for c in value):
            raise ValueError(f"transport name '{value}' must be letters, digits and '_'")
        return value
