"""rosbags' rosbag2 writer with a leaner per-message path for MCAP storage.

rosbags writes each MCAP message record with a fresh ``BytesIO`` and five small writes,
and checks on every call that the connection belongs to the bag; for the 60 000+
messages of a demo recording that is about half of the recorder's cost.
:class:`FastMcapWriter` packs the record header (opcode, length, channel, sequence, log
and publish time) with one ``struct`` call -- the same bytes, the same chunk index and
statistics as ``McapWriter.write`` -- and :class:`FastWriter` skips the membership check
(callers only pass connections it returned).  Everything else (schemas, channels,
chunking at 1 MiB, the summary section, metadata.yaml) is rosbags' own code; the
recording tests read every bag back with rosbags.  Written against rosbags 0.11.
"""

from __future__ import annotations

import struct
from types import MappingProxyType

from rosbags.interfaces import Connection
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import McapWriter

_MESSAGE_OP = 0x05
_HEAD = struct.Struct("<BQHIQQ")  # opcode, record length, channel id, sequence, log, publish
_FIXED = _HEAD.size - 9  # record fields before the payload (after opcode and length)
_CHUNK_LIMIT = 2**20  # McapWriter's chunk size


class FastMcapWriter(McapWriter):
    """``McapWriter`` whose ``write`` packs the message record header in one call."""

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        if timestamp < self.message_start_time:
            self.message_start_time = timestamp
        if timestamp > self.message_end_time:
            self.message_end_time = timestamp
        cid = connection.id
        self.channel_stats[cid] += 1
        chunk = self.chunk
        if timestamp < chunk.message_start_time:
            chunk.message_start_time = timestamp
        if timestamp > chunk.message_end_time:
            chunk.message_end_time = timestamp
        bio = chunk.bio
        chunk.msgs[cid].append((timestamp, bio.tell()))
        bio.write(_HEAD.pack(_MESSAGE_OP, _FIXED + len(data), cid, 0, timestamp, timestamp))
        bio.write(data)
        if bio.tell() > _CHUNK_LIMIT:
            self.close_chunk()


class FastWriter(Writer):
    """rosbag2 ``Writer`` using :class:`FastMcapWriter`; ``write`` trusts its caller to
    pass a connection this writer created (no compression per message: none is set)."""

    STORAGE_PLUGINS = MappingProxyType({**Writer.STORAGE_PLUGINS,
                                        StoragePlugin.MCAP: FastMcapWriter})

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        storage = self.storage
        assert storage is not None
        storage.write(connection, timestamp, data)
        self.counts[connection.id] += 1
        if timestamp < self.min_timestamp:
            self.min_timestamp = timestamp
        if timestamp > self.max_timestamp:
            self.max_timestamp = timestamp
