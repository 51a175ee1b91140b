"""The dataset schema: which topics a PSM recording holds, their types, rates, frames and units.

One table (``PSM_TOPICS``) drives the recorder's default topic list, the QoS written into a
bag, replay's choice of command topics, and the table in bags/README.md (``schema_markdown``;
tests/record check that the README shows this very table). Topic names are relative to the
arm namespace (``/PSM1`` by default); ``/tf`` is absolute.
"""
from __future__ import annotations

from typing import NamedTuple

ARM_JOINTS = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")
OLD_ARM_JOINTS = ("outer_yaw", "outer_pitch", "outer_insertion", "outer_roll", "outer_wrist_pitch",
                  "outer_wrist_yaw")
JAW_JOINTS = ("jaw",)
JOINT_UNITS = {"yaw": "rad", "pitch": "rad", "insertion": "m", "roll": "rad", "wrist_pitch": "rad",
               "wrist_yaw": "rad", "jaw": "rad"}
_CANONICAL = {**dict(zip(OLD_ARM_JOINTS, ARM_JOINTS)), **{n: n for n in ARM_JOINTS + JAW_JOINTS}}

DEFAULT_NAMESPACE = "PSM1"
BASE_FRAME = "{ns}_base"  # frame 0, at the remote centre of motion
TIP_FRAME = "{ns}"
CAMERA_FRAME = "camera_color_optical_frame"

JS_UNITS = "position rad (insertion m); velocity rad/s (m/s); effort N m (N)"
JAW_UNITS = "position rad; velocity rad/s; effort N m"
POSE_UNITS = "position m; orientation unit quaternion (x, y, z, w)"


class TopicSpec(NamedTuple):
    name: str  # relative to the arm namespace unless it starts with '/'
    msgtype: str
    role: str  # "state" (twin publishes, periodic), "event" (twin publishes on change), "command"
    rate: str  # "100 Hz", "50 Hz", "on change", "as sent"
    frame: str  # header.frame_id ({ns} = namespace), "" where the message has none
    units: str
    note: str = ""

    def topic(self, ns: str = DEFAULT_NAMESPACE) -> str:
        """The absolute topic name in namespace ns ('PSM1' or '/PSM1')."""
        if self.name.startswith("/"):
            return self.name
        return f"/{ns.strip('/')}/{self.name}"

    def frame_id(self, ns: str = DEFAULT_NAMESPACE) -> str:
        return self.frame.format(ns=ns.strip("/"))

    @property
    def qos(self) -> dict:
        """QoS the twin offers (state/event) or a client offers (command), rosbag2 v9 layout."""
        return qos_dict(depth=1 if self.role == "command" else 100,
                        durability="transient_local" if self.role == "event" else "volatile")


_JS, _PS, _WS = "sensor_msgs/msg/JointState", "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/WrenchStamped"
_STR = "std_msgs/msg/String"
_IMG, _INFO = "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo"

PSM_TOPICS: tuple[TopicSpec, ...] = (
    # published by the twin, periodic (QoS reliable, volatile, depth 100)
    TopicSpec("measured_js", _JS, "state", "100 Hz", "", JS_UNITS, "6 arm joints, names " + ", ".join(ARM_JOINTS)),
    TopicSpec("setpoint_js", _JS, "state", "100 Hz", "", JS_UNITS, "controller setpoint, same layout"),
    TopicSpec("jaw/measured_js", _JS, "state", "100 Hz", "", JAW_UNITS, 'name ["jaw"]'),
    TopicSpec("jaw/setpoint_js", _JS, "state", "100 Hz", "", JAW_UNITS, 'name ["jaw"]'),
    TopicSpec("measured_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "tool tip in the base frame"),
    TopicSpec("setpoint_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "tool-tip setpoint"),
    TopicSpec("local/measured_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "relative to the RCM frame"),
    TopicSpec("local/setpoint_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "relative to the RCM frame"),
    TopicSpec("measured_cv", "geometry_msgs/msg/TwistStamped", "state", "100 Hz", BASE_FRAME,
              "linear m/s; angular rad/s", "tool-tip twist"),
    TopicSpec("body/measured_cf", _WS, "state", "100 Hz", TIP_FRAME, "force N; torque N m", "in the tool-tip frame"),
    TopicSpec("spatial/measured_cf", _WS, "state", "100 Hz", BASE_FRAME, "force N; torque N m", "in the base frame"),
    TopicSpec("body/jacobian", "std_msgs/msg/Float64MultiArray", "state", "100 Hz", "",
              "rows [v m/s; w rad/s] per unit joint rate", "6x6, row-major, layout dims rows/cols"),
    TopicSpec("spatial/jacobian", "std_msgs/msg/Float64MultiArray", "state", "100 Hz", "",
              "rows [v m/s; w rad/s] per unit joint rate", "6x6, row-major"),
    TopicSpec("/tf", "tf2_msgs/msg/TFMessage", "state", "50 Hz", BASE_FRAME, POSE_UNITS,
              "{ns}_base -> {ns} (child_frame_id {ns})"),
    # the camera (one per env; docs/twin.md, "Camera"): all three products share one intrinsics
    TopicSpec("/camera/color/image_raw", _IMG, "state", "30 Hz", CAMERA_FRAME, "rgb8", "640x480 by default"),
    TopicSpec("/camera/color/camera_info", _INFO, "state", "30 Hz", CAMERA_FRAME, "K, P in pixels",
              "ROS pixel convention (pixel centres at integers), no distortion"),
    TopicSpec("/camera/depth/image_raw", _IMG, "state", "30 Hz", CAMERA_FRAME, "32FC1, m along the optical axis",
              "NaN where nothing was hit (REP 118)"),
    TopicSpec("/camera/depth/camera_info", _INFO, "state", "30 Hz", CAMERA_FRAME, "K, P in pixels", "as color"),
    TopicSpec("/camera/segmentation/image_raw", _IMG, "state", "30 Hz", CAMERA_FRAME, "16UC1 label ids",
              "0 background; names on /camera/segmentation/labels"),
    TopicSpec("/camera/segmentation/camera_info", _INFO, "state", "30 Hz", CAMERA_FRAME, "K, P in pixels", "as color"),
    TopicSpec("/ultrasound/image_raw", _IMG, "state", "10 Hz", "ultrasound_probe", "mono8 B-mode brightness",
              "with the ultrasound sensor group; 50 dB dynamic range"),
    # published by the twin on change (QoS reliable, transient local, depth 100)
    TopicSpec("operating_state", "crtk_msgs/msg/OperatingState", "event", "on change", "", "-",
              "state DISABLED/ENABLED/PAUSED/FAULT, is_homed, is_busy"),
    TopicSpec("desired_state", _STR, "event", "on change", "", "-"),
    TopicSpec("goal_reached", "std_msgs/msg/Bool", "event", "on change", "", "-", "after each move_*"),
    TopicSpec("error", _STR, "event", "on change", "", "-"),
    TopicSpec("warning", _STR, "event", "on change", "", "-"),
    TopicSpec("status", _STR, "event", "on change", "", "-"),
    TopicSpec("/tf_static", "tf2_msgs/msg/TFMessage", "event", "once", "world", POSE_UNITS,
              "world -> {ns}_base (the scene's base pose), world -> " + CAMERA_FRAME),
    TopicSpec("/camera/segmentation/labels", _STR, "event", "once", "", "-", "JSON object, label id -> name"),
    # commands sent to the arm by clients (QoS reliable, volatile, depth 1)
    TopicSpec("state_command", "crtk_msgs/msg/StringStamped", "command", "as sent", "", "-",
              "enable, disable, home, unhome, pause, resume"),
    TopicSpec("servo_jp", _JS, "command", "as sent", "", JS_UNITS, "names optional (then arm order)"),
    TopicSpec("servo_jr", _JS, "command", "as sent", "", JS_UNITS, "relative to the current setpoint"),
    TopicSpec("move_jp", _JS, "command", "as sent", "", JS_UNITS, "goal of an interpolated move"),
    TopicSpec("move_jr", _JS, "command", "as sent", "", JS_UNITS, "relative goal"),
    TopicSpec("servo_cp", _PS, "command", "as sent", BASE_FRAME, POSE_UNITS, "in the measured_cp frame"),
    TopicSpec("move_cp", _PS, "command", "as sent", BASE_FRAME, POSE_UNITS, "in the measured_cp frame"),
    TopicSpec("servo_jf", _JS, "command", "as sent", "", "effort N m (N)", "efforts only"),
    TopicSpec("jaw/servo_jp", _JS, "command", "as sent", "", JAW_UNITS, "one value"),
    TopicSpec("jaw/move_jp", _JS, "command", "as sent", "", JAW_UNITS, "one value"),
    TopicSpec("jaw/servo_jf", _JS, "command", "as sent", "", "effort N m", "one value"),
    TopicSpec("body/servo_cf", _WS, "command", "as sent", TIP_FRAME, "force N; torque N m"),
    TopicSpec("spatial/servo_cf", _WS, "command", "as sent", BASE_FRAME, "force N; torque N m"),
    TopicSpec("hold", "std_msgs/msg/Empty", "command", "as sent", "", "-"),
    TopicSpec("free", "std_msgs/msg/Empty", "command", "as sent", "", "-"),
    TopicSpec("set_base_frame", _PS, "command", "as sent", "", POSE_UNITS, "new base frame"),
    TopicSpec("trajectory_j/set_ratio", "std_msgs/msg/Float64", "command", "as sent", "", "ratio 0..1",
              "scales move_j* velocity/acceleration"),
)

TOPICS_BY_NAME = {t.name: t for t in PSM_TOPICS}

# commands that define a joint-space position reference, and the joints they address
POSITION_COMMANDS = {"servo_jp": ARM_JOINTS, "move_jp": ARM_JOINTS, "jaw/servo_jp": JAW_JOINTS,
                     "jaw/move_jp": JAW_JOINTS}
# a real robot's setpoints, replayed as servo commands with `--from-setpoint`
SETPOINT_AS_COMMAND = {"setpoint_js": "servo_jp", "jaw/setpoint_js": "jaw/servo_jp"}
# what the twin reports for each joint group
MEASURED_FOR = {ARM_JOINTS: "measured_js", JAW_JOINTS: "jaw/measured_js"}

INFINITE = {"sec": 9223372036, "nsec": 854775807}  # rmw's "infinite" duration in rosbag2 metadata


def qos_dict(*, depth: int, durability: str = "volatile", reliability: str = "reliable") -> dict:
    """One offered QoS profile as rosbag2 (metadata version 9, Jazzy) writes it."""
    return {
        "history": "keep_last", "depth": depth, "reliability": reliability, "durability": durability,
        "deadline": dict(INFINITE), "lifespan": dict(INFINITE), "liveliness": "automatic",
        "liveliness_lease_duration": dict(INFINITE), "avoid_ros_namespace_conventions": False,
    }


def relative_name(topic: str, ns: str = DEFAULT_NAMESPACE) -> str:
    """'/PSM1/jaw/servo_jp' -> 'jaw/servo_jp'; topics outside ns are returned unchanged."""
    prefix = f"/{ns.strip('/')}/"
    return topic[len(prefix):] if topic.startswith(prefix) else topic


def spec_for(topic: str, ns: str = DEFAULT_NAMESPACE) -> TopicSpec | None:
    """The schema entry of an absolute topic in namespace ns, or None."""
    return TOPICS_BY_NAME.get(relative_name(topic, ns)) or TOPICS_BY_NAME.get(topic)


def topics(ns: str = DEFAULT_NAMESPACE, roles=("state", "event", "command")) -> dict[str, str]:
    """{absolute topic: msgtype} of the schema's topics with the given roles."""
    return {t.topic(ns): t.msgtype for t in PSM_TOPICS if t.role in roles}


def canonical_joint(name: str) -> str:
    """'outer_yaw' -> 'yaw' (dVRK 2.2 names); 2.3 names and 'jaw' pass through."""
    try:
        return _CANONICAL[name]
    except KeyError:
        raise ValueError(f"unknown PSM joint {name!r}") from None


def schema_markdown(ns: str = DEFAULT_NAMESPACE) -> str:
    """The topic table of bags/README.md (Markdown), generated from PSM_TOPICS."""
    head = ("| topic | type | role | rate | frame_id | units | notes |\n"
            "|---|---|---|---|---|---|---|\n")
    rows = []
    for t in PSM_TOPICS:
        frame = f"`{t.frame_id(ns)}`" if t.frame else "-"
        rows.append(f"| `{t.topic(ns)}` | `{t.msgtype}` | {t.role} | {t.rate} | {frame} | {t.units} | "
                    f"{t.note.format(ns=ns) or '-'} |")
    return head + "\n".join(rows) + "\n"


__all__ = [
    "ARM_JOINTS", "DEFAULT_NAMESPACE", "JAW_JOINTS", "JOINT_UNITS", "MEASURED_FOR", "OLD_ARM_JOINTS",
    "POSITION_COMMANDS", "PSM_TOPICS", "SETPOINT_AS_COMMAND", "TOPICS_BY_NAME", "TopicSpec",
    "canonical_joint", "qos_dict", "relative_name", "schema_markdown", "spec_for", "topics",
]
