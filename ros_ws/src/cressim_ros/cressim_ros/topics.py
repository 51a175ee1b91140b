"""Topic and service names, QoS profiles and namespaces of the twin (the dVRK's, see DVRK.md).

Kept in one place so that the node, the tests and docs/twin.md agree on them.
"""
from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

# Periodic state (measured_js, ...): reliable, volatile, depth 100, as the dVRK publishes them.
PERIODIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
# Events (operating_state, error, ...): transient local, so that a client that connects late
# still gets the last operating state (the dVRK client waits on it right after connecting).
EVENT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
# Commands: depth 1; a servo stream only ever needs the newest sample.
COMMAND_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
# /clock: reliable depth 1 matches rclpy's time source (best effort) and reliable readers alike.
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.VOLATILE)

# Periodic topics by sensor group (the `sensors` parameter picks groups).
SENSOR_TOPICS = {
    "joints": ("measured_js", "setpoint_js", "jaw/measured_js", "jaw/setpoint_js"),
    "cartesian": ("measured_cp", "setpoint_cp", "local/measured_cp", "local/setpoint_cp"),
    "velocity": ("measured_cv",),
    "wrench": ("body/measured_cf", "spatial/measured_cf"),
    "jacobian": ("body/jacobian", "spatial/jacobian"),
}
EVENT_TOPICS = ("operating_state", "desired_state", "goal_reached", "error", "warning", "status")
# Every command topic a dVRK client may open gets a subscription (clients check that each of
# their publishers has a peer); the ones the kinematic twin cannot do answer with a warning.
COMMAND_TOPICS = ("state_command", "servo_jp", "servo_jr", "move_jp", "move_jr", "servo_cp", "move_cp",
                  "jaw/servo_jp", "jaw/move_jp", "hold", "free", "servo_jf", "jaw/servo_jf", "body/servo_cf",
                  "spatial/servo_cf", "set_base_frame", "trajectory_j/set_ratio")
SERVICES = ("operating_state", "crtk_version", "forward_kinematics", "local/forward_kinematics",
            "inverse_kinematics")
CRTK_VERSION = "1.1.0"
CLOCK_TOPIC = "/clock"
# tf: base -> tip of every env on /tf at the tf rate (one TFMessage per tick for all envs);
# world -> base and world -> camera of every env once on /tf_static (transient local, depth 1,
# as tf2's static broadcaster). tf2_msgs is built in ros_ws (no Jazzy wheel ships it).
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
TF_STATIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)


def env_namespaces(arm: str, num_envs: int) -> list[list[str]]:
    """The namespaces of each env: env i is /env{i}/ARM; a single env is also plain /ARM."""
    if num_envs == 1:
        return [[f"/{arm}", f"/env0/{arm}"]]
    return [[f"/env{i}/{arm}"] for i in range(num_envs)]


def env_frame_prefix(env: int, num_envs: int) -> str:
    """Prefix of an env's frame ids: '' for a single env, 'env3/' in batched mode."""
    return "" if num_envs == 1 else f"env{env}/"


__all__ = ["CLOCK_QOS", "CLOCK_TOPIC", "COMMAND_QOS", "COMMAND_TOPICS", "CRTK_VERSION", "EVENT_QOS", "EVENT_TOPICS",
           "PERIODIC_QOS", "SENSOR_TOPICS", "SERVICES", "TF_STATIC_QOS", "TF_STATIC_TOPIC", "TF_TOPIC", "env_frame_prefix", "env_namespaces"]
