"""Recover the readable part of a truncated MCAP file (a recording killed mid-write).

An MCAP file ends with a summary section and a footer; a process killed with SIGKILL, a
power cut or a full disk leaves the data section cut off somewhere, and readers that
start from the footer (rosbags, ``ros2 bag``) refuse the whole file.  The data section
itself is a plain sequence of records (``opcode u8, length u64, body``; MCAP spec), so
everything before the cut can be read front to back: schemas, channels and messages,
also inside complete chunks (rosbags writes schemas and channels into chunks).  The
messages of the chunk being written at the cut were never on disk and are lost.

:func:`recover_mcap` copies what is readable, byte for byte (CDR payloads are not
decoded), into a new rosbag2 folder with QoS and message definitions intact.
``navstack bag recover BROKEN --out FIXED`` runs it.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

from rosbags.interfaces import Connection
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
from rosbags.rosbag2.storage_mcap import DECOMPRESSORS, get_qos
from rosbags.typesys import TypesysError, get_types_from_msg

from navstack.runtime.recording.convert import humble_typestore
from navstack.runtime.recording.errors import BagError, BagFormatError, BagNotFoundError
from navstack.runtime.recording.writer import BAG_VERSION, prepare_output

MAGIC = b"\x89MCAP0\r\n"
_SCHEMA, _CHANNEL, _MESSAGE, _CHUNK, _DATA_END, _FOOTER = 0x03, 0x04, 0x05, 0x06, 0x0F, 0x02
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_MSG_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time


@dataclass
class RecoveryReport:
    """What :func:`recover_mcap` found: messages per topic, where it stopped and why."""

    source: Path
    out: Path
    counts: dict[str, int] = field(default_factory=dict)
    bytes_read: int = 0
    file_size: int = 0
    complete: bool = False
    stopped: str = ""
    skipped: dict[str, str] = field(default_factory=dict)

    @property
    def messages(self) -> int:
        return sum(self.counts.values())


@dataclass
class _Scan:
    schemas: dict[int, tuple[str, str, str]] = field(default_factory=dict)
    channels: dict[int, tuple[str, int, str, bytes]] = field(default_factory=dict)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)


def _string(buf: memoryview, pos: int) -> tuple[str, int]:
    (n,) = _U32.unpack_from(buf, pos)
    end = pos + 4 + n
    if end > len(buf):
        raise ValueError("string runs past the record")
    return bytes(buf[pos + 4:end]).decode("utf-8"), end


def _records(buf: memoryview, scan: _Scan, in_chunk: bool) -> tuple[int, str, bool]:
    """Parse records from ``buf``; returns (bytes consumed, why it stopped, footer seen)."""
    pos = 0
    while pos < len(buf):
        if pos + 9 > len(buf):
            return pos, f"a record header is cut off at byte {pos}", False
        op = buf[pos]
        (length,) = _U64.unpack_from(buf, pos + 1)
        body_start, body_end = pos + 9, pos + 9 + length
        if body_end > len(buf):
            why = f"a record (opcode 0x{op:02x}, {length} bytes) is cut off at byte {pos}"
            if op == _CHUNK and not in_chunk:
                why = f"the chunk at byte {pos} is cut off" + _partial_chunk(
                    buf[body_start:], scan)
            return pos, why, False
        body = buf[body_start:body_end]
        try:
            _record(op, body, scan)
        except (ValueError, struct.error, KeyError, UnicodeDecodeError) as exc:
            return pos, f"a damaged record (opcode 0x{op:02x}) at byte {pos}: {exc}", False
        pos = body_end
        if not in_chunk and op in (_DATA_END, _FOOTER):
            return pos, "", True
    return pos, "", False


def _record(op: int, body: memoryview, scan: _Scan) -> None:
    if op == _SCHEMA:
        (sid,) = _U16.unpack_from(body, 0)
        name, pos = _string(body, 2)
        encoding, pos = _string(body, pos)
        (n,) = _U32.unpack_from(body, pos)
        scan.schemas[sid] = (name, encoding, bytes(body[pos + 4:pos + 4 + n]).decode())
    elif op == _CHANNEL:
        cid, sid = struct.unpack_from("<HH", body, 0)
        topic, pos = _string(body, 4)
        encoding, pos = _string(body, pos)
        (n,) = _U32.unpack_from(body, pos)
        scan.channels[cid] = (topic, sid, encoding, bytes(body[pos + 4:pos + 4 + n]))
    elif op == _MESSAGE:
        cid, _seq, log_time, _pub = _MSG_HEAD.unpack_from(body, 0)
        scan.messages.append((cid, log_time, bytes(body[_MSG_HEAD.size:])))
    elif op == _CHUNK:
        _start, _end, size, _crc = struct.unpack_from("<QQQI", body, 0)
        compression, pos = _string(body, 28)
        (n,) = _U64.unpack_from(body, pos)
        if compression not in DECOMPRESSORS:
            raise ValueError(f"unknown chunk compression '{compression}'")
        inner = DECOMPRESSORS[compression](bytes(body[pos + 8:pos + 8 + n]), size)
        _, why, _ = _records(memoryview(inner), scan, in_chunk=True)
        if why:
            raise ValueError(f"inside a chunk: {why}")


def _partial_chunk(body: memoryview, scan: _Scan) -> str:
    """Read the complete records at the start of a cut-off uncompressed chunk."""
    try:
        compression, pos = _string(body, 28)
    except (ValueError, struct.error):
        return ""
    if compression or pos + 8 > len(body):
        return ""  # a compressed stream cannot be read in part
    before = len(scan.messages)
    _records(body[pos + 8:], scan, in_chunk=True)
    return f" ({len(scan.messages) - before} messages read from its complete part)"


def _mcap_file(path: Path) -> Path:
    if not path.exists():
        raise BagNotFoundError(str(path))
    if path.is_dir():
        files = sorted(path.glob("*.mcap"))
        if len(files) != 1:
            raise BagFormatError(f"{path}: expected one .mcap file in the folder, found "
                                 f"{len(files)}; give the .mcap file itself")
        return files[0]
    if path.suffix != ".mcap":
        raise BagFormatError(f"{path}: only MCAP files can be recovered (a .mcap file or a "
                             f"rosbag2 folder holding one)")
    return path


def recover_mcap(source: str | Path, out: str | Path, *, replace: bool = False
                 ) -> RecoveryReport:
    """Copy every complete message of the (possibly truncated) MCAP ``source`` into a new
    rosbag2 folder ``out``; raises :class:`BagError` naming the file if nothing is
    readable."""
    src = _mcap_file(Path(source))
    data = src.read_bytes()
    report = RecoveryReport(Path(source), Path(out), file_size=len(data))
    if not data.startswith(MAGIC):
        raise BagFormatError(f"{src}: not an MCAP file (no MCAP magic at the start)")
    scan = _Scan()
    used, why, footer = _records(memoryview(data)[len(MAGIC):], scan, in_chunk=False)
    report.bytes_read = len(MAGIC) + used
    report.complete = footer
    report.stopped = why or ("" if footer else "the file ends without a footer")
    if not scan.messages:
        raise BagFormatError(f"{src}: no complete message before the cut ({report.stopped}); "
                             f"nothing to recover")
    prepare_output(report.out, replace)
    writer = Writer(report.out, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
    try:
        writer.open()
        writer.set_custom_data("navstack.recovered_from", str(src))
        conns = _connections(writer, scan, report)
        for cid, log_time, payload in sorted(scan.messages, key=lambda m: m[1]):
            conn = conns.get(cid)
            if conn is None:
                continue
            writer.write(conn, log_time, payload)
            report.counts[conn.topic] = report.counts.get(conn.topic, 0) + 1
        writer.close()
    except (WriterError, OSError) as exc:
        raise BagError(f"{report.out}: cannot write the recovered bag ({exc})") from None
    return report


def _connections(writer: Writer, scan: _Scan, report: RecoveryReport
                 ) -> dict[int, Connection]:
    store = humble_typestore()
    conns: dict[int, Connection] = {}
    for cid, (topic, sid, encoding, metadata) in sorted(scan.channels.items()):
        schema = scan.schemas.get(sid)
        if schema is None or encoding != "cdr":
            report.skipped[topic] = ("no schema before the cut" if schema is None
                                     else f"message encoding '{encoding}' is not CDR")
            continue
        msgtype, schema_encoding, msgdef = schema
        try:
            if msgtype not in store.fielddefs:
                if schema_encoding != "ros2msg":
                    report.skipped[topic] = f"unknown type {msgtype} ({schema_encoding})"
                    continue
                store.register(get_types_from_msg(msgdef, msgtype))
            conns[cid] = writer.add_connection(
                topic, msgtype, typestore=store, serialization_format="cdr",
                offered_qos_profiles=get_qos(metadata))
        except (TypesysError, ValueError, KeyError) as exc:
            report.skipped[topic] = f"cannot rebuild its connection ({exc})"
    return conns
