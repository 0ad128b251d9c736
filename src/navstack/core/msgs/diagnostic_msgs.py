"""diagnostic_msgs equivalents, and navstack's own small control messages."""

from __future__ import annotations

from dataclasses import dataclass, field

from navstack.core.msgs.std import Header


@dataclass(frozen=True, slots=True)
class KeyValue:
    """diagnostic_msgs/KeyValue."""

    key: str = ""
    value: str = ""


@dataclass(frozen=True, slots=True)
class DiagnosticStatus:
    """diagnostic_msgs/DiagnosticStatus: ``level`` OK 0, WARN 1, ERROR 2, STALE 3."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3
    level: int = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: tuple[KeyValue, ...] = ()

    def value(self, key: str, default: str = "") -> str:
        return next((kv.value for kv in self.values if kv.key == key), default)


@dataclass(frozen=True, slots=True)
class DiagnosticArray:
    """diagnostic_msgs/DiagnosticArray."""

    header: Header = field(default_factory=Header)
    status: tuple[DiagnosticStatus, ...] = ()


@dataclass(frozen=True, slots=True)
class NavigationHold:
    """navstack: ask navigation to pause (``hold`` true) or resume, for a reason.

    Published by whoever cannot let the robot move -- a vehicle driver whose link is
    lost -- on ``/navigation/hold``.  Holds are kept per ``source``: navigation resumes
    when every source has released its hold.
    """

    hold: bool = False
    source: str = ""
    reason: str = ""
    stamp: float = 0.0
