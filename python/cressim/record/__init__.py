"""Bag I/O: recording to rosbag2 MCAP bags, reading them back, crash recovery and replay of a
bag against the twin. Bag I/O only: datasets made with the envs are cressim.datasets'.

    from cressim.record import BagWriter, read_messages, recover
    with BagWriter("bags/run1") as bag:                 # background thread, zstd chunks
        bag.write("/PSM1/measured_js", msg)             # rosbags dataclass, dict or rclpy message
    for m, msg in read_messages("bags/run1", decode=True): ...
    recover("bags/crashed")                             # after SIGKILL: rebuild summary + metadata.yaml

The topic table (types, rates, frames, units) is in schema.py and bags/README.md.
"""
from .reader import BagFormatError, BagMessage, bag_info, read_messages, read_metadata
from .recovery import RecoveryReport, needs_recovery, recover
from .schema import ARM_JOINTS, JAW_JOINTS, PSM_TOPICS, TopicSpec
from .types import decode, encode, from_dict, to_dict, typestore
from .writer import BagCore, BagWriter, RecorderError

__all__ = [
    "ARM_JOINTS", "BagCore", "BagFormatError", "BagMessage", "BagWriter", "JAW_JOINTS", "PSM_TOPICS",
    "RecorderError", "RecoveryReport", "TopicSpec", "bag_info", "decode", "encode", "from_dict",
    "needs_recovery", "read_messages", "read_metadata", "recover", "to_dict", "typestore",
]
