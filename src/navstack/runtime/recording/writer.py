"""``BagWriter``: navstack messages into a rosbag2 folder (MCAP or sqlite3 storage, CDR).

Shared by :class:`~navstack.runtime.recording.recorder.BagRecorder` (live bus) and
:func:`~navstack.runtime.recording.importer.import_bag` (bag conversion).  A topic's
connection is created on its first message with the ROS 2 type, the message definition
and hash from the Humble typestore, and the offered QoS (``transient_local`` for latched
topics).  rosbag2 metadata version 8 is written (``ros2 bag`` since Iron reads it;
Foxglove and rosbags read the MCAP file directly).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, WriterError

from navstack.runtime.recording.cdr import FAST_ENCODERS
from navstack.runtime.recording.convert import RosCodec
from navstack.runtime.recording.errors import BagError, BagExistsError
from navstack.runtime.recording.mcap_fast import FastWriter
from navstack.runtime.recording.rostime import to_ns

BAG_VERSION: Final = 8
STORAGES = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
_BAG_FILES = {".mcap", ".db3", ".yaml"}
_ZERO = QosTime(sec=0, nsec=0)

Route = tuple[Connection, Callable[[Any], bytes]]


def offered_qos(latched: bool, depth: int = 10) -> Qos:
    """The QoS profile stored for a topic (rosbag2 ``offered_qos_profiles``): reliable,
    keep_last(``depth``), transient_local when ``latched`` else volatile."""
    return Qos(history=QosHistory.KEEP_LAST, depth=depth, reliability=QosReliability.RELIABLE,
               durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
               deadline=_ZERO, lifespan=_ZERO, liveliness=QosLiveliness.AUTOMATIC,
               liveliness_lease_duration=_ZERO, avoid_ros_namespace_conventions=False)


@dataclass
class BagSummary:
    """What a written bag holds: messages per topic, log-time span [s], skipped topics
    (name -> reason)."""

    path: Path
    counts: dict[str, int] = field(default_factory=dict)
    start_time: float | None = None
    end_time: float | None = None
    skipped: dict[str, str] = field(default_factory=dict)

    @property
    def messages(self) -> int:
        return sum(self.counts.values())


def prepare_output(path: Path, replace: bool) -> None:
    """Make room for a new bag folder at ``path``.  An existing folder is removed only if
    ``replace`` and it holds nothing but a bag (metadata.yaml and storage files)."""
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        return
    ours = path.is_dir() and (path / "metadata.yaml").exists() and all(
        p.is_file() and p.suffix in _BAG_FILES for p in path.iterdir())
    if not (replace and ours):
        raise BagExistsError(str(path), is_bag=ours)
    shutil.rmtree(path)


class BagWriter:
    """Open on construction; :meth:`write` navstack messages; :meth:`close` once."""

    def __init__(self, path: str | Path, *, storage: str = "mcap", replace: bool = False,
                 codec: RosCodec | None = None) -> None:
        self.path = Path(path)
        if storage not in STORAGES:
            raise BagError(f"storage '{storage}' is not supported; use 'mcap' or 'sqlite3'")
        self.codec = codec or RosCodec()
        self.summary = BagSummary(self.path)
        self.routes: dict[str, Route] = {}
        self.closed = False
        prepare_output(self.path, replace)
        self._writer = FastWriter(self.path, version=BAG_VERSION,
                                  storage_plugin=STORAGES[storage])
        try:
            self._writer.open()
        except (WriterError, OSError) as exc:
            raise BagError(f"{self.path}: cannot create the bag ({exc})") from None
        self._writer.set_custom_data("navstack.writer", "navstack")

    def route(self, topic: str, msg_type: type, latched: bool = False, depth: int = 10) -> Route:
        """The connection and encoder of ``topic`` (created on first use).  Raises
        :class:`UnsupportedTypeError` naming the topic if the type has no ROS 2 twin."""
        route = self.routes.get(topic)
        if route is None:
            ros_type = self.codec.ros_type(msg_type, topic)
            conn = self._writer.add_connection(
                topic, ros_type, typestore=self.codec.typestore,
                offered_qos_profiles=[offered_qos(latched, depth)])
            route = (conn, FAST_ENCODERS.get(msg_type) or self.codec.serialize)
            self.routes[topic] = route
            self.summary.counts[topic] = 0
        return route

    def write_routed(self, topic: str, route: Route, msg: Any, t: float) -> None:
        """Write ``msg`` through a route from :meth:`route` at log time ``t`` [s]."""
        conn, encode = route
        self._writer.write(conn, to_ns(t), encode(msg))
        summary = self.summary
        summary.counts[topic] += 1
        if summary.start_time is None:
            summary.start_time = t
        summary.end_time = t

    def write(self, topic: str, msg: Any, t: float, latched: bool = False) -> None:
        """Write ``msg`` on ``topic`` at log time ``t`` [s]."""
        if self.closed:
            raise BagError(f"{self.path}: the bag is closed; cannot write {topic}")
        route = self.routes.get(topic) or self.route(topic, type(msg), latched,
                                                     1 if latched else 10)
        self.write_routed(topic, route, msg, t)

    def close(self) -> BagSummary:
        """Write the index and metadata.yaml; returns the summary (idempotent)."""
        if not self.closed:
            self.closed = True
            self._writer.close()
        return self.summary

    def abort(self) -> None:
        """Close without caring whether the bag is complete (after an error)."""
        if not self.closed:
            self.closed = True
            try:
                self._writer.close()
            except (WriterError, OSError, AssertionError):
                return
