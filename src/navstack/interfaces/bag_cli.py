"""The work behind ``navstack replay`` and ``navstack bag info``, kept out of ``cli.py``.

``replay`` plays a bag onto a fresh runtime (:class:`BagPlayer`, clock starting at the
bag's first message, ``rate`` x real time) and can echo topics as one line per message:
the log time, the type and the message's fields with arrays shown as their shape and
range (``ranges[360] 0.12..9.8``), cut to the terminal width.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from navstack.core.errors import UnknownNameError
from navstack.runtime.recording import BagPlayer, BagReader, runtime_for_bag


def _value(v: Any, depth: int) -> str:
    if isinstance(v, np.ndarray):
        finite = v[np.isfinite(v)] if v.dtype.kind == "f" else v.reshape(-1)
        span = f" {finite.min():.4g}..{finite.max():.4g}" if finite.size else ""
        return f"[{'x'.join(str(n) for n in v.shape)}]{span}"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, tuple | list):
        if len(v) > 3:
            return f"[{len(v)} items]"
        return "[" + ", ".join(_value(x, depth + 1) for x in v) + "]"
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        if depth > 2:
            return type(v).__name__
        return "{" + " ".join(f"{f.name}={_value(getattr(v, f.name), depth + 1)}"
                              for f in dataclasses.fields(v) if not f.name.startswith("_")) + "}"
    if isinstance(v, bytes):
        return v.hex()
    return str(v)


def format_message(topic: str, msg: Any, now: float, width: int = 200) -> str:
    """One line: ``[t] topic Type field=value ...`` cut to ``width`` characters."""
    line = f"[{now:.3f}] {topic} {type(msg).__name__} {_value(msg, 0)}"
    return line if len(line) <= width else line[:width - 3] + "..."


def info_lines(path: str | Path) -> list[str]:
    """``ros2 bag info``-like lines: span, messages, then one line per topic."""
    with BagReader(path) as bag:
        topics = bag.topics()
        lines = [f"bag:      {path} ({'ROS 1' if bag.is_ros1 else 'ROS 2'})",
                 f"span:     {bag.start_time:.3f} .. {bag.end_time:.3f} s "
                 f"({bag.end_time - bag.start_time:.3f} s)",
                 f"messages: {bag.message_count}", "topics:"]
    for t in topics.values():
        flags = ", latched" if t.latched else ""
        conv = "" if t.convertible else "  (no navstack conversion)"
        lines.append(f"  {t.name:40s} {t.ros_type:40s} {t.count:8d}{flags}{conv}")
    return lines


def replay(path: str | Path, rate: float | None = 1.0, loop: bool = False,
           topics: Iterable[str] | None = None, echo: Iterable[str] = (),
           duration: float | None = None,
           emit: Callable[[str], None] = print) -> tuple[dict[str, int], int]:
    """Play ``path``; echo the ``echo`` topics through ``emit``.  Returns the messages
    played per topic and the number of completed passes.  ``duration`` [s of bag time]
    ends the playback (the way to end ``loop``); Ctrl-C ends it too.  A topic name not in
    the bag raises :class:`UnknownNameError` (with a "did you mean")."""
    chosen = list(topics) if topics is not None else None
    echoed = set(echo)
    with BagReader(path) as bag:
        known = bag.topics()
    for name in [*(chosen or ()), *sorted(echoed)]:
        if name not in known:  # a typo would otherwise play or print nothing, silently
            raise UnknownNameError("topic", name, known)
    runtime = runtime_for_bag(path, rate)
    player = BagPlayer(runtime, path, chosen, loop=loop)
    if echoed:
        runtime.bus.add_tap(lambda topic, msg, now: emit(format_message(topic, msg, now))
                            if topic in echoed else None)
    start = runtime.now
    try:
        player.run(until=None if duration is None else start + duration)
    except KeyboardInterrupt:
        player.stop()
    return dict(player.counts), player.loops_done
