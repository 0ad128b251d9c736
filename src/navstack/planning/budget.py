"""``max_planning_time`` on the wall clock, or as a fixed expansion budget on simulated time.

Nav2's planners (``SmacPlannerHybrid``, ``SmacPlanner2D``) stop a search after
``max_planning_time`` seconds of *wall* time.  On a robot that is right: the plan is due
within that time, whatever the CPU.  In a simulation whose clock is stepped it is wrong
twice: planning takes no simulated time at all, and a wall-clock cut-off makes the same
seed give a different run on a busier machine (a search stopped at 3.1 M expansions
returns a different path from one stopped at 3.4 M).

:class:`PlanningBudget` keeps Nav2's semantics on the wall clock and, when the planner
is told that its clock is simulated (:meth:`navstack.core.interfaces.GlobalPlanner.
use_simulated_time`, called by the planner server when the scheduler runs simulated
time), turns the same ``max_planning_time`` into ``max_planning_time x
expansion_rate`` expansions -- the search a reference machine completes in that time.
The budget is checked at the same expansion counts as the wall clock is (every
``terminal_checking_interval``), so the outcome depends only on the inputs.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

__all__ = ["PlanningBudget"]


@dataclass
class PlanningBudget:
    """A search's time budget: wall seconds, or expansions on simulated time.

    ``max_time`` [s] (``None``: unlimited); ``expansion_rate`` [expansions/s] converts it
    on simulated time; ``simulated`` picks the mode.
    """

    max_time: float | None
    expansion_rate: float
    simulated: bool = False
    _t0: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.expansion_rate) and self.expansion_rate > 0.0):
            raise ValueError(f"expansion_rate must be a positive number of expansions per "
                             f"second, got {self.expansion_rate}")
        self.restart()

    @property
    def max_expansions(self) -> int | None:
        """The expansion budget on simulated time (``None`` on the wall clock or unlimited)."""
        if not self.simulated or self.max_time is None:
            return None
        return max(1, int(self.max_time * self.expansion_rate))

    def restart(self, t0: float | None = None) -> None:
        """Start the wall clock now, or at ``t0`` (a ``time.perf_counter()`` reading);
        again after a JIT compilation, which is not the search's time."""
        self._t0 = time.perf_counter() if t0 is None else t0

    def elapsed(self) -> float:
        """Wall seconds since :meth:`restart`."""
        return time.perf_counter() - self._t0

    def exceeded(self, expansions: int) -> bool:
        """True once the search has used its budget (``expansions`` done so far)."""
        if self.max_time is None:
            return False
        limit = self.max_expansions
        if limit is not None:
            return expansions > limit
        return self.elapsed() > self.max_time

    def describe(self, expansions: int) -> str:
        """What ran out, for the timeout error message."""
        assert self.max_time is not None
        if self.simulated:
            return (f"max_planning_time {self.max_time:.3f} s (simulated time: "
                    f"{self.max_expansions} expansions at sim_expansion_rate "
                    f"{self.expansion_rate:.0f}/s; {expansions} expansions done)")
        return (f"max_planning_time {self.max_time:.3f} s ({expansions} expansions in "
                f"{self.elapsed():.3f} s)")
