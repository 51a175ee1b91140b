"""The twin's topic table: every topic the PSM twin publishes or subscribes, its type, rate,
frame, units and sensor group.

One table (``PSM_TOPICS``) drives the twin node's publishers and subscriptions (cressim_ros),
the recorder's default topic list, the QoS written into a bag, replay's choice of command
topics, and the table in bags/README.md (``schema_markdown``; tests/record check that the
README shows this very table). Topic names are relative to the
arm namespace (``/PSM1`` by default); ``/tf`` is absolute.
"""
from __future__ import annotations

from typing import NamedTuple

from ..robots.dvrk import JAW_JOINTS, JOINT_UNITS, PSM_JOINTS as ARM_JOINTS, PSM_OLD_JOINTS as OLD_ARM_JOINTS
from ..robots.dvrk import canonical_joint_name

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
    group: str = ""  # the `sensors` group that switches a periodic topic on ("" for events and commands)

    def topic(self, ns: str = DEFAULT_NAMESPACE) -> str:
        """The absolute topic name in namespace ns ('PSM1' or '/PSM1')."""
        if self.name.startswith("/"):
            return self.name
        return f"/{ns.strip('/')}/{self.name}"

    def frame_id(self, ns: str = DEFAULT_NAMESPACE) -> str:
        return self.frame.format(ns=ns.strip("/"))

    @property
    def depth(self) -> int:
        """Queue depth: servo streams are latest-wins (depth 1, as the dVRK's), every other
        command is queued (a move or state command is never dropped), state and events 100."""
        return 1 if self.name in LATEST_WINS else 100

    @property
    def qos(self) -> dict:
        """QoS the twin offers (state/event) or a client offers (command), rosbag2 v9 layout."""
        return qos_dict(depth=self.depth, durability="transient_local" if self.role == "event" else "volatile")


_JS, _PS, _WS = "sensor_msgs/msg/JointState", "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/WrenchStamped"
_STR = "std_msgs/msg/String"
_IMG, _INFO = "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo"

_F64, _BOOL, _EMPTY = "std_msgs/msg/Float64", "std_msgs/msg/Bool", "std_msgs/msg/Empty"
_CIMG = "sensor_msgs/msg/CompressedImage"
LATEST_WINS = frozenset({"servo_jp", "servo_jr", "servo_cp", "servo_cv", "servo_jf", "jaw/servo_jp", "jaw/servo_jf",
                         "body/servo_cf", "spatial/servo_cf", "suction/servo_jp"})

PSM_TOPICS: tuple[TopicSpec, ...] = (
    # published by the twin, periodic (QoS reliable, volatile, depth 100)
    TopicSpec("measured_js", _JS, "state", "100 Hz", "", JS_UNITS, "6 arm joints, names " + ", ".join(ARM_JOINTS),
              "joints"),
    TopicSpec("setpoint_js", _JS, "state", "100 Hz", "", JS_UNITS, "controller setpoint, same layout", "joints"),
    TopicSpec("jaw/measured_js", _JS, "state", "100 Hz", "", JAW_UNITS, 'name ["jaw"]', "joints"),
    TopicSpec("jaw/setpoint_js", _JS, "state", "100 Hz", "", JAW_UNITS, 'name ["jaw"]', "joints"),
    TopicSpec("suction/measured_js", _JS, "state", "100 Hz", "", "position: valve 0 (shut) .. 1 (open); effort: "
              "fluid particles removed so far", 'name ["suction"]; the suction tool in a world with fluid', "joints"),
    TopicSpec("measured_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "tool tip in the base frame", "cartesian"),
    TopicSpec("setpoint_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "tool-tip setpoint", "cartesian"),
    TopicSpec("local/measured_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "relative to the RCM frame",
              "cartesian"),
    TopicSpec("local/setpoint_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "relative to the RCM frame",
              "cartesian"),
    TopicSpec("measured_cv", "geometry_msgs/msg/TwistStamped", "state", "100 Hz", BASE_FRAME,
              "linear m/s; angular rad/s", "tool-tip twist", "velocity"),
    TopicSpec("body/measured_cf", _WS, "state", "100 Hz", TIP_FRAME, "force N; torque N m", "in the tool-tip frame",
              "wrench"),
    TopicSpec("spatial/measured_cf", _WS, "state", "100 Hz", BASE_FRAME, "force N; torque N m", "in the base frame",
              "wrench"),
    TopicSpec("body/jacobian", "std_msgs/msg/Float64MultiArray", "state", "100 Hz", "",
              "rows [v m/s; w rad/s] per unit joint rate", "6x6, row-major, layout dims rows/cols", "jacobian"),
    TopicSpec("spatial/jacobian", "std_msgs/msg/Float64MultiArray", "state", "100 Hz", "",
              "rows [v m/s; w rad/s] per unit joint rate", "6x6, row-major", "jacobian"),
    TopicSpec("/tf", "tf2_msgs/msg/TFMessage", "state", "50 Hz", BASE_FRAME, POSE_UNITS,
              "{ns}_base -> {ns} (child_frame_id {ns}), and every URDF link from its parent link", "tf"),
    TopicSpec("/joint_states", _JS, "state", "50 Hz", "", JS_UNITS,
              "every URDF joint, mimic joints included (as robot_state_publisher reads it)", "tf"),
    # the camera (one per env; docs/twin.md, "Camera"): all three products share one intrinsics
    TopicSpec("/camera/color/image_raw", _IMG, "state", "30 Hz", CAMERA_FRAME, "rgb8", "640x480 by default", "color"),
    TopicSpec("/camera/color/image_raw/compressed", _CIMG, "state", "30 Hz", CAMERA_FRAME, "JPEG",
              "image_transport `compressed`; encoded only while subscribed", "color"),
    TopicSpec("/camera/color/camera_info", _INFO, "state", "30 Hz", CAMERA_FRAME, "K, P in pixels",
              "ROS pixel convention (pixel centres at integers), no distortion", "color"),
    TopicSpec("/camera/depth/image_raw", _IMG, "state", "30 Hz", CAMERA_FRAME, "32FC1, m along the optical axis",
              "NaN where nothing was hit (REP 118)", "depth"),
    TopicSpec("/camera/depth/image_raw/compressedDepth", _CIMG, "state", "30 Hz", CAMERA_FRAME,
              "inverse depth in 16-bit PNG", "image_transport `compressedDepth`; encoded only while subscribed", "depth"),
    TopicSpec("/camera/depth/camera_info", _INFO, "state", "30 Hz", CAMERA_FRAME, "K, P in pixels", "as color", "depth"),
    TopicSpec("/camera/segmentation/image_raw", _IMG, "state", "30 Hz", CAMERA_FRAME, "16UC1 label ids",
              "0 background; names on /camera/segmentation/labels", "segmentation"),
    TopicSpec("/camera/segmentation/image_raw/compressed", _CIMG, "state", "30 Hz", CAMERA_FRAME, "16-bit PNG",
              "image_transport `compressed`; encoded only while subscribed", "segmentation"),
    TopicSpec("/camera/segmentation/camera_info", _INFO, "state", "30 Hz", CAMERA_FRAME, "K, P in pixels", "as color",
              "segmentation"),
    TopicSpec("/ultrasound/image_raw", _IMG, "state", "10 Hz", "ultrasound_probe", "mono8 B-mode brightness",
              "with the ultrasound sensor group; 50 dB dynamic range", "ultrasound"),
    TopicSpec("/ultrasound/image_raw/compressed", _CIMG, "state", "10 Hz", "ultrasound_probe", "PNG",
              "image_transport `compressed`; encoded only while subscribed", "ultrasound"),
    TopicSpec("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", "state", "1 Hz", "", "-",
              "tick time, rates, frames rendered and skipped, refusals"),
    # published by the twin on change (QoS reliable, transient local, depth 100)
    TopicSpec("operating_state", "crtk_msgs/msg/OperatingState", "event", "on change", "", "-",
              "state DISABLED/ENABLED/PAUSED/FAULT, is_homed, is_busy"),
    TopicSpec("desired_state", _STR, "event", "on change", "", "-"),
    TopicSpec("goal_reached", _BOOL, "event", "on change", "", "-", "after each move_*"),
    TopicSpec("error", _STR, "event", "on change", "", "-"),
    TopicSpec("warning", _STR, "event", "on change", "", "-"),
    TopicSpec("status", _STR, "event", "on change", "", "-"),
    TopicSpec("trajectory_j/ratio", _F64, "event", "on change", "", "ratio 0..1", "min of ratio_v and ratio_a"),
    TopicSpec("trajectory_j/ratio_v", _F64, "event", "on change", "", "ratio 0..1", "of the velocity limits"),
    TopicSpec("trajectory_j/ratio_a", _F64, "event", "on change", "", "ratio 0..1", "of the acceleration limits"),
    TopicSpec("tool_type", _STR, "event", "on change", "", "-", "the instrument, e.g. LARGE_NEEDLE_DRIVER:400006"),
    TopicSpec("manip_clutch", "sensor_msgs/msg/Joy", "event", "on change", "", "-",
              "the arm's clutch button (never pressed in the twin)"),
    TopicSpec("/tf_static", "tf2_msgs/msg/TFMessage", "event", "once", "world", POSE_UNITS,
              "world -> {ns}_base (the scene's base pose), world -> " + CAMERA_FRAME),
    TopicSpec("/robot_description", _STR, "event", "once", "", "-", "the arm's URDF (as robot_state_publisher)"),
    TopicSpec("/camera/segmentation/labels", _STR, "event", "once", "", "-", "JSON object, label id -> name"),
    TopicSpec("/console/teleop/enabled", _BOOL, "event", "on change", "", "-", "teleoperation state"),
    TopicSpec("/console/teleop/scale", _F64, "event", "on change", "", "-", "teleoperation scale"),
    TopicSpec("/console/teleop/selected", _STR, "event", "on change", "", "-", "a selected MTM-PSM pair"),
    TopicSpec("/console/teleop/unselected", _STR, "event", "on change", "", "-", "an unselected pair"),
    # commands sent to the arm by clients (QoS reliable, volatile; servo streams depth 1, others 100)
    TopicSpec("state_command", "crtk_msgs/msg/StringStamped", "command", "as sent", "", "-",
              "enable, disable, home, unhome, pause, resume"),
    TopicSpec("servo_jp", _JS, "command", "as sent", "", JS_UNITS, "names optional (then arm order)"),
    TopicSpec("servo_jr", _JS, "command", "as sent", "", JS_UNITS, "relative to the current setpoint"),
    TopicSpec("move_jp", _JS, "command", "as sent", "", JS_UNITS, "goal of an interpolated move"),
    TopicSpec("move_jr", _JS, "command", "as sent", "", JS_UNITS, "relative goal"),
    TopicSpec("servo_cp", _PS, "command", "as sent", BASE_FRAME, POSE_UNITS, "in the measured_cp frame"),
    TopicSpec("move_cp", _PS, "command", "as sent", BASE_FRAME, POSE_UNITS, "in the measured_cp frame"),
    TopicSpec("servo_cv", "geometry_msgs/msg/TwistStamped", "command", "as sent", BASE_FRAME,
              "linear m/s; angular rad/s", "tool-tip twist, integrated each tick until the next"),
    TopicSpec("servo_jf", _JS, "command", "as sent", "", "effort N m (N)", "efforts only (answered with a warning)"),
    TopicSpec("jaw/servo_jp", _JS, "command", "as sent", "", JAW_UNITS, "one value, clipped to the jaw's limits"),
    TopicSpec("jaw/move_jp", _JS, "command", "as sent", "", JAW_UNITS, "one value, clipped to the jaw's limits"),
    TopicSpec("jaw/servo_jf", _JS, "command", "as sent", "", "effort N m", "one value (answered with a warning)"),
    TopicSpec("suction/servo_jp", _JS, "command", "as sent", "", "valve 0 (shut) .. 1 (open)",
              "one value; the suction tool removes fluid at its tip while > 0"),
    TopicSpec("body/servo_cf", _WS, "command", "as sent", TIP_FRAME, "force N; torque N m", "answered with a warning"),
    TopicSpec("spatial/servo_cf", _WS, "command", "as sent", BASE_FRAME, "force N; torque N m",
              "answered with a warning"),
    TopicSpec("hold", _EMPTY, "command", "as sent", "", "-"),
    TopicSpec("free", _EMPTY, "command", "as sent", "", "-", "answered with a warning"),
    TopicSpec("set_base_frame", _PS, "command", "as sent", "", POSE_UNITS, "new base frame"),
    TopicSpec("trajectory_j/set_ratio", _F64, "command", "as sent", "", "ratio 0..1",
              "scales move_j* velocity and acceleration"),
    TopicSpec("trajectory_j/set_ratio_v", _F64, "command", "as sent", "", "ratio 0..1", "velocity only"),
    TopicSpec("trajectory_j/set_ratio_a", _F64, "command", "as sent", "", "ratio 0..1", "acceleration only"),
    TopicSpec("use_gravity_compensation", _BOOL, "command", "as sent", "", "-", "kept (no effort control)"),
    TopicSpec("body/set_cf_orientation_absolute", _BOOL, "command", "as sent", "", "-", "kept (no effort control)"),
    TopicSpec("emulate_tool_present", _BOOL, "command", "as sent", "", "-", "kept; the twin's tool is always there"),
    TopicSpec("emulate_adapter_present", _BOOL, "command", "as sent", "", "-", "kept"),
    TopicSpec("set_tool_type", _STR, "command", "as sent", "", "-", "must name the twin's instrument"),
    TopicSpec("/console/power_off", _EMPTY, "command", "as sent", "", "-", "disable every arm (also /system/...)"),
    TopicSpec("/console/power_on", _EMPTY, "command", "as sent", "", "-", "enable every arm (also /system/...)"),
    TopicSpec("/console/home", _EMPTY, "command", "as sent", "", "-", "home every arm (also /system/...)"),
    TopicSpec("/console/set_volume", _F64, "command", "as sent", "", "volume 0..1",
              "logged: the twin has no speaker (also /system/...)"),
    TopicSpec("/console/beep", "std_msgs/msg/Float64MultiArray", "command", "as sent", "",
              "[duration s, frequency Hz, volume 0..1]", "logged: the twin has no speaker (also /system/...)"),
    TopicSpec("/console/string_to_speech", _STR, "command", "as sent", "", "-",
              "logged: the twin has no speaker (also /system/...)"),
    TopicSpec("/console/teleop/enable", _BOOL, "command", "as sent", "", "-", "refused with a warning: no MTM"),
    TopicSpec("/console/teleop/set_scale", _F64, "command", "as sent", "", "-", "kept, echoed on teleop/scale"),
    TopicSpec("/console/teleop/select", _STR, "command", "as sent", "", "-", "echoed on teleop/selected"),
    TopicSpec("/console/teleop/unselect", _STR, "command", "as sent", "", "-", "echoed on teleop/unselected"),
    TopicSpec("/footpedals/coag", "sensor_msgs/msg/Joy", "command", "as sent", "", "buttons[0]: 1 pressed, 0 released",
              "the coagulation pedal (the dVRK console's): energizes the needle driver over tissue with heat "
              "(arm.cautery; batched: /envN/footpedals/coag)"),
)

TOPICS_BY_NAME = {t.name: t for t in PSM_TOPICS}

# The patient cart's topics beyond its arms' (docs/twin.md, "Patient cart"). The ECM speaks the
# PSM's names above (4 joints, no jaw). An MTM's (relative to /MTML, /MTMR) besides the PSM's
# events, state_command and services; the console's buttons; the operator's input (an input
# device, or a test, is the surgeon; {mtm} is MTML or MTMR).
_JOY, _QUAT = "sensor_msgs/msg/Joy", "geometry_msgs/msg/Quaternion"
BUTTON_UNITS = "buttons[0]: 1 pressed, 0 released"
MTM_TOPICS: tuple[TopicSpec, ...] = (
    TopicSpec("measured_js", _JS, "state", "100 Hz", "", "rad",
              "the 7 joints (outer_yaw .. wrist_roll; dVRK DH, cressim.robots.mtm)"),
    TopicSpec("setpoint_js", _JS, "state", "100 Hz", "", "rad", "as measured_js (no lag)"),
    TopicSpec("local/measured_cp", _PS, "state", "100 Hz", "", POSE_UNITS, "the grip in the DH base: FK of measured_js"),
    TopicSpec("measured_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "the grip in the MTM's base frame"),
    TopicSpec("setpoint_cp", _PS, "state", "100 Hz", BASE_FRAME, POSE_UNITS, "as measured_cp"),
    TopicSpec("gripper/measured_js", _JS, "state", "100 Hz", "", JAW_UNITS, 'name ["gripper"]'),
    TopicSpec("move_cp", _PS, "command", "as sent", BASE_FRAME, POSE_UNITS, "the wrist turns the grip there"),
    TopicSpec("servo_cp", _PS, "command", "as sent", BASE_FRAME, POSE_UNITS, "as move_cp"),
    TopicSpec("body/servo_cf", _WS, "command", "as sent", "", "force N; torque N m", "zero: the hand moves it"),
    TopicSpec("lock_orientation", _QUAT, "command", "as sent", "", "unit quaternion (x, y, z, w)",
              "the grip keeps this orientation"),
    TopicSpec("unlock_orientation", _EMPTY, "command", "as sent", "", "-", ""),
    TopicSpec("use_gravity_compensation", _BOOL, "command", "as sent", "", "-", "kept"),
)
CONSOLE_TOPICS: tuple[TopicSpec, ...] = (
    TopicSpec("/footpedals/clutch", _JOY, "state", "on change, 2 Hz", "", BUTTON_UNITS, "the clutch pedal"),
    TopicSpec("/footpedals/camera", _JOY, "state", "on change, 2 Hz", "", BUTTON_UNITS, "the camera pedal"),
    TopicSpec("/console/operator_present", _JOY, "state", "on change, 2 Hz", "", BUTTON_UNITS, "the head sensor"),
    TopicSpec("/operator/clutch", _BOOL, "command", "as sent", "", "-", "the operator presses the clutch"),
    TopicSpec("/operator/camera", _BOOL, "command", "as sent", "", "-", "the operator presses the camera pedal"),
    TopicSpec("/operator/present", _BOOL, "command", "as sent", "", "-", "the operator sits at the console"),
    TopicSpec("/operator/{mtm}/servo_cp", _PS, "command", "as sent", "", POSE_UNITS,
              "where the hand holds the grip (position, in the MTM's base frame)"),
    TopicSpec("/operator/{mtm}/gripper/servo_jp", _JS, "command", "as sent", "", "rad", "the gripper angle (one)"),
)

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
    return canonical_joint_name(name)


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
    "ARM_JOINTS", "CONSOLE_TOPICS", "DEFAULT_NAMESPACE", "MTM_TOPICS", "JAW_JOINTS", "JOINT_UNITS", "LATEST_WINS", "MEASURED_FOR", "OLD_ARM_JOINTS",
    "POSITION_COMMANDS", "PSM_TOPICS", "SETPOINT_AS_COMMAND", "TOPICS_BY_NAME", "TopicSpec",
    "canonical_joint", "qos_dict", "relative_name", "schema_markdown", "spec_for", "topics",
]
