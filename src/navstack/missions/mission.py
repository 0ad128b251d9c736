"""``Mission`` and ``MissionRunner``: a behaviour tree run as a mission on the bus.

A :class:`Mission` is a named py_trees tree built on a :class:`MissionContext`.  The
:class:`MissionRunner` node ticks it every ``tick_period`` of the runtime's clock, and

* publishes the mission state on ``/mission/state`` (``std_msgs/String`` holding JSON:
  name, status, the running behaviour, the feedback text and progress numbers, elapsed
  time, the reason once it ended) -- latched, so a dashboard connecting late sees it;
* ends SUCCEEDED when the tree succeeds, FAILED with the reason of the failure that ended
  it (e.g. ``ReturnHome: could not return home ...: navigation failed: ...``), or
  CANCELED on :meth:`MissionRunner.cancel`, which stops the tree at once -- every running
  action goal is cancelled and a zero velocity is published in the same instant, so the
  robot is commanded to stop within the current control cycle;
* can end FAILED on ``max_duration``.

Like an action, a mission never ends without a status and, unless it succeeded, a reason.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from py_trees.behaviour import Behaviour
from py_trees.common import Status

from navstack.core.msgs import String
from navstack.missions.context import MissionContext
from navstack.runtime.node import Node, Runtime

__all__ = ["MISSION_STATE_TOPIC", "Mission", "MissionResult", "MissionRunner",
           "MissionStatus"]

MISSION_STATE_TOPIC = "/mission/state"


class MissionStatus(Enum):
    PENDING = "PENDING"
    RUNNING = "RUNNING"
    SUCCEEDED = "SUCCEEDED"
    FAILED = "FAILED"
    CANCELED = "CANCELED"

    @property
    def terminal(self) -> bool:
        return self in (MissionStatus.SUCCEEDED, MissionStatus.FAILED, MissionStatus.CANCELED)


@dataclass
class Mission:
    """A named behaviour tree (``root``) on ``ctx``; ``summary`` returns report data."""

    name: str
    root: Behaviour
    ctx: MissionContext
    description: str = ""
    summary: Callable[[], dict[str, Any]] | None = None


@dataclass(frozen=True)
class MissionResult:
    status: MissionStatus
    reason: str
    started: float
    ended: float
    events: tuple[tuple[float, str], ...] = ()
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return self.ended - self.started


class MissionRunner(Node):
    """Ticks a :class:`Mission` on the runtime's clock (module docstring)."""

    def __init__(self, runtime: Runtime, mission: Mission, tick_period: float = 0.1,
                 max_duration: float | None = None, name: str = "mission") -> None:
        super().__init__(name, runtime)
        self.mission = mission
        self.tick_period = tick_period
        self.max_duration = max_duration
        self.status = MissionStatus.PENDING
        self.result: MissionResult | None = None
        self.started = 0.0
        self.ticks = 0
        self.on_done: list[Callable[[MissionResult], None]] = []

    # --- lifecycle ---------------------------------------------------------------------
    def on_configure(self) -> None:
        self.pub_state = self.create_latched_publisher(MISSION_STATE_TOPIC, String)
        self.mission.root.setup_with_descendants()
        self.create_timer(self.tick_period, self._tick)

    def on_activate(self) -> None:
        self.started = self.now
        self.status = MissionStatus.RUNNING
        self.mission.ctx.log(f"mission '{self.mission.name}' started")
        self._publish()

    def start(self) -> MissionRunner:
        """Configure and activate (the first tick follows after ``tick_period``)."""
        self.configure()
        self.activate()
        return self

    @property
    def done(self) -> bool:
        return self.result is not None

    # --- ticking ---------------------------------------------------------------------
    def _tick(self) -> None:
        if self.done:
            return
        root = self.mission.root
        root.tick_once()
        self.ticks += 1
        if root.status is Status.SUCCESS:
            self._finish(MissionStatus.SUCCEEDED, "")
        elif root.status is Status.FAILURE:
            failures = self.mission.ctx.failures
            reason = failures[-1].describe() if failures else "the mission tree failed"
            self._finish(MissionStatus.FAILED, reason)
        elif (self.max_duration is not None
              and self.now - self.started > self.max_duration):
            root.stop(Status.INVALID)
            self.mission.ctx.stop_robot()
            self._finish(MissionStatus.FAILED,
                         f"did not finish within max_duration {self.max_duration:.0f} s")
        else:
            self._publish()

    def cancel(self, reason: str = "canceled on request") -> None:
        """Stop the tree now: running goals are cancelled and a zero velocity published."""
        if self.done:
            return
        self.mission.root.stop(Status.INVALID)
        self.mission.ctx.stop_robot(at_once=True)
        self._finish(MissionStatus.CANCELED, reason)

    def _finish(self, status: MissionStatus, reason: str) -> None:
        self.status = status
        ctx = self.mission.ctx
        ctx.log(f"mission '{self.mission.name}' {status.value}" + (f": {reason}" if reason
                                                                     else ""))
        data = dict(self.mission.summary()) if self.mission.summary is not None else {}
        self.result = MissionResult(status, reason, self.started, self.now,
                                    tuple(ctx.events), data)
        self._publish()
        for cb in list(self.on_done):
            cb(self.result)

    # --- state -----------------------------------------------------------------------
    def mission_state(self) -> dict[str, Any]:
        """The mission state published on ``/mission/state``."""
        ctx = self.mission.ctx
        tip = self.mission.root.tip()
        return {
            "name": self.mission.name,
            "status": self.status.value,
            "behaviour": tip.name if tip is not None and not self.done else "",
            "feedback": ctx.status_text,
            "progress": {k: round(v, 3) for k, v in ctx.progress.items()},
            "elapsed": round(self.now - self.started, 2),
            "reason": self.result.reason if self.result is not None else "",
            "events": [[round(t, 2), text] for t, text in ctx.events[-5:]],
        }

    def _publish(self) -> None:
        self.pub_state.publish(String(json.dumps(self.mission_state(), separators=(",", ":"))))

    def run(self, timeout: float) -> MissionResult:
        """Run the scheduler until the mission ends or ``timeout`` simulated seconds pass
        (then it is cancelled with that reason); returns the result."""
        if self.status is MissionStatus.PENDING:
            self.start()
        sched = self.runtime.scheduler
        sched.run_for(timeout, until=lambda: self.done)
        if not self.done:
            self.cancel(f"timed out after {timeout:.0f} s")
        sched.run_for(0.0)  # deliver what the last tick published (the final state)
        assert self.result is not None
        return self.result
