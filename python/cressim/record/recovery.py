"""Recovering a bag whose recorder died (SIGKILL, power loss, disk full).

A crashed recorder leaves BAG/BAG_0.mcap without summary and footer, possibly ending in a
half-written chunk, and no metadata.yaml. ``recover(BAG)`` walks the file record by record
from the start, keeps every complete record whose CRC checks (every closed chunk: with
BagWriter that is every message handed over more than max_chunk_age before the crash),
stops at the first truncated or damaged one, and re-writes what it kept into a new, complete
MCAP file (summary, chunk indexes, statistics) plus metadata.yaml. The damaged original is
kept beside it as BAG_0.mcap.crashed unless ``keep_original=False``.

    cressim record --recover BAG
"""
from __future__ import annotations

import io
import os
import struct
from pathlib import Path
from typing import NamedTuple

from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import breakup_chunk
from ruamel.yaml import YAML

from .writer import BagCore, mcap_path, write_metadata_yaml

MAGIC = b"\x89MCAP0\r\n"
OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_DATA_END, OP_FOOTER = 0x03, 0x04, 0x05, 0x06, 0x0F, 0x02
_KNOWN_OPCODES = set(range(0x01, 0x10))


class RecoveryReport(NamedTuple):
    bag: str
    file: str  # the repaired MCAP file
    original: str | None  # where the damaged file was kept (None: nothing was repaired, or not kept)
    repaired: bool  # False: the bag was complete already
    messages: int
    chunks_read: int
    topics: dict  # topic -> messages recovered
    stop_reason: str  # why scanning stopped: "complete", "truncated record at N", "bad chunk at N: ..."
    bytes_lost: int  # bytes after the last good record


def is_complete(path: str | os.PathLike) -> bool:
    """True when an MCAP file ends with a footer and its summary can be read."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            f.seek(0, io.SEEK_END)
            if f.tell() < 2 * len(MAGIC) + 29:
                return False
            f.seek(-len(MAGIC), io.SEEK_END)
            if f.read(len(MAGIC)) != MAGIC:
                return False
            f.seek(0)
            return make_reader(f).get_summary() is not None
    except Exception:
        return False


def _find_mcap(bag: Path) -> Path:
    if bag.is_file():
        raise ValueError(f"{bag}: give the bag directory, not the .mcap file")
    candidate = mcap_path(bag)
    if candidate.is_file():
        return candidate
    files = sorted(bag.glob("*.mcap"))
    if len(files) != 1:
        raise FileNotFoundError(f"{bag}: expected one .mcap file, found {[f.name for f in files]}")
    return files[0]


def needs_recovery(bag: str | os.PathLike) -> bool:
    """True when the bag lacks metadata.yaml or its MCAP file is incomplete."""
    bag = Path(bag)
    return not (bag / "metadata.yaml").is_file() or not is_complete(_find_mcap(bag))


def _qos_of(channel: Channel):
    text = channel.metadata.get("offered_qos_profiles", "")
    if not text:
        return None
    try:
        value = YAML(typ="safe").load(text)
        return value if isinstance(value, list) else None
    except Exception:
        return None


def scan_records(path: str | os.PathLike):
    """Yield (kind, record) for the data section of a possibly truncated MCAP file.

    kind is "schema", "channel", "message" or "chunk" (a marker after each complete chunk's
    records). Ends with ("end", (reason, good_offset)): reason "complete" when the data
    section ended normally, else why it stopped; good_offset is the end of the last good record.
    """
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            yield "end", ("not an MCAP file (bad magic)", 0)
            return
        pos = len(MAGIC)
        while True:
            if pos + 9 > size:
                yield "end", ("complete" if pos == size else f"truncated record header at {pos}", pos)
                return
            f.seek(pos)
            opcode, length = struct.unpack("<BQ", f.read(9))
            if opcode not in _KNOWN_OPCODES:
                yield "end", (f"invalid opcode {opcode:#x} at {pos}", pos)
                return
            if pos + 9 + length > size:
                yield "end", (f"truncated record (opcode {opcode:#x}) at {pos}", pos)
                return
            body = f.read(length)
            stream = ReadDataStream(io.BytesIO(body))
            try:
                if opcode == OP_CHUNK:
                    records = breakup_chunk(Chunk.read(stream), validate_crc=True)
                elif opcode == OP_SCHEMA:
                    records = [Schema.read(stream)]
                elif opcode == OP_CHANNEL:
                    records = [Channel.read(stream)]
                elif opcode == OP_MESSAGE:
                    records = [Message.read(stream, length)]
                else:
                    records = []
            except Exception as exc:
                yield "end", (f"bad record (opcode {opcode:#x}) at {pos}: {exc!r}", pos)
                return
            for record in records:
                if isinstance(record, Schema):
                    yield "schema", record
                elif isinstance(record, Channel):
                    yield "channel", record
                elif isinstance(record, Message):
                    yield "message", record
            if opcode == OP_CHUNK:
                yield "chunk", None
            pos += 9 + length
            if opcode in (OP_DATA_END, OP_FOOTER):
                yield "end", ("complete", pos)
                return


def recover(bag: str | os.PathLike, *, keep_original: bool = True, force: bool = False) -> RecoveryReport:
    """Rebuild a readable bag (complete MCAP + metadata.yaml) from what a crashed recorder left.

    Does nothing to a complete bag unless force. Returns what was recovered."""
    bag = Path(bag)
    src = _find_mcap(bag)
    if not force and not needs_recovery(bag):
        return RecoveryReport(str(bag), str(src), None, False, 0, 0, {}, "complete", 0)
    tmp_name = src.name + ".recovering"
    (bag / tmp_name).unlink(missing_ok=True)
    core = BagCore(bag, file_name=tmp_name, existing_dir=True, max_chunk_age=float("inf"))
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    chunks = 0
    skipped = 0
    reason, good = "complete", 0
    try:
        for kind, record in scan_records(src):
            if kind == "schema":
                schemas[record.id] = record
            elif kind == "channel":
                channels[record.id] = record
            elif kind == "chunk":
                chunks += 1
            elif kind == "message":
                channel = channels.get(record.channel_id)
                schema = schemas.get(channel.schema_id) if channel else None
                if schema is None:
                    skipped += 1
                    continue
                if channel.topic not in core.topics:
                    core.add_topic(channel.topic, schema.name, qos=_qos_of(channel),
                                   msgdef=schema.data.decode(),
                                   type_hash=channel.metadata.get("topic_type_hash") or None)
                core.write(channel.topic, schema.name, record.data, record.log_time, record.publish_time)
            elif kind == "end":
                reason, good = record
        metadata = core.close(write_yaml=False, relative_path=src.name)
    except BaseException:
        core.abort()
        (bag / tmp_name).unlink(missing_ok=True)
        raise
    lost = src.stat().st_size - good
    original = None
    if keep_original:
        original = src.with_name(src.name + ".crashed")
        os.replace(src, original)
    os.replace(bag / tmp_name, src)
    write_metadata_yaml(bag, metadata)
    if skipped:
        reason += f"; {skipped} messages without schema skipped"
    return RecoveryReport(str(bag), str(src), str(original) if original else None, True, core.messages, chunks,
                          {t: i.count for t, i in core.topics.items()}, reason, lost)


__all__ = ["RecoveryReport", "is_complete", "needs_recovery", "recover", "scan_records"]
