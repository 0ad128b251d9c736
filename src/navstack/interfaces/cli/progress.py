"""Progress of long commands (``navstack slam``, ``bag slam``, ``bench``).

On a terminal a rich progress bar per stage (transient: it disappears when done, the
command's own summary stays); otherwise -- a log file, CI, a pipe -- one line per stage
when it ends, ``slam: mapping 13631/13631 in 41.2 s``, so logs stay short.  Progress
goes to stderr; results go to stdout.
"""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import IO, Any


class StageProgress:
    """A ``progress(stage, done, total)`` callback; use it as a context manager."""

    def __init__(self, title: str, stream: IO[str] | None = None,
                 tty: bool | None = None) -> None:
        self.title = title
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty() if tty is None else tty
        self._stage: tuple[str, int, int, float] | None = None
        self._bar: Any = None
        self._task: Any = None
        self.lines: list[str] = []
        #: seconds between two detail lines when not on a terminal
        self.detail_period = 10.0
        self._detail = ""
        self._detail_shown = time.perf_counter()

    def __enter__(self) -> StageProgress:
        if self.tty:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self._bar = Progress(TextColumn("{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TimeElapsedColumn(),
                                 console=Console(file=self.stream), transient=True)
            self._bar.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if exc_type is None:
            self._finish_stage()
        if self._bar is not None:
            self._bar.stop()

    def __call__(self, stage: str, done: int, total: int) -> None:
        current = self._stage
        if current is None or current[0] != stage:
            self._finish_stage()
            self._stage = (stage, done, total, time.perf_counter())
            if self._bar is not None:
                self._task = self._bar.add_task(f"{self.title}: {stage}", total=total,
                                                completed=done)
            return
        self._stage = (stage, done, total, current[3])
        if self._bar is not None:
            self._bar.update(self._task, completed=done, total=total)

    def detail(self, text: str) -> None:
        """What the current stage is doing (``navstack slam``: scans, nodes, loop closures,
        ms per scan): shown beside the bar on a terminal; otherwise a line ``  <text>``
        at most every :attr:`detail_period` seconds, and the last one is appended to the
        stage's line when it ends."""
        self._detail = text
        if self._bar is not None:
            if self._task is not None and self._stage is not None:
                self._bar.update(self._task,
                                 description=f"{self.title}: {self._stage[0]} ({text})")
            return
        now = time.perf_counter()
        if now - self._detail_shown >= self.detail_period:
            self._detail_shown = now
            self.stream.write(f"  {text}\n")
            self.stream.flush()

    def _finish_stage(self) -> None:
        if self._stage is None:
            return
        stage, done, total, t0 = self._stage
        self._stage = None
        count = f" {done}/{total}" if total > 1 else ""
        line = f"{self.title}: {stage}{count} in {time.perf_counter() - t0:.1f} s"
        if self._detail:
            line += f" ({self._detail})"
            self._detail = ""
        self.lines.append(line)
        if self._bar is None:
            self.stream.write(line + "\n")
            self.stream.flush()
