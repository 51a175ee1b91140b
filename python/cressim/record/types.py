"""Message types and CDR (de)serialisation for recordings, without rclpy.

The type system is rosbags' ROS 2 Jazzy typestore plus our crtk_msgs, registered from their
.msg definitions (ros_ws/src/crtk_msgs/msg when this is a source checkout, else the copy
below, which tests/record keeps equal to those files). Messages can be given as

* rosbags dataclasses (``typestore().types['sensor_msgs/msg/JointState'](...)``),
* plain dicts (missing fields take zero values; nested messages are dicts too),
* rclpy message objects (serialised with ``rclpy.serialization.serialize_message``, then
  normalised to exact CDR when the typestore knows the type),
* already serialised CDR bytes (the message type must then be named).
"""
from __future__ import annotations

import functools
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.serde import SerdeError
from rosbags.typesys.store import Typestore

CRTK_MSG_DIR_ENV = "CRESSIM_CRTK_MSG_DIR"  # overrides where crtk_msgs/msg/*.msg are read from

# Fallback copy of the crtk_msgs types the twin publishes, from ros_ws/src/crtk_msgs/msg (comments
# dropped), for an install without the checkout; tests check it is in sync.
CRTK_MSGS_FALLBACK = {
    "crtk_msgs/msg/OperatingState": (
        "std_msgs/Header header\n"
        "string state\n"
        "string STATE_DISABLED=DISABLED\n"
        "string STATE_ENABLED=ENABLED\n"
        "string STATE_PAUSED=PAUSED\n"
        "string STATE_FAULT=FAULT\n"
        "bool is_homed\n"
        "bool is_busy\n"
    ),
    "crtk_msgs/msg/StringStamped": "std_msgs/Header header\nstring string\n",
    "crtk_msgs/msg/CartesianState": (
        "std_msgs/Header header\n"
        "geometry_msgs/Pose pose\n"
        "std_msgs/Bool pose_is_valid\n"
        "geometry_msgs/Twist twist\n"
        "std_msgs/Bool twist_is_valid\n"
        "geometry_msgs/Wrench wrench\n"
        "std_msgs/Bool wrench_is_valid\n"
    ),
}

# rosbags' Nodetype values (rosbags.typesys.msg.Nodetype): fielddefs use these
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4
_NUMPY = {
    "bool": np.bool_, "byte": np.uint8, "char": np.uint8, "octet": np.uint8,
    "int8": np.int8, "uint8": np.uint8, "int16": np.int16, "uint16": np.uint16,
    "int32": np.int32, "uint32": np.uint32, "int64": np.int64, "uint64": np.uint64,
    "float32": np.float32, "float64": np.float64,
}


def crtk_msg_dir() -> Path | None:
    """ros_ws/src/crtk_msgs/msg of this checkout ($CRESSIM_CRTK_MSG_DIR wins), or None."""
    if os.environ.get(CRTK_MSG_DIR_ENV):
        return Path(os.environ[CRTK_MSG_DIR_ENV])
    for start in (Path(__file__).resolve(), Path.cwd().resolve()):
        for folder in (start, *start.parents):
            candidate = folder / "ros_ws" / "src" / "crtk_msgs" / "msg"
            if (candidate / "OperatingState.msg").is_file():
                return candidate
    return None


def crtk_definitions() -> dict[str, str]:
    """{'crtk_msgs/msg/Name': .msg text} from the checkout's files, else the fallback copy."""
    folder = crtk_msg_dir()
    if folder is None:
        return dict(CRTK_MSGS_FALLBACK)
    return {f"crtk_msgs/msg/{p.stem}": p.read_text() for p in sorted(folder.glob("*.msg"))}


@functools.lru_cache(maxsize=1)
def typestore() -> Typestore:
    """The ROS 2 Jazzy typestore with crtk_msgs registered (one per process)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict = {}
    for name, text in crtk_definitions().items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def typestore_from_definitions(definitions: Mapping[str, str]) -> Typestore:
    """A fresh Jazzy typestore with extra types from {msgtype: ros2msg definition}.

    Definitions as stored in MCAP schemas (the type followed by its dependencies, separated by
    '=====' lines and 'MSG: pkg/Name' headers) are accepted, which is how a reader decodes a
    bag with the types written into the bag rather than the types it knows.
    """
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict = {}
    for name, text in definitions.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def normalize_msgtype(msgtype: str) -> str:
    """'sensor_msgs/JointState' -> 'sensor_msgs/msg/JointState'; full names pass through."""
    parts = msgtype.split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return msgtype


def rclpy_msgtype(msg: Any) -> str | None:
    """'sensor_msgs/msg/JointState' for an rclpy message object, else None."""
    cls = type(msg)
    if not hasattr(cls, "get_fields_and_field_types"):
        return None
    parts = cls.__module__.split(".")  # e.g. sensor_msgs.msg._joint_state
    if len(parts) < 2 or parts[1] not in ("msg", "srv", "action"):
        return None
    return f"{parts[0]}/{parts[1]}/{cls.__name__}"


def msgtype_of(msg: Any) -> str | None:
    """The message type of a rosbags dataclass or rclpy message, else None."""
    name = getattr(type(msg), "__msgtype__", None)
    if isinstance(name, str):
        return name
    return rclpy_msgtype(msg)


def _zero(typ: str):
    if typ == "string" or typ == "wstring":
        return ""
    if typ == "bool":
        return False
    if typ.startswith("float"):
        return 0.0
    return 0


def _convert(store: Typestore, ntype: int, sub, value):
    if ntype == _BASE:
        typ = sub[0]
        if value is None:
            return _zero(typ)
        if typ in ("string", "wstring"):
            return str(value)
        if typ == "bool":
            return bool(value)
        if typ.startswith("float"):
            return float(value)
        return int(value)
    if ntype == _NAME:
        return from_dict(sub, value if value is not None else {}, store=store)
    if ntype in (_ARRAY, _SEQUENCE):
        (etype, esub), length = sub
        if etype == _BASE and esub[0] not in ("string", "wstring"):
            dtype = _NUMPY[esub[0]]
            if value is None:
                return np.zeros(length if ntype == _ARRAY else 0, dtype=dtype)
            return np.asarray(value, dtype=dtype).reshape(-1)
        items = list(value) if value is not None else [None] * (length if ntype == _ARRAY else 0)
        return [_convert(store, etype, esub, v) for v in items]
    raise TypeError(f"unsupported field node type {ntype}")


def from_dict(msgtype: str, data: Any, *, store: Typestore | None = None):
    """A rosbags dataclass of msgtype from a dict (missing fields: zero) or a dataclass."""
    store = store or typestore()
    msgtype = normalize_msgtype(msgtype)
    if getattr(type(data), "__msgtype__", None) == msgtype:
        return data
    try:
        _, fields = store.fielddefs[msgtype]
    except KeyError:
        raise KeyError(f"unknown message type {msgtype!r} (not in the Jazzy typestore or crtk_msgs)") from None
    if isinstance(data, Mapping):
        unknown = set(data) - {name for name, _ in fields}
        if unknown:
            raise ValueError(f"{msgtype} has no field(s) {sorted(unknown)}")
        get = data.get
    else:
        def get(name, default=None):
            return getattr(data, name, default)
    kwargs = {name: _convert(store, ntype, sub, get(name)) for name, (ntype, sub) in fields}
    return store.types[msgtype](**kwargs)


def to_dict(msg: Any) -> Any:
    """A rosbags dataclass as nested dicts/lists (numpy arrays become lists)."""
    if hasattr(msg, "__dataclass_fields__"):
        return {k: to_dict(getattr(msg, k)) for k in msg.__dataclass_fields__ if k != "__msgtype__"}
    if isinstance(msg, np.ndarray):
        return msg.tolist()
    if isinstance(msg, (list, tuple)):
        return [to_dict(v) for v in msg]
    if isinstance(msg, np.generic):
        return msg.item()
    return msg


def encode(msg: Any, msgtype: str | None = None, *, store: Typestore | None = None,
           normalize: bool = True) -> tuple[str, bytes]:
    """(msgtype, CDR bytes) of a message in any of the accepted forms (module docstring).

    normalize=False leaves rclpy's serialisation as it is (see normalize_cdr)."""
    if isinstance(msg, (bytes, bytearray, memoryview)):
        if msgtype is None:
            raise ValueError("serialised bytes need an explicit msgtype")
        return normalize_msgtype(msgtype), bytes(msg)
    name = rclpy_msgtype(msg)
    if name is not None:
        from rclpy.serialization import serialize_message

        if msgtype is not None and normalize_msgtype(msgtype) != name:
            raise ValueError(f"message is a {name}, not a {msgtype}")
        data = serialize_message(msg)
        return name, normalize_cdr(data, name, store=store) if normalize else data
    store = store or typestore()
    name = getattr(type(msg), "__msgtype__", None)
    if name is None:
        if msgtype is None:
            raise ValueError(f"cannot tell the message type of a {type(msg).__name__}; pass msgtype")
        name = normalize_msgtype(msgtype)
        msg = from_dict(name, msg, store=store)
    elif msgtype is not None and normalize_msgtype(msgtype) != name:
        raise ValueError(f"message is a {name}, not a {msgtype}")
    return name, bytes(store.serialize_cdr(msg, name))


def normalize_cdr(data: bytes, msgtype: str, *, store: Typestore | None = None) -> bytes:
    """The exact CDR of a message serialised by rclpy.

    rclpy's serialize_message (rmw_fastrtps, Jazzy) may append up to 8 junk bytes and leaves
    alignment padding uninitialised; re-serialising gives the CDR that DDS puts on the wire,
    which strict readers (rosbags) accept. Types the typestore does not know pass unchanged."""
    store = store or typestore()
    msgtype = normalize_msgtype(msgtype)
    if msgtype not in store.types:
        return bytes(data)
    return bytes(store.serialize_cdr(decode(data, msgtype, store=store), msgtype))


def decode(data: bytes | memoryview, msgtype: str, *, store: Typestore | None = None):
    """A rosbags dataclass from CDR bytes.

    Tolerates trailing bytes: rmw_fastrtps (Jazzy) serialises some messages with up to 8
    bytes of padding after the payload (e.g. JointState), more than the 3 that rosbags'
    deserialize_cdr accepts; the payload itself is parsed strictly."""
    store = store or typestore()
    msgtype = normalize_msgtype(msgtype)
    try:
        return store.deserialize_cdr(data, msgtype)
    except SerdeError as exc:
        if "size mismatch" not in str(exc) or bytes(data[:2]) not in (b"\x00\x00", b"\x00\x01"):
            raise
    msgdef = store.get_msgdef(msgtype)
    func = msgdef.deserialize_cdr_le if data[1] else msgdef.deserialize_cdr_be
    message, pos = func(memoryview(data)[4:], 0, msgdef.cls, store)
    if len(data) - 4 - pos > 8:
        raise SerdeError(f"CDR message size mismatch for {msgtype!r}: {len(data) - 4 - pos} trailing bytes")
    return message


def message_definition(msgtype: str, *, store: Typestore | None = None) -> tuple[str, str]:
    """(ros2msg definition text as rosbag2 stores it in an MCAP schema, RIHS01 type hash)."""
    store = store or typestore()
    msgtype = normalize_msgtype(msgtype)
    text, _ = store.generate_msgdef(msgtype, ros_version=2)
    return text, store.hash_rihs01(msgtype)


def stamp(ns: int) -> dict:
    """builtin_interfaces/Time dict of integer nanoseconds."""
    return {"sec": int(ns // 1_000_000_000), "nanosec": int(ns % 1_000_000_000)}


def stamp_ns(time_msg: Any) -> int:
    """Integer nanoseconds of a builtin_interfaces/Time (dataclass, rclpy message or dict)."""
    if isinstance(time_msg, Mapping):
        return int(time_msg["sec"]) * 1_000_000_000 + int(time_msg["nanosec"])
    return int(time_msg.sec) * 1_000_000_000 + int(time_msg.nanosec)


__all__ = [
    "CRTK_MSGS_FALLBACK",
    "crtk_definitions",
    "decode",
    "encode",
    "from_dict",
    "message_definition",
    "msgtype_of",
    "normalize_cdr",
    "normalize_msgtype",
    "stamp",
    "stamp_ns",
    "to_dict",
    "typestore",
    "typestore_from_definitions",
]
