"""``BagReader``: read ROS 2 (MCAP / sqlite3) and ROS 1 bags as navstack messages.

A thin layer over ``rosbags.highlevel.AnyReader``: it accepts a rosbag2 folder, a bare
``.mcap`` / ``.db3`` file or a ROS 1 ``.bag``, turns every failure into one
:class:`~navstack.runtime.recording.errors.BagError` line naming the file, and converts
messages with :class:`~navstack.runtime.recording.convert.RosCodec` (ROS 1 messages use
the same field names, so the same functions apply).  Messages come in log-time order.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection, ConnectionExtRosbag1, QosDurability

from navstack.runtime.recording.convert import (
    BY_ROS_TYPE,
    ROS_TYPE_ALIASES,
    RosCodec,
    humble_typestore,
)
from navstack.runtime.recording.errors import (
    BagFormatError,
    BagNotFoundError,
    UnsupportedTypeError,
)
from navstack.runtime.recording.rostime import from_ns

_KNOWN_SUFFIXES = {".bag", ".mcap", ".db3"}


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a bag: ROS type, message count, latched (transient local) or not."""

    name: str
    ros_type: str
    count: int
    latched: bool
    convertible: bool


@dataclass(frozen=True)
class BagMessage:
    """A converted message with its bag (log) time [s]."""

    topic: str
    log_time: float
    msg: Any


def resolve_bag_path(path: str | Path) -> Path:
    """The path rosbags should open, or a clear :class:`BagError` why there is none."""
    p = Path(path)
    if not p.exists():
        raise BagNotFoundError(str(p))
    if p.is_dir():
        if (p / "metadata.yaml").exists():
            return p
        storage = sorted(q for q in p.iterdir() if q.suffix in (".mcap", ".db3"))
        if len(storage) == 1:
            return storage[0]
        raise BagFormatError(f"{p}: folder has no metadata.yaml and "
                             f"{'several' if storage else 'no'} .mcap/.db3 files; give the "
                             f"rosbag2 folder or one storage file")
    if p.suffix not in _KNOWN_SUFFIXES:
        raise BagFormatError(f"{p}: unknown bag format '{p.suffix or p.name}' (expected a "
                             f"rosbag2 folder, .mcap, .db3 or a ROS 1 .bag)")
    return p


_MCAP_MAGIC = b"\x89MCAP0\r\n"


def truncated_mcap(source: Path) -> Path | None:
    """The MCAP file under ``source`` if it starts like one but does not end like one."""
    files = sorted(source.glob("*.mcap")) if source.is_dir() else [source]
    for f in files:
        if f.suffix != ".mcap" or not f.is_file():
            continue
        with f.open("rb") as fh:
            head = fh.read(len(_MCAP_MAGIC))
            size = fh.seek(0, 2)
            fh.seek(max(size - len(_MCAP_MAGIC), 0))
            tail = fh.read()
        if head == _MCAP_MAGIC and (size < 2 * len(_MCAP_MAGIC) or tail != _MCAP_MAGIC):
            return f
    return None


def _latched(conn: Connection) -> bool:
    ext = conn.ext
    if isinstance(ext, ConnectionExtRosbag1):
        return bool(ext.latching)
    return any(q.durability is QosDurability.TRANSIENT_LOCAL for q in ext.offered_qos_profiles)


class BagReader:
    """Open with ``with BagReader(path) as bag:``; see the module docstring."""

    def __init__(self, path: str | Path, codec: RosCodec | None = None) -> None:
        self.path = Path(path)
        self._source = resolve_bag_path(self.path)
        self.codec = codec or RosCodec()
        self._reader: AnyReader | None = None

    # --- lifecycle -------------------------------------------------------------------------
    def open(self) -> BagReader:
        try:
            reader = AnyReader([self._source], default_typestore=humble_typestore())
            reader.open()
        except AnyReaderError as exc:
            cut = truncated_mcap(self._source)
            if cut is not None:
                raise BagFormatError(
                    f"{self.path}: the MCAP file {cut.name} is truncated (no summary and "
                    f"footer: the recording was cut off, e.g. killed or out of disk); recover "
                    f"its readable messages with `navstack bag recover {self.path} --out "
                    f"FIXED`") from None
            raise BagFormatError(f"{self.path}: not a readable bag ({exc})") from None
        except (OSError, ValueError, KeyError) as exc:
            raise BagFormatError(f"{self.path}: cannot open the bag ({exc})") from None
        self._reader = reader
        return self

    def close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    def __enter__(self) -> BagReader:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def reader(self) -> AnyReader:
        if self._reader is None:
            self.open()
        assert self._reader is not None
        return self._reader

    # --- metadata ---------------------------------------------------------------------------
    @property
    def is_ros1(self) -> bool:
        return not self.reader.is2

    @property
    def start_time(self) -> float:
        """Log time of the first message [s] (0 for an empty bag)."""
        r = self.reader
        return from_ns(r.start_time) if r.message_count else 0.0

    @property
    def end_time(self) -> float:
        """Log time of the last message [s]."""
        r = self.reader
        return from_ns(r.end_time - 1) if r.message_count else 0.0

    @property
    def message_count(self) -> int:
        return int(self.reader.message_count)

    def topics(self) -> dict[str, TopicSummary]:
        out: dict[str, TopicSummary] = {}
        for conn in self.reader.connections:
            prev = out.get(conn.topic)
            ros_type = ROS_TYPE_ALIASES.get(conn.msgtype, conn.msgtype)
            count = conn.msgcount + (prev.count if prev else 0)
            out[conn.topic] = TopicSummary(conn.topic, conn.msgtype, count,
                                           _latched(conn) or bool(prev and prev.latched),
                                           ros_type in BY_ROS_TYPE)
        return dict(sorted(out.items()))

    # --- messages ---------------------------------------------------------------------------
    def _connections(self, topics: Iterable[str] | None) -> list[Connection]:
        conns = self.reader.connections
        if topics is None:
            return [c for c in conns
                    if ROS_TYPE_ALIASES.get(c.msgtype, c.msgtype) in BY_ROS_TYPE]
        wanted = set(topics)
        chosen = [c for c in conns if c.topic in wanted]
        for c in chosen:  # a topic asked for by name must convert: say which does not
            try:
                self.codec.conversion_from(c.msgtype, c.topic)
            except UnsupportedTypeError as exc:
                raise UnsupportedTypeError(f"{self.path}: {exc}") from None
        return chosen

    def messages(self, topics: Iterable[str] | None = None, start: float | None = None,
                 stop: float | None = None) -> Iterator[BagMessage]:
        """Converted messages in log-time order.

        ``topics``: names to read (missing names are simply absent -- check
        :meth:`topics`); ``None`` reads every topic with a convertible type.  A named topic
        whose type does not convert raises :class:`UnsupportedTypeError` before anything
        is read.  ``start``/``stop`` bound the log time [s] (``stop`` exclusive).
        """
        conns = self._connections(topics)  # checked now, not at the first next()
        return self._iterate(conns, start, stop)

    def _iterate(self, conns: list[Connection], start: float | None,
                 stop: float | None) -> Iterator[BagMessage]:
        if not conns:
            return
        reader = self.reader
        lo = None if start is None else round(start * 1e9)
        hi = None if stop is None else round(stop * 1e9)
        codec = self.codec
        for conn, stamp, raw in reader.messages(connections=conns, start=lo, stop=hi):
            try:
                obj = reader.deserialize(raw, conn.msgtype)
            except AnyReaderError as exc:
                raise BagFormatError(f"{self.path}: topic '{conn.topic}': cannot decode a "
                                     f"{conn.msgtype} message ({exc})") from None
            yield BagMessage(conn.topic, from_ns(stamp),
                             codec.from_ros(conn.msgtype, obj, conn.topic))
