"""Link watchdog: declares a link lost when the far side has been silent too long.

Pure logic on an explicit clock (the driver node's: simulated time in simulation, the
wall clock on hardware).  The driver feeds it every valid packet; ``check(now)`` reports
the transitions.  On "lost" the driver commands zero (stop packets), reports
``link lost`` on its status and asks navigation to pause; on "restored" it clears both.

A link is lost once no valid packet arrived for ``timeout`` seconds, and restored after
``restore_count`` valid packets in a row (one stray packet from a vehicle that is
rebooting does not resume navigation).  A link that never spoke is reported lost
``timeout`` after the watchdog started.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["LinkWatchdog", "WatchdogEvent"]

WatchdogEvent = Literal["lost", "restored"]


@dataclass
class LinkWatchdog:
    """See module docstring.  Times in seconds of the caller's clock."""

    timeout: float = 0.3
    restore_count: int = 3
    started_at: float = 0.0
    last_valid: float | None = None
    lost: bool = False
    lost_at: float | None = None
    losses: int = 0
    _streak: int = 0

    def __post_init__(self) -> None:
        if not self.timeout > 0.0:
            raise ValueError(f"watchdog timeout must be > 0 s, got {self.timeout}")
        if self.restore_count < 1:
            raise ValueError(f"restore_count must be >= 1, got {self.restore_count}")

    def start(self, now: float) -> None:
        self.started_at = now

    def feed(self, now: float) -> None:
        """A valid packet arrived at ``now``."""
        self.last_valid = now
        self._streak += 1

    def silence(self, now: float) -> float:
        """Seconds since the last valid packet (or since start)."""
        ref = self.started_at if self.last_valid is None else self.last_valid
        return max(0.0, now - ref)

    def check(self, now: float) -> WatchdogEvent | None:
        """The transition at ``now``, if any."""
        if not self.lost and self.silence(now) > self.timeout:
            self.lost, self.lost_at = True, now
            self.losses += 1
            self._streak = 0
            return "lost"
        if self.lost and self._streak >= self.restore_count \
                and self.silence(now) <= self.timeout:
            self.lost, self.lost_at = False, None
            return "restored"
        if self.lost and self.silence(now) > self.timeout:
            self._streak = 0
        return None
