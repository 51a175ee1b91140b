"""rclpy glue: record topics to a BagWriter, and link replay to a running twin.

Needs the ROS 2 wheels (``source ros_ws/env.sh``); everything else in cressim.record works
without them. Messages are taken and sent as serialised CDR (raw subscriptions,
``Publisher.publish(bytes)``), so nothing is converted on the way into or out of a bag.
Each object runs its own rclpy Context, node and executor thread.
"""
from __future__ import annotations

import importlib
import threading
import time
from typing import Callable

from . import types as _types
from .schema import DEFAULT_NAMESPACE, PSM_TOPICS, TOPICS_BY_NAME, relative_name


def rclpy_problem() -> str | None:
    """None when rclpy can be used here, else why not."""
    try:
        import rclpy  # noqa: F401
    except ImportError as exc:
        return f"rclpy not importable ({exc}); source ros_ws/env.sh after ros_ws/build.sh"
    return None


def message_class(msgtype: str):
    """The rclpy message class of 'pkg/msg/Name' (ImportError/AttributeError if not installed)."""
    pkg, sub, name = _types.normalize_msgtype(msgtype).split("/")
    return getattr(importlib.import_module(f"{pkg}.{sub}"), name)


def _qos(role: str, *, best_effort: bool = False, depth: int | None = None):
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth or 100,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if role == "event" else DurabilityPolicy.VOLATILE)


def _role(topic: str, ns: str) -> str:
    spec = TOPICS_BY_NAME.get(relative_name(topic, ns)) or TOPICS_BY_NAME.get(topic)
    return spec.role if spec else "state"


class _Node:
    def __init__(self, node_name: str):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(node_name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name=node_name, daemon=True)
        self._thread.start()
        self.skipped: dict[str, str] = {}

    def _spin(self):
        try:
            self.executor.spin()
        except Exception:  # shutdown while spinning
            pass

    def subscribe_raw(self, topic: str, msgtype: str, callback: Callable[[bytes], None], qos) -> bool:
        try:
            cls = message_class(msgtype)
        except (ImportError, AttributeError) as exc:  # e.g. tf2_msgs has no Jazzy wheel
            self.skipped[topic] = f"{msgtype} not importable ({exc})"
            return False
        self.node.create_subscription(cls, topic, callback, qos, raw=True)
        return True

    def close(self):
        try:
            self.executor.shutdown(timeout_sec=2.0)
        except Exception:
            pass
        try:
            self.node.destroy_node()
        finally:
            if self.context.ok():
                self.context.shutdown()
        self._thread.join(timeout=2.0)


class RclpyRecorder:
    """Subscribes (raw) to topics and hands every message to a BagWriter; log_time = receive time."""

    def __init__(self, writer, topics: dict[str, str], *, ns: str = DEFAULT_NAMESPACE,
                 node_name: str = "cressim_record", best_effort: bool = False):
        self.writer = writer
        self.received = 0
        self.errors = 0
        self._node = _Node(node_name)
        self.topics = {}
        for topic, msgtype in topics.items():
            writer.add_topic(topic, msgtype)
            if self._node.subscribe_raw(topic, msgtype, self._callback(topic, msgtype),
                                        _qos(_role(topic, ns), best_effort=best_effort)):
                self.topics[topic] = msgtype

    @property
    def skipped(self) -> dict:
        return dict(self._node.skipped)

    def _callback(self, topic: str, msgtype: str):
        def on_message(data: bytes) -> None:
            self.received += 1
            try:
                self.writer.write(topic, data, msgtype=msgtype)
            except Exception:  # never raise out of a callback; counted
                self.errors += 1
        return on_message

    def close(self) -> None:
        self._node.close()


class RclpyTwinLink:
    """Replay's link to a running twin: publish(topic, msgtype, cdr) on ns/topic, drain() the
    twin's measured_js / jaw/measured_js as (topic, t_clock, JointState). With a recorder, the
    published commands and every state/event topic the twin publishes are recorded too."""

    def __init__(self, command_types: dict[str, str], *, ns: str = DEFAULT_NAMESPACE, recorder=None,
                 clock: Callable[[], float] = time.monotonic, node_name: str = "cressim_replay",
                 sim_clock: bool = False):
        self.ns = ns.strip("/")
        # sim_clock: the twin's /clock (simulated seconds) times commands and samples, so a twin
        # that a busy machine slows down still gets each command at the same simulated time
        self.clock = self.sim_time if sim_clock else clock
        self._sim_ns = None
        self.recorder = recorder
        self._lock = threading.Lock()
        self._samples: list = []
        self.errors = 0
        self._node = _Node(node_name)
        self._publishers = {}
        for rel, msgtype in command_types.items():
            spec = TOPICS_BY_NAME.get(rel)
            depth = 10 if spec is None or spec.role == "command" else None
            self._publishers[rel] = self._node.node.create_publisher(
                message_class(msgtype), self.topic(rel), _qos("command", depth=depth))
            if recorder is not None:
                recorder.add_topic(self.topic(rel), msgtype)
        if sim_clock:
            self._node.subscribe_raw("/clock", "rosgraph_msgs/msg/Clock", self._on_clock, _qos("state", best_effort=True))
        for spec in PSM_TOPICS:
            if spec.role == "command":
                continue
            topic = spec.topic(self.ns)
            self._node.subscribe_raw(topic, spec.msgtype, self._callback(spec.name, topic, spec.msgtype),
                                     _qos(spec.role))

    def topic(self, rel: str) -> str:
        return rel if rel.startswith("/") else f"/{self.ns}/{rel}"

    def _on_clock(self, data: bytes) -> None:
        clock = _types.decode(data, "rosgraph_msgs/msg/Clock").clock
        self._sim_ns = clock.sec * 1_000_000_000 + clock.nanosec

    def sim_time(self) -> float:
        """The twin's simulated time (s) as last seen on /clock; 0 before the first."""
        return (self._sim_ns or 0) * 1e-9

    def _callback(self, rel: str, topic: str, msgtype: str):
        measured = rel in ("measured_js", "jaw/measured_js")

        def on_message(data: bytes) -> None:
            t = self.clock()
            try:
                if self.recorder is not None:
                    self.recorder.write(topic, data, msgtype=msgtype)
                if measured:
                    msg = _types.decode(data, msgtype)
                    with self._lock:
                        self._samples.append((rel, t, msg))
            except Exception:  # never raise out of a callback; counted
                self.errors += 1
        return on_message

    def publish(self, topic: str, msgtype: str, data: bytes) -> None:
        self._publishers[topic].publish(bytes(data))
        if self.recorder is not None:
            self.recorder.write(self.topic(topic), data, msgtype=msgtype)

    def drain(self) -> list:
        with self._lock:
            out, self._samples = self._samples, []
        return out

    def wait_for_twin(self, timeout: float = 10.0) -> list[str]:
        """Wait until the twin subscribes to every command topic and measured_js flows.
        Returns what is still missing after timeout (empty: ready)."""
        deadline = time.monotonic() + timeout
        while True:
            missing = [self.topic(rel) for rel, pub in self._publishers.items() if pub.get_subscription_count() == 0]
            with self._lock:
                flowing = any(rel == "measured_js" for rel, _, _ in self._samples)
            if not flowing:
                missing.append(self.topic("measured_js") + " (no data)")
            if self.clock == self.sim_time and self._sim_ns is None:
                missing.append("/clock (no data: the twin publishes it with the clock sensor group)")
            if not missing or time.monotonic() >= deadline:
                return missing
            time.sleep(0.05)

    def close(self) -> None:
        self._node.close()


__all__ = ["RclpyRecorder", "RclpyTwinLink", "message_class", "rclpy_problem"]
