"""float seconds <-> ``builtin_interfaces/msg/Time`` and bag timestamps [ns].

navstack keeps time as float seconds (ARCHITECTURE.md §3); ROS 2 messages carry
``Time{int32 sec, uint32 nanosec}`` with ``0 <= nanosec < 1e9`` and bags store int64
nanoseconds.  Conversions round to the nearest nanosecond, so a round trip is exact to
1 ns; negative times keep ``nanosec`` positive (``-0.25 s`` is ``sec=-1, nanosec=75e7``)
as rclcpp does.
"""

from __future__ import annotations

import math

NS_PER_S = 1_000_000_000


def to_sec_nsec(t: float) -> tuple[int, int]:
    """``(sec, nanosec)`` of ``t`` seconds, rounded to the nearest nanosecond."""
    total = round(t * NS_PER_S) if math.isfinite(t) else 0
    sec, nsec = divmod(total, NS_PER_S)
    return int(sec), int(nsec)


def from_sec_nsec(sec: int, nanosec: int) -> float:
    """Float seconds of a ROS ``Time``/``Duration``: ``sec + nanosec / 1e9`` (the division
    rounds correctly, so ``468750000`` ns is exactly ``0.46875``)."""
    return float(sec) + nanosec / NS_PER_S


def to_ns(t: float) -> int:
    """Bag timestamp [ns] of ``t`` seconds."""
    return round(t * NS_PER_S)


def from_ns(ns: int) -> float:
    """Float seconds of a bag timestamp [ns]."""
    sec, nsec = divmod(int(ns), NS_PER_S)
    return float(sec) + nsec / NS_PER_S
