"""The twin's topics as ROS sees them: QoS profiles and message classes of the one topic table
(cressim.record.schema.PSM_TOPICS, which also drives the recorder and bags/README.md), and the
namespaces of each env.
"""
from __future__ import annotations

import collections
import importlib

from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from cressim.record.schema import PSM_TOPICS, TOPICS_BY_NAME, TopicSpec


def qos(spec: TopicSpec) -> QoSProfile:
    """Reliable, as the dVRK: periodic volatile depth 100; events transient local (a late client
    gets the last operating_state); commands volatile, servo streams latest-wins (depth 1),
    every other command queued (depth 100: a move or state command is never dropped)."""
    durability = DurabilityPolicy.TRANSIENT_LOCAL if spec.role == "event" else DurabilityPolicy.VOLATILE
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=spec.depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=durability)


# Commands that clients publish latched: crtk's state_command is transient local, and crtk sends
# `enable` right after it creates its publisher, so a volatile reader that discovery matches later
# never gets it. The dVRK's own reader is volatile, and so is every other client's writer (ours,
# `ros2 topic pub`): a standing transient-local reader would meet those with an incompatible QoS.
LATCHED_COMMANDS = ("state_command",)
RETRY_S = 0.05  # s, steady (paused or not): the graph looked at again while it lags the reader's matches


class LatchedCommandReader:
    """A command topic read by a volatile reader, which every writer matches, and, only while a
    latched writer has not been caught up with, by a transient-local one that gets its history
    (what it sent before the readers matched). A latched writer is caught up with when a sample
    comes through both readers (its history comes before its live samples) or it is gone; a new
    one is seen through the volatile reader's match events and the graph (its writers' QoS).
    Each sample is passed once: `callback(msg, info, latched)`, latched where it came from the
    history (the writer's last word, however late discovery made it: not stale).

    Between a latched writer's discovery and its next command, a volatile writer that appears is
    told of the transient-local reader (rclpy warns of an incompatible QoS): both kinds of
    client at once, not one alone."""

    SEEN = 64  # samples remembered to pass each once (a latched writer's history is crtk's 10)

    def __init__(self, node, msg_type, topic: str, profile: QoSProfile, callback):
        self.node, self.msg_type, self.topic, self.callback = node, msg_type, topic, callback
        self.latched_profile = QoSProfile(history=profile.history, depth=profile.depth,
                                          reliability=profile.reliability, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.reader = node.create_subscription(
            msg_type, topic, lambda msg, info: self._deliver(msg, info, False), profile,
            event_callbacks=SubscriptionEventCallbacks(matched=lambda status: self._writers_changed()))
        self.catch_up = None  # the transient-local reader, while a latched writer has not been caught up with
        self.retry = None  # a timer while the graph knows fewer writers than the reader matched
        self.served = set()  # latched writers (gids) caught up with or being so
        self.seen = collections.deque(maxlen=self.SEEN)

    def _writers_changed(self):
        try:
            self._look_at_writers()
        except Exception as exc:  # noqa: BLE001 - a callback of the node's must not raise
            if self.node.context.ok():
                self.node.get_logger().error(f"{self.topic}: looking at its writers failed: {exc}",
                                             throttle_duration_sec=1.0)

    def _look_at_writers(self):
        writers = self.node.get_publishers_info_by_topic(self.topic)
        if len(writers) < self.reader.get_publisher_count() and self.retry is None:  # the graph lags discovery
            self.retry = self.node.create_timer(RETRY_S, self._retry, clock=Clock(clock_type=ClockType.STEADY_TIME))
        latched = {bytes(w.endpoint_gid) for w in writers
                   if w.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL}
        if latched - self.served and self.catch_up is None:
            self.catch_up = self.node.create_subscription(self.msg_type, self.topic,
                                                          lambda msg, info: self._deliver(msg, info, True),
                                                          self.latched_profile)
        self.served = latched  # caught up with, or being so; one gone is forgotten
        if not latched:
            self._end_catch_up()

    def _retry(self):
        self.node.destroy_timer(self.retry)
        self.retry = None
        self._writers_changed()

    def _end_catch_up(self):
        if self.catch_up is not None:
            self.node.destroy_subscription(self.catch_up)
            self.catch_up = None

    def _deliver(self, msg, info, latched: bool):
        key = (info.get("source_timestamp"), info.get("publication_sequence_number"))
        if key in self.seen:  # through the other reader too: the latched writers are caught up with
            self._end_catch_up()
            return
        self.seen.append(key)
        self.callback(msg, info, latched)


def on_new_reader(callback) -> PublisherEventCallbacks:
    """Event callbacks that call `callback()` when a reader matches the publisher. The arms'
    operating_state uses it to say the state again: crtk's readers are volatile, so a client that
    commands `enable` right after it starts (dvrk_teleoperation.py) would otherwise miss the
    answer published before its reader matched, and wait for it until its timeout."""
    def matched(status):
        if status.current_count_change > 0:
            callback()
    return PublisherEventCallbacks(matched=matched)


def msg_class(spec: TopicSpec):
    """'sensor_msgs/msg/JointState' -> the rclpy message class."""
    package, kind, name = spec.msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def arm_topics(role: str) -> list[TopicSpec]:
    """Topics under each arm namespace with the given role."""
    return [t for t in PSM_TOPICS if t.role == role and not t.name.startswith("/")]


# Periodic arm topics by sensor group (the `sensors` parameter picks groups).
SENSOR_TOPICS: dict[str, tuple[str, ...]] = {}
for _t in arm_topics("state"):
    SENSOR_TOPICS.setdefault(_t.group, ())
    SENSOR_TOPICS[_t.group] += (_t.name,)

# /clock: reliable depth 1 matches rclpy's time source (best effort) and reliable readers alike.
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
# Images: reliable (a reliable publisher serves best-effort and reliable readers alike) but a
# short queue, since a late frame is worth less than the next one.
IMAGE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)
# Latched once-only topics (/tf_static, /robot_description, labels): depth 1, as tf2's static
# broadcaster and robot_state_publisher.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
CRTK_VERSION = "1.1.0"
CLOCK_TOPIC = "/clock"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
ROBOT_DESCRIPTION_TOPIC = "/robot_description"
DIAGNOSTICS_TOPIC = "/diagnostics"
SERVICES = ("operating_state", "crtk_version", "forward_kinematics", "local/forward_kinematics",
            "inverse_kinematics")
CONSOLE_NAMESPACES = ("/console", "/system")  # dVRK 2.3 renamed the console `system`; both answer


def env_namespaces(arm: str, num_envs: int) -> list[list[str]]:
    """The namespaces of each env: env i is /env{i}/ARM; a single env is also plain /ARM."""
    if num_envs == 1:
        return [[f"/{arm}", f"/env0/{arm}"]]
    return [[f"/env{i}/{arm}"] for i in range(num_envs)]


def env_frame_prefix(env: int, num_envs: int) -> str:
    """Prefix of an env's frame ids: '' for a single env, 'env3/' in batched mode."""
    return "" if num_envs == 1 else f"env{env}/"


def env_topic(topic: str, env: int, num_envs: int) -> str:
    """A global topic of one env: /camera/... for a single env, /env3/camera/... in batched mode."""
    return topic if num_envs == 1 else f"/env{env}{topic}"


__all__ = ["CLOCK_QOS", "CLOCK_TOPIC", "CONSOLE_NAMESPACES", "CRTK_VERSION", "DIAGNOSTICS_TOPIC", "IMAGE_QOS",
           "LATCHED_QOS", "ROBOT_DESCRIPTION_TOPIC", "SENSOR_TOPICS", "SERVICES", "TF_STATIC_TOPIC", "TF_TOPIC",
           "TOPICS_BY_NAME", "arm_topics", "env_frame_prefix", "env_namespaces", "env_topic", "msg_class", "qos",
           "LATCHED_COMMANDS", "LatchedCommandReader", "on_new_reader"]


def fill_pose(pose, p):
    """A geometry_msgs Pose from x, y, z, qx, qy, qz, qw."""
    pose.position.x, pose.position.y, pose.position.z = float(p[0]), float(p[1]), float(p[2])
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (
        float(p[3]), float(p[4]), float(p[5]), float(p[6]))
