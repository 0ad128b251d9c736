"""Simulated link impairments for tests: delay, loss and blackouts (issue 21).

Applied by the process that declares them, in both directions of its link (a bad radio on
the robot): while a blackout lasts nothing is sent or received; otherwise each message is
lost with probability ``loss`` and delivered ``delay`` seconds late.  Times are seconds
since the transport opened, on the process clock.
"""

from __future__ import annotations

import random
import threading

from pydantic import Field, field_validator

from navstack.core.params import Params


class LinkImpairments(Params):
    """``delay`` [s] added to each received message, ``loss`` probability per message,
    ``blackouts`` as ``[start_s, duration_s]`` pairs since the link opened, ``seed``."""

    delay: float = Field(0.0, ge=0.0, le=10.0)
    loss: float = Field(0.0, ge=0.0, lt=1.0)
    blackouts: list[tuple[float, float]] = Field(default_factory=list)
    seed: int = 0

    @field_validator("blackouts")
    @classmethod
    def _check_blackouts(cls, value: list[tuple[float, float]]) -> list[tuple[float, float]]:
        for start, duration in value:
            if start < 0.0 or duration <= 0.0:
                raise ValueError(f"blackout [{start}, {duration}] needs start >= 0 and "
                                 f"duration > 0 (seconds since the link opened)")
        return value

    @property
    def active(self) -> bool:
        return self.delay > 0.0 or self.loss > 0.0 or bool(self.blackouts)


class ImpairedLink:
    """Decides, thread-safely, whether a message passes and how late."""

    def __init__(self, params: LinkImpairments) -> None:
        self.params = params
        self._rng = random.Random(params.seed)
        self._lock = threading.Lock()
        self.dropped_blackout = 0
        self.dropped_loss = 0

    def in_blackout(self, t: float) -> bool:
        """Whether ``t`` (seconds since the link opened) falls in a blackout."""
        return any(start <= t < start + dur for start, dur in self.params.blackouts)

    def passes(self, t: float) -> bool:
        """Whether a message at ``t`` gets through (counts the ones that do not)."""
        if self.in_blackout(t):
            with self._lock:
                self.dropped_blackout += 1
            return False
        if self.params.loss > 0.0:
            with self._lock:
                lost = self._rng.random() < self.params.loss
                self.dropped_loss += lost
            return not lost
        return True
