"""The twin's ROS 2 node: wires the dVRK's topics and services to cressim.twin's ROS-free objects.

What lives where. `cressim.twin.TwinArms` is the arms (batched state, the dVRK's behaviour,
commands that return events, the tick); `cressim.twin.SensorLoop` renders cameras and
ultrasound on their own cadence, off the tick; the topic table is cressim.record.schema. This
node only turns messages into calls and events into messages.

Timing. A steady-clock timer at publish_rate runs the tick (steady, so that with use_sim_time
it does not wait on the /clock it publishes itself): TwinArms.tick (simulated time advances one
period), the periodic topics from one device -> host snapshot, the tick's events (after the
data: a client that sees is_busy=false then reads measured at the goal), then the sensors due
are handed to the sensor thread. The tick never waits on an image. The operating_state that
answers `home` may be held over ticks (at most 1 s of simulated time) until the arm's state
topics have their readers (homed_hold.py: a client told "homed" reads setpoint_cp at once).

Start. "cressim twin ready" is logged after the first tick has been published; before it, one
sensor frame is rendered so every pipeline is built (the drivers cache them on disk, so a second
start is quick).

Robustness. Every callback is wrapped: a bad message is refused with a reason on `error` (or
`warning` for commands the twin cannot do) and a throttled log line; an exception inside a
handler is reported the same way. The node never dies from a message.
"""
from __future__ import annotations

import collections
import functools
import math
import threading
import time
import traceback
from array import array
from types import SimpleNamespace

import numpy as np
import rclpy
import torch
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import PoseStamped, TransformStamped, TwistStamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray, MultiArrayDimension, String
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from crtk_msgs.msg import OperatingState
from crtk_msgs.srv import QueryForwardKinematics, QueryInverseKinematics, TriggerOperatingState

from cressim.robots.dvrk import PSM_JOINTS
from cressim.robots.kinematics import matrix_to_pose7
from cressim.twin import ConfigError, Sensor, SensorLoop, StateReport, TwinArms, TwinConfig
from cressim.robots.ecm import ecm_urdf
from cressim.twin.cart import EYES, Cart, pairs
from cressim.twin.command_checks import stale_refusal
from cressim.twin.sensor_loop import process_threads
from cressim.twin_scene_file import DEFAULT_SCENE, SceneError, load_scene

from . import params as P
from .camera_topics import PRODUCTS, CameraTopics, CameraView, camera_frame
from .console_topics import ConsoleTopics
from .ecm_topics import EcmTopics
from .diagnostics import build_diagnostics
from .homed_hold import HomedHold, readers_caught_up
from .recorder import RecordingUnavailable, open_recorder
from .robot_state import RobotStateTopics
from .simulation_control import SimulationControl
from .topics import (CLOCK_QOS, CLOCK_TOPIC, CONSOLE_NAMESPACES, CRTK_VERSION, DIAGNOSTICS_TOPIC, LATCHED_COMMANDS,
                     LATCHED_QOS, LatchedCommandReader, on_new_reader,
                     SENSOR_TOPICS, TF_STATIC_TOPIC, TF_TOPIC, TOPICS_BY_NAME, arm_topics, env_frame_prefix,
                     env_namespaces, env_topic, fill_pose, msg_class, qos)
from .ultrasound_topics import UltrasoundTopics, ultrasound_frame

ERROR_INTERVAL_S = 0.05  # the same refusal (env, kind) goes to `error` at most this often
LOG_THROTTLE_S = 1.0
DIAGNOSTICS_PERIOD_S = 1.0
SOUNDS = ("set_volume", "beep", "string_to_speech")  # the console's; the twin has no speaker
# arm commands the twin cannot carry out: answered on `warning` (clients still find a peer)
UNSUPPORTED = {"free": "free (a compliant arm)", "servo_jf": "joint effort control",
               "jaw/servo_jf": "jaw effort control", "body/servo_cf": "wrench control",
               "spatial/servo_cf": "wrench control"}
FLAGS = {"use_gravity_compensation": "use_gravity_compensation",
         "body/set_cf_orientation_absolute": "body_cf_orientation_absolute",
         "emulate_tool_present": "tool_present", "emulate_adapter_present": "adapter_present"}
TOOL_TYPES = {"psm_lnd": "LARGE_NEEDLE_DRIVER:400006", "psm_suction": "CRESSIM_SUCTION_TUBE"}


class TwinNode(Node):
    def __init__(self, *, threaded_sensors: bool = True, **kwargs):
        super().__init__("cressim_twin", **kwargs)
        self.refusals = collections.Counter()  # (env, kind) -> count (env None: the console), reported at shutdown
        self.console_commands = collections.Counter()  # console topic (power_on, beep, ...) -> count
        self._last_error = {}  # (env, kind) -> (wall time, suppressed count)
        self.recorder = None
        self._record_lock = threading.Lock()  # the tick and the sensor thread both record
        self.ready = False
        self._read_parameters()
        self._build(threaded_sensors)
        self.add_on_set_parameters_callback(self._on_set_parameters)

    # ------------------------------------------------------------------ configuration
    def _read_parameters(self):
        scene_name = self.declare_parameter(
            "scene", DEFAULT_SCENE, ParameterDescriptor(description=P.BY_NAME["scene"].description)).value
        try:
            self.scene = load_scene(scene_name)
        except SceneError as exc:
            raise ConfigError(str(exc)) from None
        cfg = {"scene": self.scene.path}
        for name, default in P.defaults(self.scene).items():
            if name == "scene":
                continue
            spec = P.BY_NAME[name]
            descriptor = ParameterDescriptor(description=spec.description, dynamic_typing=spec.kind is float)
            cfg[name] = self.declare_parameter(name, default, descriptor).value
        problem = P.check(cfg, cfg, running=False)
        if problem:
            raise ConfigError(f"parameter {problem}")
        self.cfg = cfg
        self.use_sim_time = bool(self.get_parameter("use_sim_time").value)

    def _on_set_parameters(self, parameters):
        changes = {p.name: p.value for p in parameters}
        problem = P.check(changes, self.cfg, running=True)
        if problem is None and "ultrasound" in changes.get("sensors", ()) and self.ultrasound is None:
            problem = ("sensors: ultrasound was not on when the node started (its probe and scatterers are built "
                       "then): restart the node with ultrasound in sensors")
        if problem is None and changes.get("record"):
            try:  # open it here so that a failure is the refusal's reason
                new_recorder = open_recorder(changes["record"])
            except (RecordingUnavailable, OSError, ValueError) as exc:
                problem = f"record: {exc}"
            else:
                self._close_recorder()
                self._open_recording(new_recorder)
        if problem:
            self.get_logger().warning(f"parameter change refused: {problem}")
            return SetParametersResult(successful=False, reason=problem)
        for name, value in changes.items():
            if name == "use_sim_time":
                self.use_sim_time = bool(value)
                continue
            self.cfg[name] = list(value) if isinstance(value, (list, tuple)) else value
            if name == "record" and not value:
                self._close_recorder()
            if name in ("camera_rate", "ultrasound_rate") and name[:-5] in self.sensors.sensors:
                self.sensors.set_rate(name[:-5], value)
        if "publish_rate" in changes:
            self._set_rate()
        if "sensors" in changes:
            self._create_sensor_publishers()
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ building
    def _build(self, threaded_sensors: bool):
        cfg = self.cfg
        self._threads_before_engine = process_threads()
        config = TwinConfig(
            scene=self.scene, num_envs=cfg["num_envs"], robot=cfg["robot"], dynamics=cfg["dynamics"],
            arm=cfg["arm"], physics_rate=cfg["physics_rate"], particle_rate=cfg["particle_rate"],
            publish_rate=cfg["publish_rate"],
            camera_width=cfg["camera_width"], camera_height=cfg["camera_height"],
            # the probe and its scatterers exist when the node starts with the group
            ultrasound="ultrasound" in cfg["sensors"])
        # a patient cart (the scene's `cart:`): one row per PSM, each under its own name
        self.cart = Cart(config) if self.scene.cart else None
        self.arms = self.cart or TwinArms(config)
        arms = self.arms
        self.num_envs, self.arm, self.robot = arms.num_envs, arms.arm, arms.robot
        if self.cart:
            self.arm_names, self.prefixes = list(arms.names), [""] * self.num_envs
            self.namespaces = [[f"/{name}"] for name in self.arm_names]
        else:
            self.arm_names = [self.arm] * self.num_envs
            self.prefixes = [env_frame_prefix(i, self.num_envs) for i in range(self.num_envs)]
            self.namespaces = env_namespaces(self.arm, self.num_envs)
        self.base_frame_id = [f"{p}{name}_base" for p, name in zip(self.prefixes, self.arm_names)]
        if self.cart:  # a cart's PSMs report measured_cp in the endoscope's frame, as the dVRK's console sets
            self.base_frame_id = [self.cart.ecm.name] * self.num_envs
        engine, scenery = arms.bodies.engine, arms.bodies.scenery
        views = None
        if self.cart:  # the endoscope's rectified pair: the right camera's P[3] = -fx B (ROS)
            fx = scenery.camera.intrinsics()[0]
            views = [CameraView(f"/camera/{eye}", f"camera_{eye}_optical_frame", -fx * scenery.baseline * k)
                     for k, eye in enumerate(EYES)]
        self.camera = CameraTopics(self, engine, scenery.camera, scenery.labels, self.num_envs, views)
        self.ecm = EcmTopics(self, self.cart.ecm) if self.cart else None
        self.console = ConsoleTopics(self, self.cart) if self.cart else None  # the MTMs, pedals, operator
        self.ultrasound = None
        if scenery.ultrasound is not None:
            self.ultrasound = UltrasoundTopics(self, engine, scenery.ultrasound, self.num_envs)
        # the URDF's links on /tf, /joint_states and /robot_description (a cart's under each arm's name)
        if self.cart:
            cart = self.cart
            self.robot_states = [RobotStateTopics(self, arms, arms.psm.urdf_path.read_text(),
                                                  names=[self.arm_names[k] for k in rows])
                                 for arms, rows in cart.groups]  # one FK per instrument for all its PSMs
            self.robot_states.append(RobotStateTopics(
                self, SimpleNamespace(num_envs=1, arm=cart.ecm.name), ecm_urdf().read_text(),
                names=[cart.ecm.name], bodies=cart.ecm_bodies, state=cart.ecm_joints))
        else:
            self.robot_states = [RobotStateTopics(self, arms, arms.psm.urdf_path.read_text())]
        images = self.camera.images  # grabbed right after the frame, converted and published off the engine lock
        sensors = [Sensor("camera", cfg["camera_rate"], render=True, read=lambda: images.grab(self.cfg["sensors"]),
                          publish=lambda raw, stamp: self.camera.publish(raw, stamp, self._recorder_fn()))]
        if self.ultrasound is not None:
            sensors.append(Sensor("ultrasound", cfg["ultrasound_rate"], sense=True, read=self.ultrasound.read,
                                  publish=lambda images, stamp: self.ultrasound.publish(images, stamp,
                                                                                        self._recorder_fn())))
        self.sensors = SensorLoop(arms, sensors, threaded=threaded_sensors, on_error=self._sensor_failed)
        self._tick_times = collections.deque(maxlen=500)
        self._tick_ns = collections.deque(maxlen=500)  # steady time of each tick, for the rate
        self._next_tf_ns = 0
        self._next_diagnostics = 0.0
        self._last_statistics = None
        self.homed_hold = HomedHold()  # keyed by env
        self._create_event_publishers()
        self._create_sensor_publishers()
        self._create_subscriptions()
        self._create_services()
        self.control = SimulationControl(self)
        self.clock_pub = self.create_publisher(ClockMsg, CLOCK_TOPIC, CLOCK_QOS)
        self.tf_pub = self.create_publisher(TFMessage, TF_TOPIC, qos(TOPICS_BY_NAME[TF_TOPIC]))
        self.tf_static_pub = self.create_publisher(TFMessage, TF_STATIC_TOPIC, LATCHED_QOS)
        self.diagnostics_pub = self.create_publisher(msg_class(TOPICS_BY_NAME[DIAGNOSTICS_TOPIC]), DIAGNOSTICS_TOPIC,
                                                     qos(TOPICS_BY_NAME[DIAGNOSTICS_TOPIC]))
        self._publish_static_tf()
        for env in range(self.num_envs):
            self._emit(self._latched_events(env))
        recorder = None
        if cfg["record"]:  # opened now (a bad path fails at once), written from the first tick on
            try:
                recorder = open_recorder(cfg["record"])
            except (RecordingUnavailable, OSError, ValueError) as exc:
                raise ConfigError(f"record: {exc}") from None
        self.live_view = None
        if cfg["live_view"]:
            from .live_view import LiveView  # foxglove-sdk: imported only when asked for

            try:
                self.live_view = LiveView(self, cfg["live_view"],
                                          cameras=[v.namespace for v in self.camera.views if v.env == 0],
                                          robots=[rs.topic("", row) for rs in self.robot_states
                                                  for row in rs.first_env_rows])
            except Exception as exc:  # noqa: BLE001 - the port taken, say
                raise ConfigError(f"live_view: port {cfg['live_view']}: {exc}") from None
        self._sync_sensor_groups()
        self.sensors.render_now()  # builds every pipeline before the first tick (can take a minute cold)
        if recorder is not None:
            self._open_recording(recorder)
        if self.arms.bodies.device.type == "cpu" and not self.arms.dynamic:
            # lavapipe renders on the CPU: frames take the time the 100 Hz tick leaves (a dynamic
            # arm's physics runs on the same driver threads, so they keep their priority there)
            self.sensors.lower_priority(self.arms.engine_threads | (process_threads() - self._threads_before_engine))
        self.timer = None
        self._set_rate()

    def _publish_static_tf(self):
        """world -> base (the scene's base pose), world -> camera and probe of every env, latched;
        a cart's: world -> every arm's base, the ECM's tip -> each eye."""
        stamp, N, scene = self.stamp(), self.num_envs, self.scene
        spec = self.arms.bodies.scenery
        transforms = []
        if self.cart:
            cart, ecm = self.cart, self.cart.ecm.name
            frames = [("world", f"{name}_base", base) for name, base in zip(self.arm_names, cart.psm_bases)]
            frames.append(("world", f"{ecm}_base", cart.ecm_base))
            frames += [(ecm, view.frame, offset) for view, offset in zip(self.camera.views, cart.eye_offsets())]
            transforms = [_transform(stamp, parent, child, _pose7(T)) for parent, child, T in frames]
        else:
            for env in range(N):
                prefix = env_frame_prefix(env, N)
                transforms.append(_transform(stamp, f"{prefix}world", f"{prefix}{self.arm}_base",
                                             (*scene.base_position, *scene.base_rotation)))
                transforms.append(_transform(stamp, f"{prefix}world", camera_frame(env, N),
                                             (*spec.camera.position, *spec.camera_rotation)))
                if spec.ultrasound is not None:
                    position, rotation = spec.probe_pose()
                    probe = ultrasound_frame(env, N, spec.ultrasound.frame)
                    transforms.append(_transform(stamp, f"{prefix}world", probe, (*position, *rotation)))
        self.static_tf = TFMessage(transforms=transforms)
        self.tf_static_pub.publish(self.static_tf)

    def _latched_events(self, env: int) -> list:
        """The events a late subscriber (or a new recording) needs: the arm's current state."""
        return ([(env, "operating_state", self.arms.report(env))] + self.arms.ratio_events(env)
                + [(env, "tool_type", TOOL_TYPES[self.robot])])

    def _open_recording(self, recorder):
        """Starts a recording with everything latched so far (a bag is self-contained)."""
        self.recorder = recorder
        self._record(TF_STATIC_TOPIC, self.static_tf)
        for env in range(self.num_envs):
            self._record(self.camera.labels_topic(env), self.camera.labels)
            for _, topic, value in self._latched_events(env):
                self._record(f"{self.namespaces[env][0]}/{topic}", self._message(env, topic, value))
        for topic, msg in (item for rs in self.robot_states for item in rs.topics_for_recording()):
            self._record(topic, msg)
        if self.cart:  # the ECM's and the MTMs' states
            for topic, msg in self.ecm.latched() + [item for mtm in self.console.mtms for item in mtm.latched()]:
                self._record(topic, msg)

    def _set_rate(self):
        self.arms.set_rate(self.cfg["publish_rate"])
        if self.timer is not None:
            self.destroy_timer(self.timer)
        self.timer = self.create_timer(1.0 / self.cfg["publish_rate"], self._tick,
                                       clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _create_event_publishers(self):
        def again(env):  # a new reader of operating_state: the arm's state now (topics.on_new_reader)
            return on_new_reader(lambda: self._emit([(env, "operating_state", self.arms.report(env))]))

        self.event_pubs = [[{t.name: self.create_publisher(
            msg_class(t), f"{ns}/{t.name}", qos(t),
            **({"event_callbacks": again(env)} if t.name == "operating_state" else {}))
            for t in arm_topics("event")} for ns in namespaces] for env, namespaces in enumerate(self.namespaces)]
        console = {name: self.create_publisher(msg_class(TOPICS_BY_NAME[name]), name, qos(TOPICS_BY_NAME[name]))
                   for name in TOPICS_BY_NAME if name.startswith("/console/teleop/") and
                   TOPICS_BY_NAME[name].role == "event"}
        self.console_pubs = console
        console["/console/teleop/enabled"].publish(Bool(data=False))
        console["/console/teleop/scale"].publish(Float64(data=0.2))

    def _create_sensor_publishers(self):
        if not hasattr(self, "sensor_pubs"):
            self.sensor_pubs = [[{} for _ in namespaces] for namespaces in self.namespaces]
        for env, namespaces in enumerate(self.namespaces):  # publishers of newly enabled groups
            for k, ns in enumerate(namespaces):
                for group in self.cfg["sensors"]:
                    for topic in SENSOR_TOPICS.get(group, ()):
                        if topic not in self.sensor_pubs[env][k]:
                            spec = TOPICS_BY_NAME[topic]
                            self.sensor_pubs[env][k][topic] = self.create_publisher(msg_class(spec), f"{ns}/{topic}",
                                                                                    qos(spec))
        self.camera.enable(self.cfg["sensors"])
        if hasattr(self, "sensors"):
            self._sync_sensor_groups()

    def _sync_sensor_groups(self):
        groups = set(self.cfg["sensors"])
        self.sensors.enable("camera", bool(groups & set(PRODUCTS)))
        self.sensors.enable("ultrasound", "ultrasound" in groups)

    def _create_subscriptions(self):
        arms = self.arms
        handlers = {
            "state_command": lambda env, m: arms.state_command(env, m.string),
            "servo_jp": lambda env, m: arms.servo_jp(env, m),
            "servo_jr": lambda env, m: arms.servo_jp(env, m, relative=True),
            "move_jp": lambda env, m: arms.move_jp(env, m),
            "move_jr": lambda env, m: arms.move_jp(env, m, relative=True),
            "servo_cp": lambda env, m: arms.servo_cp(env, m.pose),
            "move_cp": lambda env, m: arms.move_cp(env, m.pose),
            "servo_cv": lambda env, m: arms.servo_cv(env, m.twist),
            "jaw/servo_jp": lambda env, m: arms.jaw_servo_jp(env, m),
            "jaw/move_jp": lambda env, m: arms.jaw_move_jp(env, m),
            "suction/servo_jp": lambda env, m: arms.instrument_command(env, "suction/servo_jp", m),
            "hold": lambda env, m: arms.hold(env),
            "set_base_frame": self._set_base_frame,
            "trajectory_j/set_ratio": lambda env, m: arms.set_ratio(env, m.data),
            "trajectory_j/set_ratio_v": lambda env, m: arms.set_ratio(env, m.data, which="_v"),
            "trajectory_j/set_ratio_a": lambda env, m: arms.set_ratio(env, m.data, which="_a"),
            "set_tool_type": self._set_tool_type,
            **{name: functools.partial(self._flag, flag) for name, flag in FLAGS.items()},
            **{name: functools.partial(self._unsupported, name) for name in UNSUPPORTED},
        }
        self._command_subs, self._latched_readers = [], []
        for spec in arm_topics("command"):
            handler = handlers[spec.name]
            for env, namespaces in enumerate(self.namespaces):
                for ns in namespaces:
                    callback = functools.partial(self._on_command, spec.name, handler, env)
                    if spec.name in LATCHED_COMMANDS:  # crtk latches it (topics.LatchedCommandReader)
                        self._latched_readers.append(LatchedCommandReader(self, msg_class(spec), f"{ns}/{spec.name}",
                                                                          qos(spec), callback))
                    else:
                        self._command_subs.append(self.create_subscription(msg_class(spec), f"{ns}/{spec.name}",
                                                                           callback, qos(spec)))
        # the console's (also under /system/, dVRK 2.3's name): every arm's power and homing, its sounds
        console = {**{topic: functools.partial(self._on_console, command)
                      for topic, command in (("power_on", "enable"), ("power_off", "disable"), ("home", "home"))},
                   **{sound: functools.partial(self._on_sound, sound) for sound in SOUNDS}}
        topics = [(f"{ns}/{topic}", f"/console/{topic}", handler)
                  for ns in CONSOLE_NAMESPACES for topic, handler in console.items()]
        topics += [(f"/console/teleop/{topic}", f"/console/teleop/{topic}", handler) for topic, handler in (
            ("enable", self._on_teleop_enable), ("set_scale", self._on_teleop_scale),
            ("select", functools.partial(self._on_teleop_select, "selected")),
            ("unselect", functools.partial(self._on_teleop_select, "unselected")))]
        for topic, name, handler in topics:
            spec = TOPICS_BY_NAME[name]
            self._command_subs.append(self.create_subscription(
                msg_class(spec), topic, functools.partial(self._on_console_command, topic, handler), qos(spec)))
        # the coagulation pedal: one per env; a cart's console has one for all its PSMs
        spec = TOPICS_BY_NAME["/footpedals/coag"]
        pedals = ([(spec.name, range(self.num_envs))] if self.cart else
                  [(env_topic(spec.name, env, self.num_envs), [env]) for env in range(self.num_envs)])
        for topic, envs in pedals:
            self._command_subs.append(self.create_subscription(
                msg_class(spec), topic, functools.partial(self._on_coag_pedal, list(envs), topic), qos(spec)))

    def _create_services(self):
        self._service_handles = []
        for env, namespaces in enumerate(self.namespaces):
            for ns in namespaces:
                for name, srv_type, handler in (
                        ("operating_state", TriggerOperatingState, self._srv_operating_state),
                        ("crtk_version", Trigger, self._srv_crtk_version),
                        ("forward_kinematics", QueryForwardKinematics, functools.partial(self._srv_fk, local=False)),
                        ("local/forward_kinematics", QueryForwardKinematics, functools.partial(self._srv_fk, local=True)),
                        ("inverse_kinematics", QueryInverseKinematics, self._srv_ik)):
                    self._service_handles.append(self.create_service(
                        srv_type, f"{ns}/{name}", functools.partial(self._guarded_service, name, handler, env)))

    # ------------------------------------------------------------------ time and output helpers
    def stamp(self) -> TimeMsg:
        """Stamp of everything published: the node's clock, or with use_sim_time the simulated
        time this node itself publishes on /clock. Never zero (zero means invalid to clients)."""
        if self.use_sim_time:
            ns = max(self.arms.sim_ns, 1)
        else:
            ns = self.get_clock().now().nanoseconds
            ns = ns if ns > 0 else time.time_ns()
        return TimeMsg(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def now_ns(self) -> int:
        s = self.stamp()
        return s.sec * 1_000_000_000 + s.nanosec

    def _message(self, env: int, topic: str, value):
        if isinstance(value, StateReport):
            msg = OperatingState(state=value.state, is_homed=value.is_homed, is_busy=value.is_busy)
            msg.header.stamp = self.stamp()
            msg.header.frame_id = self.base_frame_id[env]
            return msg
        if isinstance(value, bool):
            return Bool(data=value)
        if isinstance(value, float):
            return Float64(data=value)
        return String(data=str(value))

    def _emit(self, events):
        """Publishes events ((env, topic, value) from TwinArms) on each env's namespaces (and
        records them under the first); refusals go through the rate limit and the log; the
        operating_state that answers `home` through homed_hold."""
        for e_env, topic, value in events:
            if topic in ("error", "warning") and not str(value).startswith(self.arms.label(e_env) + ":"):
                self._refuse(e_env, _kind_of(str(value)), str(value), level=topic)
                continue
            for out_topic, out_value in self.homed_hold.admit(e_env, topic, value):  # `home`'s answer may wait
                self._publish_event(e_env, out_topic, self._message(e_env, out_topic, out_value))

    def _state_readers_caught_up(self, env: int) -> bool:
        """Each namespace of env: its state topics have as many readers as its operating_state."""
        return all(readers_caught_up(states, events["operating_state"])
                   for states, events in zip(self.sensor_pubs[env], self.event_pubs[env]))

    def _publish_event(self, env: int, topic: str, msg):
        for pubs in self.event_pubs[env]:
            pubs[topic].publish(msg)
        if self.recorder is not None:
            self._record(f"{self.namespaces[env][0]}/{topic}", msg)

    def _recorder_fn(self):
        if self.recorder is None:
            return None
        stamp_ns = self.now_ns()
        return lambda topic, msg: self._record(topic, msg, stamp_ns)

    def _record(self, topic, msg, stamp_ns=None):
        with self._record_lock:
            recorder = self.recorder
            if recorder is None:
                return
            try:
                recorder.write(topic, msg, stamp_ns if stamp_ns is not None else self.now_ns())
            except Exception as exc:  # noqa: BLE001 - a recording problem must not stop the twin
                self.get_logger().error(f"recording failed, stopped: {exc}")
                self.recorder = None
                _close_quietly(recorder, self.get_logger())

    def _close_recorder(self):
        with self._record_lock:
            recorder, self.recorder = self.recorder, None
        if recorder is not None:
            _close_quietly(recorder, self.get_logger())

    def _refuse(self, env: int, kind: str, text: str, *, level: str = "error"):
        """Publishes a refusal on env's `error` (or `warning`) topic, rate-limited per (env, kind)."""
        self.refusals[(env, kind)] += 1
        now = time.monotonic()
        last, suppressed = self._last_error.get((env, kind), (-math.inf, 0))
        if now - last < ERROR_INTERVAL_S:
            self._last_error[(env, kind)] = (last, suppressed + 1)
            return
        suffix = f" (+{suppressed} similar refusals not published)" if suppressed else ""
        self._last_error[(env, kind)] = (now, 0)
        line = f"{self.arms.label(env)}: {text}{suffix}"
        self._publish_event(env, level, String(data=line))
        # one call site per severity: rclpy fixes a throttled call site's severity at its first
        # call and raises if it changes (which failed the tick, and counted the refusal again)
        if level == "error":
            self.get_logger().error(line, throttle_duration_sec=LOG_THROTTLE_S)
        else:
            self.get_logger().warning(line, throttle_duration_sec=LOG_THROTTLE_S)

    def _stale(self, kind: str, msg, info) -> str | None:
        """Why a stamped command was too old when the middleware received it (None: fresh)."""
        header = getattr(msg, "header", None)
        if header is None:
            return None
        received = (info or {}).get("received_timestamp") or time.time_ns()
        return stale_refusal(header.stamp.sec * 1_000_000_000 + header.stamp.nanosec, received, self.arms.sim_ns,
                             self.scene.stale_command_after, what=kind)

    # ------------------------------------------------------------------ subscriptions
    def _on_command(self, kind, handler, env, msg, info, latched=False):
        try:
            if self.recorder is not None:
                self._record(f"{self.namespaces[env][0]}/{kind}", msg)
            # a latched writer's command (crtk's state_command) from its history may come as late as
            # discovery took: it is the writer's last word, not a stale one
            problem = None if latched else self._stale(kind, msg, info)
            if problem:
                self._refuse(env, kind, problem)
                return
            self._emit(handler(env, msg))
        except Exception as exc:  # noqa: BLE001 - the node must survive any message
            self._refuse(env, kind, f"{kind}: internal error, command ignored ({type(exc).__name__}: {exc})")
            self.get_logger().error(traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)

    def _set_base_frame(self, env, msg):
        events = self.arms.set_base_frame(env, msg.pose)
        if not events:
            if msg.header.frame_id:
                self.base_frame_id[env] = msg.header.frame_id
            events = [(env, "status", f"{self.arms.label(env)}: base frame set ({self.base_frame_id[env]})")]
        return events

    def _set_tool_type(self, env, msg):
        ours = TOOL_TYPES[self.robot]
        if msg.data.strip() not in (ours, ours.split(":")[0]):
            return [(env, "warning", f"set_tool_type refused: the twin's instrument is {ours} (robot {self.robot}); "
                                     "start the twin with another robot to change it")]
        return [(env, "tool_type", ours)]

    def _flag(self, name, env, msg):
        return self.arms.set_flag(env, name, msg.data)

    def _unsupported(self, kind, env, msg):
        arm = "joint-driven (position drives)" if self.arms.dynamic else "kinematic"
        return [(env, "warning", f"{kind} refused: {UNSUPPORTED[kind]} is not simulated; the twin's arm is {arm}")]

    def _on_coag_pedal(self, envs, topic, msg):
        """The dVRK console's coagulation pedal (sensor_msgs/Joy): buttons[0] 1 pressed, anything
        else (0 released, 2 a quick tap that is over) not. A cart's pedal goes to every PSM: those
        whose instrument takes it heat; only when none does, each says why it refused."""
        try:
            if self.recorder is not None:
                self._record(topic, msg)
            pressed = len(msg.buttons) > 0 and msg.buttons[0] == 1
            answers = [self.arms.instrument_command(env, "footpedals/coag", pressed) for env in envs]
            events = [event for events in answers for event in events]
            if not all(answers):  # an instrument took it: the others' refusals are no news
                events = [(env, kind, value) for env, kind, value in events if kind != "error"]
            self._emit(events)
        except Exception:  # noqa: BLE001 - the node must survive any message
            self.get_logger().error(traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)

    def _on_console_command(self, topic, handler, msg):
        """Every console command: recorded, counted, then handled; the node survives any message."""
        try:
            if self.recorder is not None:
                self._record(topic, msg)
            self.console_commands[topic.split("/", 2)[2]] += 1  # /system/beep and /console/beep: beep
            handler(msg)
        except Exception:  # noqa: BLE001
            self.get_logger().error(traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)

    def _refuse_console(self, kind, text):
        """A console command refused: logged (throttled) and counted; the console has no `error` topic."""
        self.refusals[(None, kind)] += 1
        self.get_logger().warning(f"console {text}", throttle_duration_sec=LOG_THROTTLE_S)

    def _on_console(self, command, msg):
        for env in range(self.num_envs):
            self._emit(self.arms.state_command(env, command))
        if self.ecm is not None:
            self.ecm.emit(pairs(self.cart.ecm.state_command(0, command)))
            for topics in self.console.mtms:
                topics.emit(topics.mtm.state_command(command))

    def _on_sound(self, kind, msg):
        """The console's set_volume, beep and string_to_speech: checked and logged (no speaker here)."""
        problem, asked = _sound(kind, msg)
        if problem:
            self._refuse_console(kind, f"{kind} refused: {problem}")
        else:
            self.get_logger().info(f"console {asked} (the twin has no speaker)", throttle_duration_sec=LOG_THROTTLE_S)

    def _on_teleop_enable(self, msg):
        if msg.data:
            why = ("the cart runs no teleoperation of its own: run the dVRK's dvrk_teleoperation.py against its MTMs"
                   if self.cart else "the twin has no MTM to teleoperate from (a patient cart has)")
            self._refuse_console("teleop/enable", f"teleop/enable refused: {why}")
        self.console_pubs["/console/teleop/enabled"].publish(Bool(data=False))

    def _on_teleop_scale(self, msg):
        if math.isfinite(msg.data) and msg.data > 0:
            self.console_pubs["/console/teleop/scale"].publish(Float64(data=float(msg.data)))

    def _on_teleop_select(self, which, msg):
        self.console_pubs[f"/console/teleop/{which}"].publish(String(data=msg.data))

    # ------------------------------------------------------------------ services
    def _guarded_service(self, name, handler, env, request, response):
        try:
            return handler(env, request, response)
        except Exception as exc:  # noqa: BLE001
            self.get_logger().error(traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)
            if hasattr(response, "message"):
                response.message = f"{name}: internal error ({type(exc).__name__}: {exc})"
            return response

    def _srv_operating_state(self, env, request, response):
        response.operating_state = self._message(env, "operating_state", self.arms.report(env))
        return response

    def _srv_crtk_version(self, env, request, response):
        response.success, response.message = True, CRTK_VERSION
        return response

    def _srv_fk(self, env, request, response, *, local):
        pose, problem = self.arms.forward(env, JointState(position=list(request.jp)), local=local)
        if problem:
            response.result, response.message = False, problem
            return response
        fill_pose(response.cp, pose)
        response.result = True
        return response

    def _srv_ik(self, env, request, response):
        response.jp, response.result, response.message = self.arms.inverse(env, request.cp, request.jp)
        return response

    # ------------------------------------------------------------------ the tick
    def _tick(self):
        """The timer's: a tick while the simulation plays (simulation_control.py)."""
        if self.control.running:
            self.advance()

    def resume(self):
        """Playing again after a pause: the pause is not a late tick."""
        self._tick_ns.clear()

    def rewind(self):
        """The simulated clock went back to 0 (a reset): tf and the sensors are due again."""
        self._next_tf_ns = 0
        self.sensors.rewind()

    def drop_held_answers(self):
        """The arms were reset (not homed): an answer to `home` held back (homed_hold.py) is void."""
        for hold in [self.homed_hold] + ([self.ecm.hold] + [m.hold for m in self.console.mtms] if self.cart else []):
            hold.clear()

    def advance(self):
        """One tick: the arms and the engine one publish period on, then what it publishes."""
        started = time.perf_counter()
        try:
            events = self.arms.tick()
            stamp = self.stamp()
            self.homed_hold.check(self._state_readers_caught_up)  # before the samples: their readers get them
            self._publish(stamp)
            for env, topic, value in self.homed_hold.due(self.arms.period_ns):
                self._publish_event(env, topic, self._message(env, topic, value))
            self._emit(events)
            self.sensors.offer(self.arms.sim_ns, stamp)
            if started >= self._next_diagnostics:
                self._next_diagnostics = started + DIAGNOSTICS_PERIOD_S
                self._publish_diagnostics(stamp)
        except Exception:  # noqa: BLE001 - a failing tick is reported and the next one runs
            if not self.context.ok():
                return  # the node is stopping (its context shut down mid-tick): nothing to report
            self.get_logger().error("tick failed: " + traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)
        self._tick_times.append(time.perf_counter() - started)
        now_ns = time.monotonic_ns()
        if self._tick_ns and now_ns - self._tick_ns[-1] > 10 * self.arms.period_ns:
            self.get_logger().warning(f"tick {(now_ns - self._tick_ns[-1]) * 1e-6:.0f} ms after the last one "
                                      f"(period {self.arms.period_ns * 1e-6:g} ms): the machine is busy",
                                      throttle_duration_sec=LOG_THROTTLE_S)
        self._tick_ns.append(now_ns)
        if not self.ready:
            self.ready = True
            cfg = self.cfg
            self.get_logger().info(
                f"cressim twin ready: {self.num_envs} x {self.robot} ({cfg['dynamics']} arm) as "
                f"{', '.join(n for ns in self.namespaces for n in ns)} at {cfg['publish_rate']:g} Hz "
                f"(physics {cfg['physics_rate']:g} Hz, engine on {self.arms.bodies.engine.device['name']})")

    def _publish(self, stamp):
        groups = set(self.cfg["sensors"])
        N, arms = self.num_envs, self.arms
        stamp_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        snap = arms.snapshot(cartesian=bool(groups & {"cartesian", "velocity", "tf", "wrench"}),
                             jacobian="jacobian" in groups)
        names, jaw_names = list(PSM_JOINTS), ["jaw"]
        zeros6, zeros1 = array("d", [0.0] * 6), array("d", [0.0])
        publish_tf = "tf" in groups and arms.sim_ns >= self._next_tf_ns
        if publish_tf:
            self._next_tf_ns = arms.sim_ns + int(1e9 / self.cfg["tf_rate"])
        record = None if self.recorder is None else (lambda topic, msg: self._record(topic, msg, stamp_ns))
        transforms = []
        for env in range(N):
            msgs = {}
            if "joints" in groups:
                msgs["measured_js"] = _joint_state(stamp, names, snap.measured[env], snap.measured_v[env], zeros6)
                msgs["setpoint_js"] = _joint_state(stamp, names, snap.setpoint[env], snap.setpoint_v[env], zeros6)
                msgs["jaw/measured_js"] = _joint_state(stamp, jaw_names, snap.jaw_meas[env], snap.jaw_meas_v[env],
                                                       zeros1)
                msgs["jaw/setpoint_js"] = _joint_state(stamp, jaw_names, snap.jaw_sp[env], snap.jaw_sp_v[env], zeros1)
                if arms.instrument("suction") is not None:
                    msgs["suction/measured_js"] = _joint_state(stamp, ["suction"], snap.suction_valve[env], zeros1,
                                                               array("d", snap.suction_removed[env]))
            prefix, name = self.prefixes[env], self.arm_names[env]
            local_frame, base_frame, tip_frame = f"{prefix}{name}_base", self.base_frame_id[env], f"{prefix}{name}"
            if "cartesian" in groups:
                msgs["local/measured_cp"] = _pose_stamped(stamp, local_frame, snap.local_measured_cp[env])
                msgs["local/setpoint_cp"] = _pose_stamped(stamp, local_frame, snap.local_setpoint_cp[env])
                msgs["measured_cp"] = _pose_stamped(stamp, base_frame, snap.measured_cp[env])
                msgs["setpoint_cp"] = _pose_stamped(stamp, base_frame, snap.setpoint_cp[env])
            if "velocity" in groups:
                m = TwistStamped()
                m.header.stamp, m.header.frame_id = stamp, base_frame
                v, w = snap.measured_v_linear[env], snap.measured_v_angular[env]
                m.twist.linear.x, m.twist.linear.y, m.twist.linear.z = float(v[0]), float(v[1]), float(v[2])
                m.twist.angular.x, m.twist.angular.y, m.twist.angular.z = float(w[0]), float(w[1]), float(w[2])
                msgs["measured_cv"] = m
            if "jacobian" in groups:
                msgs["spatial/jacobian"] = _matrix_msg(snap.spatial_jacobian[env])
                msgs["body/jacobian"] = _matrix_msg(snap.body_jacobian[env])
            if publish_tf:
                transforms.append(_transform(stamp, local_frame, tip_frame, snap.local_measured_cp[env]))
            if "wrench" in groups:  # what contacts and held tissue exert on the tool, about its tip
                msgs["spatial/measured_cf"] = _wrench(stamp, base_frame, snap.spatial_cf[env])
                msgs["body/measured_cf"] = _wrench(stamp, tip_frame, snap.body_cf[env])
            for k, pubs in enumerate(self.sensor_pubs[env]):
                for topic, msg in msgs.items():
                    pub = pubs.get(topic)
                    if pub is not None:
                        pub.publish(msg)
                        if record is not None and k == 0:
                            record(f"{self.namespaces[env][0]}/{topic}", msg)
        if publish_tf:
            for robot_state in self.robot_states:
                transforms += robot_state.publish(stamp, _transform, record)
        if self.ecm is not None:
            self.ecm.publish(stamp)
            self.console.publish(stamp)
            if publish_tf:
                ecm = self.cart.ecm.name
                transforms.append(_transform(stamp, f"{ecm}_base", ecm, self.ecm.tip_pose7()))
        if transforms:  # all envs' transforms in one message
            tf = TFMessage(transforms=transforms)
            self.tf_pub.publish(tf)
            if record is not None:
                record(TF_TOPIC, tf)
        if "clock" in groups:
            clock = ClockMsg()
            clock.clock = TimeMsg(sec=arms.sim_ns // 1_000_000_000, nanosec=arms.sim_ns % 1_000_000_000)
            self.clock_pub.publish(clock)

    def _publish_diagnostics(self, stamp):
        stats = self.statistics()  # frames and refusals over the last period, not since the start
        self.diagnostics_pub.publish(build_diagnostics(stats, stamp=stamp, previous=self._last_statistics,
                                                       window_s=DIAGNOSTICS_PERIOD_S))
        self._last_statistics = stats

    def statistics(self) -> dict:
        """Tick time, rates and counts of the last ticks (for /diagnostics and the shutdown log)."""
        ticks = np.array(self._tick_times) * 1e3 if self._tick_times else np.zeros(1)
        stamps = np.array(self._tick_ns)
        rate = (len(stamps) - 1) / ((stamps[-1] - stamps[0]) * 1e-9) if len(stamps) > 1 and stamps[-1] > stamps[0] \
            else 0.0
        refusals = collections.Counter()
        for (_, kind), n in self.refusals.items():
            refusals[kind] += n
        return dict(node=self.get_name(), period_ms=1e3 / self.cfg["publish_rate"], tick_mean_ms=float(ticks.mean()),
                    tick_max_ms=float(ticks.max()), publish_rate_hz=float(rate),
                    target_rate_hz=float(self.cfg["publish_rate"]), sensors=self.sensors.stats(),
                    refusals=dict(refusals), console=dict(self.console_commands), num_envs=self.num_envs)

    def _sensor_failed(self, sensor, exc):
        if not rclpy.ok():  # a frame that finished while the node shuts down has nowhere to go
            return
        name = sensor.name if sensor is not None else "sensor frame"
        self.get_logger().error(f"{name} failed: {type(exc).__name__}: {exc}", throttle_duration_sec=LOG_THROTTLE_S)

    # ------------------------------------------------------------------ shutdown
    def close(self):
        self.sensors.close()
        self._close_recorder()
        if self.live_view is not None:
            self.live_view.close()
        if self.refusals:
            labels = {(env, kind): f"{'console' if env is None else self.arms.label(env)} {kind}"
                      for env, kind in self.refusals}
            summary = ", ".join(f"{labels[key]}: {self.refusals[key]}" for key in sorted(labels, key=labels.get))
            self.get_logger().info(f"refused commands: {summary}")
        if self.console_commands:
            self.get_logger().info("console commands: " + ", ".join(f"{k}: {n}" for k, n in
                                                                    sorted(self.console_commands.items())))
        if self._tick_times:
            s = self.statistics()
            self.get_logger().info(f"tick time over the last {len(self._tick_times)}: mean {s['tick_mean_ms']:.2f} ms, "
                                   f"max {s['tick_max_ms']:.2f} ms; {s['publish_rate_hz']:.1f} ticks/s; sensors "
                                   + ", ".join(f"{k} {v['rendered']} rendered, {v['skipped']} skipped"
                                               for k, v in s["sensors"].items()))


def _sound(kind: str, msg) -> tuple[str | None, str]:
    """(why a console sound command is refused, or None; what it asks) for set_volume (Float64,
    0..1), beep (Float64MultiArray: duration s, frequency Hz, volume 0..1), string_to_speech."""
    if kind == "string_to_speech":
        return (None, f"says {msg.data!r}") if msg.data.strip() else ("nothing to say (an empty string)", "")
    values = [float(msg.data)] if kind == "set_volume" else list(msg.data)
    if kind == "beep" and len(values) != 3:
        return f"{len(values)} values, expected 3 (duration s, frequency Hz, volume 0..1)", ""
    if not all(math.isfinite(v) for v in values):
        return f"{values} is not finite", ""
    volume = values[-1]
    if not 0.0 <= volume <= 1.0:
        return f"volume {volume:g} is not within [0, 1]", ""
    if kind == "set_volume":
        return None, f"volume {volume:g}"
    duration, frequency, _ = values
    if duration <= 0.0 or frequency <= 0.0:
        return f"duration {duration:g} s and frequency {frequency:g} Hz must be positive", ""
    return None, f"beep {duration:g} s at {frequency:g} Hz, volume {volume:g}"


def _kind_of(text: str) -> str:
    """'servo_jp refused: ...' -> 'servo_jp' (the refusal's kind, for counting and rate limits)."""
    head = text.split(" refused", 1)[0].split(":", 1)[0].strip()
    return head or "command"


def _close_quietly(recorder, logger):
    try:
        recorder.close()
    except Exception as exc:  # noqa: BLE001
        logger.error(f"closing the recording failed: {exc}")


def _transform(stamp, parent, child, p) -> TransformStamped:
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (float(p[0]), float(p[1]),
                                                                                       float(p[2]))
    r = t.transform.rotation
    r.x, r.y, r.z, r.w = float(p[3]), float(p[4]), float(p[5]), float(p[6])
    return t


def _pose7(T) -> np.ndarray:
    """A 4x4 -> x, y, z, qx, qy, qz, qw."""
    return matrix_to_pose7(torch.as_tensor(np.asarray(T, dtype=np.float64)[None]))[0].numpy()


def _joint_state(stamp, names, position, velocity, effort) -> JointState:
    m = JointState()
    m.header.stamp = stamp
    m.name = names
    m.position = array("d", position)
    m.velocity = array("d", velocity)
    m.effort = effort
    return m


def _pose_stamped(stamp, frame, p) -> PoseStamped:
    m = PoseStamped()
    m.header.stamp, m.header.frame_id = stamp, frame
    fill_pose(m.pose, p)
    return m


def _wrench(stamp, frame, w) -> WrenchStamped:
    m = WrenchStamped()
    m.header.stamp, m.header.frame_id = stamp, frame
    m.wrench.force.x, m.wrench.force.y, m.wrench.force.z = float(w[0]), float(w[1]), float(w[2])
    m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z = float(w[3]), float(w[4]), float(w[5])
    return m


def _matrix_msg(values) -> Float64MultiArray:
    m = Float64MultiArray()
    m.layout.dim = [MultiArrayDimension(label="rows", size=6, stride=36),
                    MultiArrayDimension(label="columns", size=6, stride=6)]
    m.data = array("d", values)
    return m


def main(args=None) -> int:
    """Entry point `cressim_twin` (and `python -m cressim_ros`)."""
    import signal

    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    # rclpy.init() of this rclpy (the Jazzy wheels) returns None, not the context manager newer
    # demos use with `with`; try/finally does the same. SIGINT and SIGTERM end the spin loop
    # between two callbacks, not rclpy's handler: that one shuts the context down at once, in
    # the middle of a tick's publishing, and the shutdown log could not reach /rosout.
    torch.set_num_threads(1)  # tensors of a few envs: threads only contend with DDS and the engine
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()

    def on_signal(signum, frame):
        stop.set()
        signal.signal(signal.SIGINT, signal.default_int_handler)  # a second Ctrl-C interrupts the shutdown

    previous = {}
    try:
        try:
            P.check_params_files(args)  # file:line:column of a bad value in a --params-file
            node = TwinNode()
        except ConfigError as exc:
            rclpy.logging.get_logger("cressim_twin").fatal(f"not started: {exc}")
            return 2
        previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        try:
            while not stop.is_set():
                executor.spin_once(timeout_sec=0.1)  # the tick's timer wakes it every period
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            node.close()
            node.destroy_node()
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        rclpy.try_shutdown()
    return 0


__all__ = ["ConfigError", "TwinNode", "main"]
