"""NTP-style clock offset and round-trip estimation between two processes.

One exchange (RFC 5905 §8): the client stamps ``t1`` when it sends a probe, the server
stamps ``t2`` on receipt and ``t3`` on reply, the client stamps ``t4`` on receipt.  Then
``offset = ((t2 - t1) + (t3 - t4)) / 2`` (server clock minus client clock) and
``delay = (t4 - t1) - (t3 - t2)``.  Queueing only ever lengthens ``delay`` and biases the
offset by at most ``delay / 2``, so, like NTP's clock filter, the estimate is the offset
of the sample with the smallest delay among the recent ones.  Zenoh's own HLC timestamps
order events but do not remove an offset between hosts (issue 21: a host 0.55 s ahead had
its samples dropped), hence this explicit exchange.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class ClockSample:
    """One exchange: offset of the server's clock over the client's, and round trip [s]."""

    offset: float
    delay: float
    t4: float  # client receive time


def exchange_sample(t1: float, t2: float, t3: float, t4: float) -> ClockSample:
    """The offset/delay of one probe (all four stamps in seconds, each on its own clock)."""
    for name, t in (("t1", t1), ("t2", t2), ("t3", t3), ("t4", t4)):
        if not math.isfinite(t):
            raise ValueError(f"clock exchange stamp {name} is not finite: {t}")
    return ClockSample(offset=((t2 - t1) + (t3 - t4)) / 2.0,
                       delay=max(0.0, (t4 - t1) - (t3 - t2)), t4=t4)


class OffsetEstimator:
    """Keeps the last ``window`` exchanges; the estimate is the minimum-delay sample's.

    ``max_age`` [s, client clock] forgets samples older than that, so a clock that is
    stepped or drifts is followed within ``max_age``.
    """

    def __init__(self, window: int = 16, max_age: float = 30.0) -> None:
        if window < 1:
            raise ValueError(f"clock filter window must be >= 1, got {window}")
        self._samples: deque[ClockSample] = deque(maxlen=window)
        self.max_age = max_age
        self.count = 0

    def add(self, sample: ClockSample) -> None:
        self._samples.append(sample)
        self.count += 1

    def _fresh(self) -> list[ClockSample]:
        if not self._samples:
            return []
        newest = self._samples[-1].t4
        return [s for s in self._samples if newest - s.t4 <= self.max_age]

    @property
    def ready(self) -> bool:
        return bool(self._samples)

    def best(self) -> ClockSample | None:
        fresh = self._fresh()
        return min(fresh, key=lambda s: s.delay) if fresh else None

    @property
    def offset(self) -> float:
        """Estimated offset [s] (peer clock minus ours); 0 before the first exchange."""
        best = self.best()
        return best.offset if best is not None else 0.0

    @property
    def delay(self) -> float:
        """Round trip of the best sample [s] (``inf`` before the first exchange)."""
        best = self.best()
        return best.delay if best is not None else math.inf

    @property
    def last_delay(self) -> float:
        return self._samples[-1].delay if self._samples else math.inf
