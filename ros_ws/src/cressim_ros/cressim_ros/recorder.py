"""The recording hook: the node hands every message it publishes or receives to a `recorder`.

    recorder = open_recorder(path)        # when the `record` parameter is set
    recorder.write(topic, msg, stamp_ns)  # from the node, for each message
    recorder.close()

The MCAP/rosbag2 writing itself lives in cressim.record (written separately); this module
only adapts it, so the node does not depend on its details. If cressim.record is not
importable, setting `record` is refused with the reason (the node keeps running).
"""
from __future__ import annotations

from typing import Any, Protocol


class Recorder(Protocol):
    def write(self, topic: str, msg: Any, stamp_ns: int) -> None: ...

    def close(self) -> None: ...


class RecordingUnavailable(RuntimeError):
    pass


class _BagWriterRecorder:
    """Adapts cressim.record's BagWriter (a rosbag2 folder with one MCAP file)."""

    def __init__(self, path: str):
        from cressim.record.writer import BagWriter

        self.path = path
        self._bag = BagWriter(path)

    def write(self, topic: str, msg: Any, stamp_ns: int) -> None:
        # BagWriter serialises on this thread and queues; the disk is written by its own thread
        self._bag.write(topic, msg, log_time=stamp_ns)

    def close(self) -> None:
        self._bag.close()

    @property
    def stats(self) -> dict:
        return dict(self._bag.stats)


def open_recorder(path: str) -> Recorder:
    try:
        return _BagWriterRecorder(path)
    except ImportError as exc:
        raise RecordingUnavailable(f"recording needs cressim.record ({exc})") from None


__all__ = ["Recorder", "RecordingUnavailable", "open_recorder"]
