"""``import_bag``: a ROS 1 or ROS 2 bag into a navstack rosbag2 (MCAP, ROS 2 Humble types).

Reads anything :class:`~navstack.runtime.recording.reader.BagReader` opens (ROS 1
``.bag``, rosbag2 MCAP or sqlite3), converts each message to its navstack type and writes
it back as the ROS 2 Humble message (so ROS 1 ``tf/tfMessage`` becomes
``tf2_msgs/msg/TFMessage``, headers lose ``seq``, frame ids their leading ``/``), keeping
topic names, log times and latching (``transient_local``).  The result plays with
:class:`BagPlayer`, feeds ``navstack bag slam`` and ``navstack report``, and opens in
Foxglove.  By default every topic with a convertible type is imported and the rest are
listed as skipped; topics asked for by name must exist and convert.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from navstack.runtime.recording.errors import BagError, BagFormatError
from navstack.runtime.recording.reader import BagReader
from navstack.runtime.recording.writer import BagSummary, BagWriter


@dataclass
class ImportResult:
    """The written bag's summary, the source path and whether it was a ROS 1 bag."""

    source: Path
    ros1: bool
    summary: BagSummary


def import_bag(source: str | Path, out: str | Path, topics: Iterable[str] | None = None, *,
               storage: str = "mcap", replace: bool = False) -> ImportResult:
    """Convert ``source`` into a rosbag2 folder at ``out`` (module docstring)."""
    src = Path(source)
    with BagReader(src) as bag:
        info = bag.topics()
        if topics is not None:
            chosen = list(dict.fromkeys(topics))
            missing = [t for t in chosen if t not in info]
            if missing:
                raise BagFormatError(f"{src}: no topic {', '.join(missing)} in the bag "
                                     f"(it has: {', '.join(info) or 'nothing'})")
            skipped: dict[str, str] = {}
        else:
            chosen = [t for t, s in info.items() if s.convertible]
            skipped = {t: f"type {s.ros_type} has no navstack conversion"
                       for t, s in info.items() if not s.convertible}
        if not chosen:
            found = ", ".join(f"{t} [{s.ros_type}]" for t, s in info.items()) or "nothing"
            raise BagFormatError(f"{src}: no topic with a convertible type (found {found}); "
                                 f"nothing to import")
        messages = bag.messages(chosen)  # named topics of unconvertible types fail here
        writer = BagWriter(out, storage=storage, replace=replace)
        try:
            for item in messages:
                writer.write(item.topic, item.msg, item.log_time, info[item.topic].latched)
        except BagError:
            writer.abort()
            raise
        summary = writer.close()
        summary.skipped.update(skipped)
        return ImportResult(src, bag.is_ros1, summary)
