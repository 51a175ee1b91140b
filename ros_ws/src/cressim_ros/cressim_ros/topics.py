"""The twin's topics as ROS sees them: QoS profiles and message classes of the one topic table
(cressim.record.schema.PSM_TOPICS, which also drives the recorder and bags/README.md), and the
namespaces of each env.
"""
from __future__ import annotations

import importlib

from rclpy.event_handler import PublisherEventCallbacks
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from cressim.record.schema import PSM_TOPICS, TOPICS_BY_NAME, TopicSpec


def qos(spec: TopicSpec) -> QoSProfile:
    """Reliable, as the dVRK: periodic volatile depth 100; events transient local (a late client
    gets the last operating_state); commands volatile, servo streams latest-wins (depth 1),
    every other command queued (depth 100: a move or state command is never dropped)."""
    durability = DurabilityPolicy.TRANSIENT_LOCAL if spec.role == "event" else DurabilityPolicy.VOLATILE
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=spec.depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=durability)


# Commands that clients publish latched (crtk's state_command is transient local): each also gets
# a transient-local reader, which only latched writers match and which receives a command sent
# before the readers matched (crtk sends `enable` right after creating its publisher; a volatile
# reader loses it while discovery runs), however late: it is not refused as stale. Both readers
# see a latched writer's later ones: `FirstDelivery` passes each (stamp, command) once.
LATCHED_COMMANDS = ("state_command",)


def latched_reader_qos(spec: TopicSpec) -> QoSProfile:
    profile = qos(spec)
    profile.durability = DurabilityPolicy.TRANSIENT_LOCAL
    return profile


class FirstDelivery:
    """Whether a latched command (a StringStamped) is new on its channel, or the same message
    arriving through the other reader."""

    def __init__(self):
        self.last = {}

    def first(self, channel, msg) -> bool:
        key = (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.string)
        if self.last.get(channel) == key:
            return False
        self.last[channel] = key
        return True


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
           "FirstDelivery", "LATCHED_COMMANDS", "latched_reader_qos", "on_new_reader"]


def fill_pose(pose, p):
    """A geometry_msgs Pose from x, y, z, qx, qy, qz, qw."""
    pose.position.x, pose.position.y, pose.position.z = float(p[0]), float(p[1]), float(p[2])
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (
        float(p[3]), float(p[4]), float(p[5]), float(p[6]))
