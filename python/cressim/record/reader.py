"""Reading rosbag2 MCAP bags (ours, ros2 bag's, a real dVRK's) with the mcap package.

Types are decoded with the Jazzy typestore (plus crtk_msgs); a type it does not know is
registered from the definition stored in the bag's MCAP schema, so bags with other message
packages can be read as well.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Iterable, Iterator, NamedTuple

from mcap.reader import make_reader
from rosbags.typesys import get_types_from_msg
from ruamel.yaml import YAML

from . import types as _types


class BagMessage(NamedTuple):
    topic: str
    msgtype: str
    log_time: int  # ns
    publish_time: int  # ns
    data: bytes  # CDR
    sequence: int

    def decode(self, store=None):
        """The message as a rosbags dataclass."""
        return _types.decode(self.data, self.msgtype, store=store)


class BagFormatError(RuntimeError):
    """The bag cannot be read as it is (e.g. written by a process that crashed)."""


def read_metadata(bag: str | os.PathLike) -> dict | None:
    """The rosbag2_bagfile_information of BAG/metadata.yaml, or None if there is none."""
    path = Path(bag) / "metadata.yaml"
    if not path.is_file():
        return None
    return YAML(typ="safe").load(path.read_text())["rosbag2_bagfile_information"]


def mcap_files(bag: str | os.PathLike) -> list[Path]:
    """The MCAP files of a bag: metadata.yaml's relative_file_paths, else BAG/*.mcap, or BAG itself."""
    bag = Path(bag)
    if bag.is_file():
        return [bag]
    if not bag.is_dir():
        raise FileNotFoundError(f"no bag at {bag}")
    meta = read_metadata(bag)
    if meta is not None:
        return [bag / p for p in meta["relative_file_paths"]]
    files = sorted(bag.glob("*.mcap"))
    if not files:
        raise FileNotFoundError(f"{bag} holds neither metadata.yaml nor an .mcap file")
    return files


def decoder_store(schemas: Iterable[tuple[str, str]]):
    """A typestore for decoding: ours, plus types registered from (name, ros2msg text) schemas."""
    store = _types.typestore()
    unknown = [(name, text) for name, text in schemas if name not in store.types and text]
    if not unknown:
        return store
    store = _types.typestore_from_definitions(_types.crtk_definitions())
    for name, text in unknown:
        try:
            store.register(get_types_from_msg(text, name))
        except Exception:  # an unparsable schema: messages of this type stay undecodable
            pass
    return store


def read_messages(bag: str | os.PathLike, topics: Iterable[str] | str | None = None, *,
                  decode: bool = False) -> Iterator[Any]:
    """Messages of a bag in log-time order: BagMessage, or (BagMessage, decoded) if decode.

    A bag whose writer crashed has no summary: this raises BagFormatError; run
    cressim.record.recovery.recover on it first (``cressim record --recover BAG``).
    """
    if isinstance(topics, str):
        topics = [topics]
    topics = list(topics) if topics is not None else None
    for path in mcap_files(bag):
        with open(path, "rb") as f:
            reader = make_reader(f)
            try:
                summary = reader.get_summary()
            except Exception as exc:  # McapError, struct.error, ... on a truncated file
                raise BagFormatError(f"{path} has no readable summary ({exc!r}); the recorder may have "
                                     f"crashed: recover it with `cressim record --recover {bag}`") from exc
            store = None
            if decode and summary is not None:
                store = decoder_store((s.name, s.data.decode()) for s in summary.schemas.values())
            for schema, channel, message in reader.iter_messages(topics=topics, log_time_order=True):
                item = BagMessage(channel.topic, schema.name if schema else "", message.log_time,
                                  message.publish_time, message.data, message.sequence)
                if decode:
                    if store is None:
                        store = decoder_store([(schema.name, schema.data.decode())] if schema else [])
                    yield item, item.decode(store)
                else:
                    yield item


def bag_info(bag: str | os.PathLike) -> dict:
    """Summary of a bag: topics, types and counts, times, chunks and compression (from the MCAP summary)."""
    info: dict[str, Any] = {"bag": str(bag), "files": [], "topics": {}, "message_count": 0, "chunks": 0,
                            "compression": set(), "start_ns": None, "end_ns": None,
                            "metadata_yaml": (Path(bag) / "metadata.yaml").is_file() if Path(bag).is_dir() else None}
    for path in mcap_files(bag):
        with open(path, "rb") as f:
            try:
                summary = make_reader(f).get_summary()
            except Exception as exc:
                raise BagFormatError(f"{path} has no readable summary ({exc!r}); recover it first") from exc
        if summary is None:
            raise BagFormatError(f"{path} has no summary")
        info["files"].append(str(path))
        stats = summary.statistics
        counts = stats.channel_message_counts if stats else {}
        for cid, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            entry = info["topics"].setdefault(channel.topic, {"type": schema.name if schema else "", "count": 0})
            entry["count"] += counts.get(cid, 0)
        info["message_count"] += stats.message_count if stats else 0
        info["chunks"] += len(summary.chunk_indexes)
        info["compression"].update(c.compression for c in summary.chunk_indexes)
        if stats and stats.message_count:
            info["start_ns"] = stats.message_start_time if info["start_ns"] is None else min(
                info["start_ns"], stats.message_start_time)
            info["end_ns"] = stats.message_end_time if info["end_ns"] is None else max(
                info["end_ns"], stats.message_end_time)
    info["compression"] = sorted(info["compression"])
    info["duration_s"] = ((info["end_ns"] - info["start_ns"]) / 1e9) if info["start_ns"] is not None else 0.0
    return info


def format_info(info: dict) -> str:
    lines = [f"bag:        {info['bag']}",
             f"files:      {', '.join(info['files'])}",
             f"messages:   {info['message_count']} in {info['chunks']} chunks "
             f"({', '.join(c or 'uncompressed' for c in info['compression']) or '-'})",
             f"duration:   {info['duration_s']:.3f} s",
             f"metadata:   {'metadata.yaml' if info['metadata_yaml'] else 'no metadata.yaml'}",
             "topics:"]
    width = max((len(t) for t in info["topics"]), default=0)
    for topic, entry in sorted(info["topics"].items()):
        lines.append(f"  {topic:{width}s}  {entry['count']:7d}  {entry['type']}")
    return "\n".join(lines)


__all__ = ["BagFormatError", "BagMessage", "bag_info", "decoder_store", "format_info", "mcap_files",
           "read_messages", "read_metadata"]
