"""Time as integer nanoseconds at the seams where float seconds would round.

Messages and algorithms keep float seconds (ARCHITECTURE §3); the scheduler's event times
and the simulator's physics clock are whole nanoseconds, as ``rclcpp::Time`` is, so sums
such as ``start + k * period`` are exact and the same elapsed time gives the same steps
whatever the clock's start value (a float second keeps 1e-13 s at 1000 s and 2.4e-7 s at
the 1.8e9 s of a wall-clock epoch: sums of it round differently at different starts).
"""

from __future__ import annotations

import math

NS_PER_S = 1_000_000_000


def to_ns(t: float) -> int:
    """Seconds -> the nearest integer nanosecond.  The whole and the fractional part are
    converted apart, so a 1.8e9 s stamp keeps its fraction (``t * 1e9`` would round it to
    256 ns).  Raises ``ValueError`` for NaN and ``OverflowError`` for infinities."""
    whole = math.floor(t)
    return whole * NS_PER_S + round((t - whole) * 1e9)


def to_s(ns: int) -> float:
    """Integer nanoseconds -> the nearest float second (``int / int`` is correctly
    rounded in Python, also beyond 2**53 ns)."""
    return ns / NS_PER_S


def elapsed(now: float, since: float) -> float:
    """``now - since`` [s] as the difference of whole nanoseconds.

    Use it where an elapsed time is compared with a threshold: instants on the same
    nanosecond grid then differ by exactly their grid distance (``0.3`` s of 20 Hz
    cycles equals a ``0.3`` s tolerance), where the float difference of two absolute
    stamps carries their rounding and the comparison's outcome changed with the clock's
    start value.  Infinite or NaN operands give the plain float difference."""
    if math.isfinite(now) and math.isfinite(since):
        return (to_ns(now) - to_ns(since)) / NS_PER_S
    return now - since
