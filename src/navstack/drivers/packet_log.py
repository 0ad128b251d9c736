"""Packet logs: what ``navstack link monitor --log`` records and ``navstack link replay``
sends.

JSON Lines, one object per line.  The first line is the header::

    {"navstack_packet_log": 1, "source": "udp:5005", "protocol": "rover_vcu",
     "started": "2024-05-01T12:00:00+00:00"}

then one line per packet, in arrival order::

    {"t": 0.0213, "link": "vcu", "dir": "rx", "hex": "52564f44..."}

``t`` is seconds since the log started (monotonic clock), ``dir`` ``rx`` (received by the
recorder) or ``tx`` (sent by it), ``hex`` the packet's bytes.  Readers refuse a file
without the header, a line that is not JSON, a missing field, a non-hex payload or times
that go backwards, naming the file and line.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Literal

from navstack.core.errors import ConfigError

__all__ = ["LOG_VERSION", "LoggedPacket", "PacketLogWriter", "read_packet_log"]

LOG_VERSION = 1


@dataclass(frozen=True, slots=True)
class LoggedPacket:
    t: float
    link: str
    direction: Literal["rx", "tx"]
    data: bytes


class PacketLogWriter:
    """Appends packets to an open text file (flushes every line)."""

    def __init__(self, stream: IO[str], source: str, protocol: str) -> None:
        self.stream = stream
        header = {"navstack_packet_log": LOG_VERSION, "source": source, "protocol": protocol,
                  "started": datetime.now(UTC).isoformat(timespec="seconds")}
        stream.write(json.dumps(header) + "\n")
        stream.flush()
        self.count = 0

    def write(self, packet: LoggedPacket) -> None:
        self.stream.write(json.dumps({"t": round(packet.t, 6), "link": packet.link,
                                      "dir": packet.direction, "hex": packet.data.hex()}) + "\n")
        self.stream.flush()
        self.count += 1


def read_packet_log(path: str | Path) -> tuple[dict[str, object], list[LoggedPacket]]:
    """(header, packets) of a packet log; :class:`ConfigError` naming file and line."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read packet log: {exc}", file=str(path)) from None
    if not lines:
        raise ConfigError("empty file: not a navstack packet log", file=str(path))
    try:
        header = json.loads(lines[0])
    except json.JSONDecodeError:
        header = None
    if not isinstance(header, dict) or header.get("navstack_packet_log") != LOG_VERSION:
        raise ConfigError(f"line 1 is not a navstack packet log header (version "
                          f"{LOG_VERSION}); record one with `navstack link monitor --log`",
                          file=str(path))
    packets: list[LoggedPacket] = []
    last = 0.0
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        where = f"line {number}"
        try:
            row = json.loads(line)
            t, link, direction = float(row["t"]), str(row["link"]), row["dir"]
            data = bytes.fromhex(row["hex"])
        except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"{where}: expected {{\"t\", \"link\", \"dir\", \"hex\"}}: "
                              f"{type(exc).__name__}: {exc}", file=str(path)) from None
        if direction not in ("rx", "tx"):
            raise ConfigError(f"{where}: dir must be 'rx' or 'tx', got {direction!r}",
                              file=str(path))
        if t < last:
            raise ConfigError(f"{where}: time {t} goes backwards (previous {last})",
                              file=str(path))
        last = t
        packets.append(LoggedPacket(t, link, direction, data))
    return header, packets
