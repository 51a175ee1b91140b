"""Recording to rosbag2 bags in MCAP storage, from a background thread.

Layout (what ``ros2 bag`` and rosbags read)::

    BAG/                       a directory
      metadata.yaml            rosbag2 metadata, version 9 (Jazzy); written at close or by recovery
      BAG_0.mcap               MCAP, profile "ros2": ros2msg schemas, CDR messages, zstd chunks

Crash safety. Messages go into MCAP chunks; a chunk is closed (compressed, written, the
message indexes after it, and the stream flushed to the OS) as soon as it holds
``chunk_size`` bytes (default 1 MiB) or its oldest message was handed to ``write`` more than
0.9 x ``max_chunk_age`` ago (default 1 s; the 10 % leaves room for scheduling). So every
message given to ``write`` more than ``max_chunk_age`` before a crash of the process (SIGKILL
included) is in a complete chunk in the kernel's page cache and survives; ``fsync=True`` also
fsyncs each chunk for power loss. The summary, footer and metadata.yaml are written by
``close``; after a crash, :func:`cressim.record.recovery.recover` rebuilds them.

Never blocking the simulation. ``BagWriter.write`` serialises the message on the caller's
thread (a snapshot: later changes to the message object are not recorded), appends it to a
bounded in-memory queue and returns; the disk is touched only by the writer thread, which
takes the queue in batches (``poll`` = 50 ms after the oldest queued message, or sooner when
1000 messages / 1 MiB wait) so that it seldom competes with the caller for the GIL. The queue
holds at most ``max_queue`` messages and ``max_queue_bytes`` bytes. When it is full the policy
is explicit (``on_full``):

* ``"drop_oldest"`` (default): the oldest queued messages are discarded to make room, counted
  in ``stats["dropped"]`` (and per topic in ``stats["dropped_by_topic"]``); write never waits.
* ``"block"``: write waits until the writer thread has made room (lossless, may stall the caller).
"""
from __future__ import annotations

import atexit
import collections
import io
import os
import threading
import time
import weakref
from pathlib import Path
from typing import Any, Callable

from mcap.writer import CompressionType, Writer as McapWriter
from ruamel.yaml import YAML

from . import types as _types
from .schema import TOPICS_BY_NAME, qos_dict, spec_for

LIBRARY = "cressim-record"
MESSAGE_RECORD_OVERHEAD = 31  # MCAP Message record: opcode 1 + length 8 + channel 2 + seq 4 + times 16
DEFAULT_CHUNK_SIZE = 1 << 20
DEFAULT_MAX_CHUNK_AGE = 1.0
AGE_TARGET = 0.9  # chunks are closed at this fraction of max_chunk_age
ON_FULL = ("drop_oldest", "block")


class RecorderError(RuntimeError):
    """The recorder cannot take messages (closed, or its writer thread failed)."""


def mcap_path(bag: str | os.PathLike) -> Path:
    """BAG/BAG_0.mcap: where a bag directory keeps its (single) MCAP file."""
    bag = Path(bag)
    return bag / f"{bag.name}_0.mcap"


def _yaml_dump(data: Any) -> str:
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    yaml.width = 1 << 16  # no folded lines
    stream = io.StringIO()
    yaml.dump(data, stream)
    return stream.getvalue()


def _compression(name: str) -> CompressionType:
    try:
        return {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE,
                "": CompressionType.NONE}[name]
    except KeyError:
        raise ValueError(f"compression must be zstd, lz4 or none, not {name!r}") from None


class TopicInfo:
    __slots__ = ("topic", "msgtype", "msgdef", "type_hash", "qos", "channel_id", "count", "sequence")

    def __init__(self, topic, msgtype, msgdef, type_hash, qos):
        self.topic, self.msgtype, self.msgdef, self.type_hash, self.qos = topic, msgtype, msgdef, type_hash, qos
        self.channel_id = None
        self.count = 0
        self.sequence = 0


def metadata_dict(relative_path: str, topics: list[TopicInfo], start_ns: int, end_ns: int, *,
                  custom_data: dict | None = None, ros_distro: str = "jazzy") -> dict:
    """rosbag2's metadata.yaml content (version 9) for one storage file."""
    count = sum(t.count for t in topics)
    start = start_ns if count else 0
    duration = max(0, end_ns - start_ns) if count else 0
    return {"rosbag2_bagfile_information": {
        "version": 9,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": count,
        "topics_with_message_count": [
            {"topic_metadata": {"name": t.topic, "type": t.msgtype, "serialization_format": "cdr",
                                "offered_qos_profiles": list(t.qos), "type_description_hash": t.type_hash},
             "message_count": t.count}
            for t in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [relative_path],
        "files": [{"path": relative_path, "starting_time": {"nanoseconds_since_epoch": start},
                   "duration": {"nanoseconds": duration}, "message_count": count}],
        "custom_data": dict(custom_data) if custom_data else None,
        "ros_distro": ros_distro,
    }}


def write_metadata_yaml(bag: Path, metadata: dict) -> None:
    """Write BAG/metadata.yaml atomically (temporary file, then rename)."""
    tmp = bag / "metadata.yaml.tmp"
    tmp.write_text(_yaml_dump(metadata), encoding="utf8")
    tmp.replace(bag / "metadata.yaml")


def default_qos(topic: str) -> list[dict]:
    """Offered QoS for a topic: the schema's profile for PSM topics (any arm namespace), else
    reliable, volatile, depth 10."""
    spec = spec_for(topic)
    if spec is None and topic.count("/") >= 2:
        spec = TOPICS_BY_NAME.get(topic.strip("/").split("/", 1)[1])
    return [spec.qos if spec is not None else qos_dict(depth=10)]


class BagCore:
    """A rosbag2 MCAP bag written synchronously by one thread (BagWriter's worker, recovery).

    Chunk closing is explicit here: ``write`` closes the open chunk when it reaches
    ``chunk_size`` bytes, ``due(now)`` says when its oldest message is older than the age
    target, and ``close_chunk`` closes it.
    """

    def __init__(self, bag: str | os.PathLike, *, chunk_size: int = DEFAULT_CHUNK_SIZE,
                 max_chunk_age: float = DEFAULT_MAX_CHUNK_AGE, compression: str = "zstd", fsync: bool = False,
                 custom_data: dict | None = None, ros_distro: str = "jazzy", file_name: str | None = None,
                 existing_dir: bool = False):
        self.bag = Path(bag)
        if self.bag.exists() and (not self.bag.is_dir() or (any(self.bag.iterdir()) and not existing_dir)):
            raise FileExistsError(f"{self.bag} exists and is not an empty directory; not overwriting")
        self.bag.mkdir(parents=True, exist_ok=True)
        self.path = self.bag / file_name if file_name else mcap_path(self.bag)
        self.chunk_size = int(chunk_size)
        self.max_chunk_age = float(max_chunk_age)
        self.fsync = fsync
        self.custom_data = dict(custom_data or {})
        self.ros_distro = ros_distro
        self._file = open(self.path, "xb")
        # mcap never closes a chunk on its own (huge chunk_size): we do, by size and by age
        self._mcap = McapWriter(self._file, chunk_size=1 << 62, compression=_compression(compression))
        self._mcap.start(profile="ros2", library=LIBRARY)
        self._file.flush()
        self.topics: dict[str, TopicInfo] = {}
        self._schemas: dict[str, int] = {}
        self.open_bytes = 0
        self.open_count = 0
        self.open_since = 0.0  # monotonic time the open chunk's oldest message was handed over
        self.chunks = 0
        self.messages = 0
        self.start_ns = None
        self.end_ns = None
        self.closed = False

    # topics -----------------------------------------------------------------------------
    def add_topic(self, topic: str, msgtype: str, *, qos: list[dict] | None = None, msgdef: str | None = None,
                  type_hash: str | None = None) -> TopicInfo:
        """Register a topic (idempotent for the same type); the MCAP records go into the open chunk."""
        msgtype = _types.normalize_msgtype(msgtype)
        info = self.topics.get(topic)
        if info is not None:
            if info.msgtype != msgtype:
                raise ValueError(f"topic {topic} is {info.msgtype}, not {msgtype}")
            return info
        if msgdef is None:
            msgdef, type_hash = _types.message_definition(msgtype)
        elif type_hash is None:
            try:
                type_hash = _types.message_definition(msgtype)[1]
            except Exception:  # a type only the bag knows
                type_hash = ""
        info = TopicInfo(topic, msgtype, msgdef, type_hash, list(qos) if qos is not None else default_qos(topic))
        schema_id = self._schemas.get(msgtype)
        if schema_id is None:
            schema_id = self._mcap.register_schema(name=msgtype, encoding="ros2msg", data=msgdef.encode())
            self._schemas[msgtype] = schema_id
        info.channel_id = self._mcap.register_channel(
            topic=topic, message_encoding="cdr", schema_id=schema_id,
            metadata={"offered_qos_profiles": _yaml_dump(info.qos).strip(), "topic_type_hash": type_hash})
        self.topics[topic] = info
        return info

    # messages ---------------------------------------------------------------------------
    def write(self, topic: str, msgtype: str, data: bytes, log_time: int, publish_time: int | None = None,
              handed_at: float | None = None) -> None:
        info = self.topics.get(topic) or self.add_topic(topic, msgtype)
        if info.msgtype != _types.normalize_msgtype(msgtype):
            raise ValueError(f"topic {topic} is {info.msgtype}, not {msgtype}")
        self._mcap.add_message(channel_id=info.channel_id, log_time=int(log_time), data=data,
                               publish_time=int(publish_time if publish_time is not None else log_time),
                               sequence=info.sequence & 0xFFFFFFFF)
        info.sequence += 1
        info.count += 1
        self.messages += 1
        self.start_ns = log_time if self.start_ns is None else min(self.start_ns, log_time)
        self.end_ns = log_time if self.end_ns is None else max(self.end_ns, log_time)
        if self.open_count == 0:
            self.open_since = time.monotonic() if handed_at is None else handed_at
        self.open_count += 1
        self.open_bytes += MESSAGE_RECORD_OVERHEAD + len(data)
        if self.open_bytes >= self.chunk_size:
            self.close_chunk()

    def deadline(self) -> float | None:
        """Monotonic time by which the open chunk must be closed (None: no open chunk)."""
        if self.open_count == 0:
            return None
        return self.open_since + AGE_TARGET * self.max_chunk_age

    def due(self, now: float | None = None) -> bool:
        deadline = self.deadline()
        return deadline is not None and (time.monotonic() if now is None else now) >= deadline

    def close_chunk(self) -> None:
        """Close the open chunk (if any): compress, write it and its indexes, flush to the OS."""
        if self.open_count:
            self._mcap.flush()  # finalises the chunk and flushes the stream
            self.chunks += 1
            if self.fsync:
                os.fsync(self._file.fileno())
        self.open_bytes = 0
        self.open_count = 0

    # end --------------------------------------------------------------------------------
    def metadata(self, relative_path: str | None = None) -> dict:
        return metadata_dict(relative_path or self.path.name, list(self.topics.values()), self.start_ns or 0,
                             self.end_ns or 0,
                             custom_data=self.custom_data, ros_distro=self.ros_distro)

    def close(self, *, write_yaml: bool = True, relative_path: str | None = None) -> dict:
        """Close the last chunk, write the summary and footer, then metadata.yaml. Returns the metadata.

        relative_path: the file name metadata.yaml names (recovery writes under a temporary name)."""
        if self.closed:
            return self.metadata(relative_path)
        self.close_chunk()
        metadata = self.metadata(relative_path)
        self._mcap.add_metadata("rosbag2", {
            "serialized_metadata": _yaml_dump(metadata["rosbag2_bagfile_information"]).strip()})
        self._mcap.finish()
        self._file.flush()
        if self.fsync:
            os.fsync(self._file.fileno())
        self._file.close()
        self.closed = True
        if write_yaml:
            write_metadata_yaml(self.bag, metadata)
        return metadata

    def abort(self) -> None:
        """Stop without summary or metadata.yaml (what a crash leaves; recovery can repair it)."""
        if not self.closed:
            self.closed = True
            try:
                self._file.close()
            except OSError:
                pass


_OPEN_WRITERS: "weakref.WeakSet[BagWriter]" = weakref.WeakSet()


@atexit.register
def _close_open_writers():  # pragma: no cover - exercised by interpreter exit
    for writer in list(_OPEN_WRITERS):
        try:
            writer.close(timeout=10.0)
        except Exception:
            pass


class BagWriter:
    """Records messages to a rosbag2 MCAP bag from a background thread (module docstring).

        with BagWriter("bags/run1") as bag:
            bag.write("/PSM1/measured_js", js)          # rosbags dataclass or rclpy message
            bag.write("/PSM1/servo_jp", {"position": q}, msgtype="sensor_msgs/msg/JointState")

    ``log_time`` defaults to ``clock()`` (time.time_ns: the receive time rosbag2 records);
    pass the sim clock's time to record sim time instead.
    """

    def __init__(self, bag: str | os.PathLike, *, chunk_size: int = DEFAULT_CHUNK_SIZE,
                 max_chunk_age: float = DEFAULT_MAX_CHUNK_AGE, max_queue: int = 100_000,
                 max_queue_bytes: int = 256 << 20, on_full: str = "drop_oldest", compression: str = "zstd",
                 fsync: bool = False, custom_data: dict | None = None, ros_distro: str = "jazzy",
                 clock: Callable[[], int] = time.time_ns, poll: float = 0.05):
        if on_full not in ON_FULL:
            raise ValueError(f"on_full must be one of {ON_FULL}, not {on_full!r}")
        if max_queue < 1 or max_queue_bytes < 1:
            raise ValueError("max_queue and max_queue_bytes must be positive")
        if max_chunk_age <= 0:
            raise ValueError("max_chunk_age must be positive")
        self.on_full = on_full
        self.max_queue, self.max_queue_bytes = int(max_queue), int(max_queue_bytes)
        self.clock = clock
        self.poll = min(float(poll), 0.1 * max_chunk_age)
        self._wake_count = max(1, min(1000, self.max_queue // 2))
        self._wake_bytes = max(1, min(1 << 20, self.max_queue_bytes // 2))
        self._core = BagCore(bag, chunk_size=chunk_size, max_chunk_age=max_chunk_age, compression=compression,
                             fsync=fsync, custom_data=custom_data, ros_distro=ros_distro)
        self.bag = self._core.bag
        self.path = self._core.path
        self._cond = threading.Condition()
        self._queue: collections.deque = collections.deque()
        self._queue_bytes = 0
        self._types: dict[str, str] = {}
        self._pending_topics: list = []
        self._dropped = 0
        self._dropped_by_topic: collections.Counter = collections.Counter()
        self._accepted = 0
        self._written = 0
        self._flush_requests = 0
        self._flushes_done = 0
        self._stop = False
        self._error: BaseException | None = None
        self._metadata: dict | None = None
        self._thread = threading.Thread(target=self._run, name=f"cressim-record:{self.bag.name}", daemon=True)
        self._thread.start()
        _OPEN_WRITERS.add(self)

    # caller side ------------------------------------------------------------------------
    def add_topic(self, topic: str, msgtype: str, *, qos: list[dict] | None = None) -> None:
        """Declare a topic ahead of its first message (optional; also sets its offered QoS)."""
        msgtype = _types.normalize_msgtype(msgtype)
        _types.message_definition(msgtype)  # unknown types fail here, in the caller
        with self._cond:
            self._check_open()
            known = self._types.get(topic)
            if known is not None and known != msgtype:
                raise ValueError(f"topic {topic} is {known}, not {msgtype}")
            if known is None:
                self._types[topic] = msgtype
                self._pending_topics.append((topic, msgtype, qos))
                self._cond.notify_all()

    def write(self, topic: str, msg: Any, *, msgtype: str | None = None, log_time: int | None = None,
              publish_time: int | None = None) -> None:
        """Queue one message (any form cressim.record.types accepts); never touches the disk.

        rclpy messages are serialised here (a snapshot) and normalised to exact CDR by the
        writer thread (types.normalize_cdr), which keeps the caller's share small."""
        from_rclpy = _types.rclpy_msgtype(msg) is not None
        msgtype, data = _types.encode(msg, msgtype, normalize=False)
        handed_at = time.monotonic()
        log_time = self.clock() if log_time is None else int(log_time)
        item = (topic, msgtype, data, log_time, publish_time, handed_at, from_rclpy)
        with self._cond:
            self._check_open()
            known = self._types.get(topic)
            if known is None:
                _types.message_definition(msgtype)
                self._types[topic] = msgtype
                self._pending_topics.append((topic, msgtype, None))
            elif known != msgtype:
                raise ValueError(f"topic {topic} is {known}, not {msgtype}")
            size = len(data)
            if self.on_full == "block":
                while (self._queue and (len(self._queue) >= self.max_queue
                                        or self._queue_bytes + size > self.max_queue_bytes)):
                    self._cond.notify_all()  # make sure the writer thread is draining
                    self._cond.wait()
                    self._check_open()
            else:
                while self._queue and (len(self._queue) >= self.max_queue
                                       or self._queue_bytes + size > self.max_queue_bytes):
                    old = self._queue.popleft()
                    self._queue_bytes -= len(old[2])
                    self._dropped += 1
                    self._dropped_by_topic[old[0]] += 1
            self._queue.append(item)
            self._queue_bytes += size
            self._accepted += 1
            # wake the writer thread when the queue stops being empty (it then sleeps until `poll`
            # after the oldest message) or when a lot is waiting: not on every message, since
            # it competes with the caller for the GIL
            if (len(self._queue) == 1 or len(self._queue) >= self._wake_count
                    or self._queue_bytes >= self._wake_bytes):
                self._cond.notify_all()

    def flush(self, timeout: float | None = None) -> bool:
        """Write everything queued so far and close the open chunk. False on timeout."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            self._check_open()
            self._flush_requests += 1
            target = self._flush_requests
            self._cond.notify_all()
            while self._flushes_done < target:
                if self._error is not None:
                    raise RecorderError(f"recorder for {self.bag} failed: {self._error!r}") from self._error
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return False
                self._cond.wait(remaining)
        return True

    def close(self, timeout: float | None = None) -> dict | None:
        """Drain the queue, close the bag (summary, metadata.yaml) and stop the thread.

        Returns the metadata (the content of metadata.yaml). Raises RecorderError if the
        writer thread failed; the bag can then be repaired with recovery.recover."""
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        self._thread.join(timeout)
        _OPEN_WRITERS.discard(self)
        if self._thread.is_alive():
            raise RecorderError(f"recorder for {self.bag} did not finish within {timeout} s")
        if self._error is not None:
            raise RecorderError(f"recorder for {self.bag} failed: {self._error!r}") from self._error
        return self._metadata

    @property
    def stats(self) -> dict:
        with self._cond:
            return {
                "accepted": self._accepted, "written": self._written, "queued": len(self._queue),
                "queued_bytes": self._queue_bytes, "dropped": self._dropped,
                "dropped_by_topic": dict(self._dropped_by_topic), "chunks": self._core.chunks,
                "on_full": self.on_full, "error": repr(self._error) if self._error else None,
                "closed": self._stop,
            }

    def _check_open(self):
        if self._error is not None:
            raise RecorderError(f"recorder for {self.bag} failed: {self._error!r}") from self._error
        if self._stop:
            raise RecorderError(f"recorder for {self.bag} is closed")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    # writer thread ----------------------------------------------------------------------
    def _run(self):
        core = self._core
        try:
            while True:
                with self._cond:
                    while True:
                        if self._pending_topics or self._stop or self._flush_requests > self._flushes_done:
                            break
                        if len(self._queue) >= self._wake_count or self._queue_bytes >= self._wake_bytes:
                            break
                        deadline = core.deadline()
                        now = time.monotonic()
                        if deadline is not None and now >= deadline:
                            break
                        if self._queue and now >= self._queue[0][5] + self.poll:
                            break
                        if self._queue:  # wake `poll` after the oldest queued message was handed over
                            wait = self._queue[0][5] + self.poll - now
                        else:
                            wait = None
                        if deadline is not None:
                            wait = deadline - now if wait is None else min(wait, deadline - now)
                        self._cond.wait(wait)
                    topics, self._pending_topics = self._pending_topics, []
                    batch = list(self._queue)
                    self._queue.clear()
                    self._queue_bytes = 0
                    flush_target = self._flush_requests
                    stop = self._stop
                    self._cond.notify_all()  # room for blocked writers
                for topic, msgtype, qos in topics:
                    core.add_topic(topic, msgtype, qos=qos)
                for topic, msgtype, data, log_time, publish_time, handed_at, from_rclpy in batch:
                    if from_rclpy:
                        data = _types.normalize_cdr(data, msgtype)
                    core.write(topic, msgtype, data, log_time, publish_time, handed_at)
                    if core.due():
                        core.close_chunk()
                if core.due() or flush_target > self._flushes_done or stop:
                    core.close_chunk()
                with self._cond:
                    self._written += len(batch)
                    if flush_target > self._flushes_done:
                        self._flushes_done = flush_target
                    self._cond.notify_all()
                if stop:
                    with self._cond:
                        if self._queue or self._pending_topics:
                            continue
                    self._metadata = core.close()
                    return
        except BaseException as exc:  # disk full, ...: reported by write/flush/close
            with self._cond:
                self._error = exc
                self._cond.notify_all()
            core.abort()


__all__ = ["BagCore", "BagWriter", "RecorderError", "mcap_path", "metadata_dict", "write_metadata_yaml"]
