"""``BagPlayer``: publish a bag's messages on a bus in log-time order (``ros2 bag play``).

The player is driven by the scheduler: each message is scheduled with ``call_at`` at
``offset + log_time`` and published when the clock gets there, so whatever runs on the
same runtime (TF buffer, SLAM, localization, a report tap) sees the messages interleaved
with its own timers exactly as they were recorded.  The offset maps the bag's first
message onto the clock's time when :meth:`start` is called; a runtime made by
:func:`runtime_for_bag` starts its clock at the bag's start time, so header stamps,
TF lookups and ``now`` agree (offset 0).

*Rate.*  Playback speed is the scheduler's: a ``sim`` scheduler with ``rate=R`` plays at
R x real time, with ``rate=None`` as fast as the CPU allows (``ros2 bag play --rate``).
*Loop.*  With ``loop`` the bag starts again after its last message, shifted by its
duration plus the mean message gap; header stamps are not rewritten (as with
``ros2 bag play --loop``).  Reading is streamed: one message is scheduled at a time.
Latched topics (transient local in the bag) are published latched.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from navstack.runtime.bus import DEFAULT_QOS, Publisher, QoS
from navstack.runtime.node import Runtime
from navstack.runtime.recording.reader import BagMessage, BagReader
from navstack.runtime.scheduler import Scheduler


def runtime_for_bag(path: str | Path, rate: float | None = None) -> Runtime:
    """A fresh runtime whose simulated clock starts at the bag's first message and runs at
    ``rate`` x real time (``None``: as fast as possible)."""
    with BagReader(path) as bag:
        start = bag.start_time
    return Runtime(Scheduler("sim", start_time=start, rate=rate))


class BagPlayer:
    """Plays ``path`` onto ``runtime``'s bus; :meth:`start`, then run the scheduler."""

    def __init__(self, runtime: Runtime, path: str | Path, topics: Iterable[str] | None = None,
                 *, loop: bool = False, max_loops: int | None = None) -> None:
        self.runtime = runtime
        self.path = Path(path)
        self.topics = list(topics) if topics is not None else None
        self.loop = loop
        self.max_loops = max_loops
        self.counts: dict[str, int] = {}
        self.loops_done = 0
        self.finished = False
        self._reader = BagReader(self.path).open()
        info = self._reader.topics()
        self._latched = {name for name, t in info.items() if t.latched}
        self._start = self._reader.start_time
        self._duration = self._reader.end_time - self._start
        self._gap = self._mean_gap(info)
        self._publishers: dict[str, Publisher[Any]] = {}
        self._iter: Iterator[BagMessage] | None = None
        self._offset = 0.0

    def _mean_gap(self, info: dict[str, Any]) -> float:
        played = [t for name, t in info.items() if t.convertible
                  and (self.topics is None or name in self.topics)]
        count = sum(t.count for t in played)
        return self._duration / (count - 1) if count > 1 and self._duration > 0 else 1e-3

    # --- control ----------------------------------------------------------------------------
    def start(self) -> None:
        """Begin playing: the first message is due now."""
        self._offset = self.runtime.scheduler.now - self._start
        self._iter = self._reader.messages(self.topics)
        self._schedule_next()

    def stop(self) -> None:
        """Stop playing (pending message dropped) and release the bag."""
        self.finished = True
        self._iter = None
        self._reader.close()

    @property
    def end_time(self) -> float:
        """Scheduler time of the last message of the current pass."""
        return self._offset + self._start + self._duration

    def run(self, until: float | None = None) -> dict[str, int]:
        """Start and run the scheduler until the bag (all loops) is played or the clock
        reaches ``until``; returns the messages published per topic."""
        if self._iter is None and not self.finished:
            self.start()
        sched = self.runtime.scheduler
        sched.run_until(until if until is not None else float("inf"),
                        until=lambda: self.finished)
        sched.run_until(sched.now)  # deliver what the last messages started
        return dict(self.counts)

    # --- playing ----------------------------------------------------------------------------
    def _schedule_next(self) -> None:
        it = self._iter
        if it is None:
            return
        item = next(it, None)
        if item is None:
            self.loops_done += 1
            more = self.loop and (self.max_loops is None or self.loops_done < self.max_loops)
            if not more:
                self.stop()
                return
            self._offset += self._duration + self._gap
            self._iter = it = self._reader.messages(self.topics)
            item = next(it, None)
            if item is None:
                self.stop()
                return
        self.runtime.scheduler.call_at(self._offset + item.log_time, self._publish, item)

    def _publish(self, item: BagMessage) -> None:
        if self.finished:
            return
        pub = self._publishers.get(item.topic)
        if pub is None:
            qos = QoS(depth=1, latched=True) if item.topic in self._latched else DEFAULT_QOS
            pub = self.runtime.bus.publisher(item.topic, type(item.msg), qos)
            self._publishers[item.topic] = pub
        pub.publish(item.msg)
        self.counts[item.topic] = self.counts.get(item.topic, 0) + 1
        self._schedule_next()
