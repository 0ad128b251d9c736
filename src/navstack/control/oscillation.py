"""Oscillation detection on the velocity command stream.

The planetary rover's behaviour tree runs an ``OscillationDetected`` guard in parallel with
its navigation (see ``FIELD-ROBOTS.md``): a chase whose command keeps flipping sign while
the rover goes nowhere is stopped. ROS 1 move_base had the same idea as
``oscillation_timeout`` / ``oscillation_distance`` (the robot must move that far within
that time). This detector combines both: within the last ``window`` seconds it counts
sign flips of the angular and of the linear command (values smaller than ``deadband`` do
not count as a sign), and reports an oscillation when either count reaches ``min_flips``
while the robot's net displacement over the window stays under ``min_progress`` metres.
A slalom that makes progress is not an oscillation; a robot turning left-right-left on
the spot is.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

from pydantic import Field

from navstack.core.params import Params

__all__ = ["OscillationDetector", "OscillationParams", "OscillationReport"]


class OscillationParams(Params):
    """``window`` [s]: how far back flips are counted; ``min_flips``: sign flips of one
    command component within the window that count as oscillating; ``deadband``: |value|
    below which a command has no sign (angular [rad/s] and linear [m/s]);
    ``min_progress`` [m]: net displacement over the window that clears a suspicion
    (move_base's ``oscillation_distance``).  ``deadband`` 0.1 (was 0.05): behind issue
    18's velocity smoother DWB settles out of an in-place turn with 0.06-0.17 rad/s
    wobbles of both signs, four "flips" within a second, which fired the guard on normal
    GPS legs (bench rover seeds 6 and 13)."""

    window: float = Field(default=6.0, gt=0.0)
    min_flips: int = Field(default=4, ge=1)
    deadband: float = Field(default=0.1, ge=0.0)
    min_progress: float = Field(default=0.5, ge=0.0)


@dataclass(frozen=True)
class OscillationReport:
    """Why the detector fired: flips per component within ``window`` s and the net
    displacement [m]."""

    angular_flips: int
    linear_flips: int
    progress: float
    window: float

    @property
    def reason(self) -> str:
        return (f"oscillating: {self.angular_flips} angular and {self.linear_flips} linear "
                f"sign flips within {self.window:g} s while moving {self.progress:.2f} m")


@dataclass
class _Sample:
    stamp: float
    angular_sign: int
    linear_sign: int
    x: float
    y: float


class OscillationDetector:
    """Feed it every command with the robot's position; :meth:`update` returns a report
    while oscillating, None otherwise. :meth:`reset` when a new goal starts."""

    def __init__(self, params: OscillationParams | None = None) -> None:
        self.params = params or OscillationParams()
        self._samples: deque[_Sample] = deque()

    def reset(self) -> None:
        self._samples.clear()

    def _sign(self, value: float) -> int:
        if not math.isfinite(value) or abs(value) < self.params.deadband:
            return 0
        return 1 if value > 0.0 else -1

    def update(self, stamp: float, linear: float, angular: float, x: float, y: float
               ) -> OscillationReport | None:
        p = self.params
        if self._samples and stamp < self._samples[-1].stamp:
            self.reset()  # time went backwards (a reset simulation): start over
        self._samples.append(_Sample(stamp, self._sign(angular), self._sign(linear), x, y))
        while self._samples and self._samples[0].stamp < stamp - p.window:
            self._samples.popleft()
        if self._samples[-1].stamp - self._samples[0].stamp < 0.5 * p.window:
            return None  # not enough history to judge
        angular_flips = _flips(s.angular_sign for s in self._samples)
        linear_flips = _flips(s.linear_sign for s in self._samples)
        if max(angular_flips, linear_flips) < p.min_flips:
            return None
        first = self._samples[0]
        progress = math.hypot(x - first.x, y - first.y)
        if progress >= p.min_progress:
            return None
        return OscillationReport(angular_flips, linear_flips, progress, p.window)


def _flips(signs: Iterable[int]) -> int:
    """Sign changes in a sequence of -1/0/+1, ignoring zeros (a stop between a left and a
    right turn is still a flip)."""
    count, last = 0, 0
    for s in signs:
        if s == 0:
            continue
        if last and s != last:
            count += 1
        last = s
    return count
