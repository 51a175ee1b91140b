"""The twin's ROS 2 node: N simulated dVRK PSMs in one cressim engine, spoken to as the dVRK.

State. Every env's joints are rows of batched tensors on the engine's device: setpoint and
measured (N, 6), jaw (N, 1), their velocities, the base frames (N, 4, 4), the trajectories.
A command for env i validates its message (O(dof), numpy) and writes row i; the timer tick
then advances all envs together: trajectories, the measured lag, the engine's link bodies,
kinematics, one device->host copy of everything published. Only publishing loops over envs
(one message per env and topic is what ROS needs).

Timing. A steady-clock timer at publish_rate runs the tick (a steady clock, so that with
use_sim_time the timer does not wait on the /clock it publishes itself). Each tick advances
simulated time by one publish period and runs physics_rate / publish_rate engine substeps.

Measured vs setpoint. `dynamics: kinematic` (default): measured follows setpoint through a
first-order lag with time constant `measured_lag` from the scene (default 5 ms; 0 makes them
equal), measured velocity is its finite difference, and the engine's link bodies follow
measured. `dynamics: dynamic`: the arm is jointed dynamic bodies in the engine whose position
drives track the setpoint (arm_bodies.py); measured positions and velocities are the engine's
joint coordinates and rates, gathered for all envs by one index. Efforts and wrenches are zero.

Faults. The engine flags an env whose solve went bad (env.health: NaN, speed, penetration) and
resets it at the start of the next frame; the twin then puts that env's arm in FAULT (motion
stops, a message on `error` names the flag) and has the reset pose the arm at its setpoint at
rest. `enable` clears the fault.

In-process use. Functions in `step_hooks` run inside every tick, after the trajectories set the
setpoints and before the drive/body targets are written and the engine steps: a training loop
in the same process reads the engine's tensors and writes the setpoints of the envs it owns
(docs/twin.md, "Training beside the twin").

Robustness. Every callback is wrapped: a bad message is refused with a reason on `error`
(or `warning` for commands the kinematic twin cannot do) and a throttled log line; an
exception inside a handler is caught and reported the same way. The node never dies from a
message.
"""
from __future__ import annotations

import collections
import functools
import math
import os
import time
import traceback
from array import array

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
from std_msgs.msg import Bool, Empty, Float64, Float64MultiArray, MultiArrayDimension, String
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from crtk_msgs.msg import OperatingState, StringStamped
from crtk_msgs.srv import QueryForwardKinematics, QueryInverseKinematics, TriggerOperatingState

from cressim.robots import PSM, PSM_JOINT_NAMES, robot_dir

from . import params as P
from .arm_bodies import ArmBodies, describe_health
from .arm_state import FAULT, ArmState
from .camera_topics import PRODUCTS, CameraTopics, camera_frame
from .command_checks import joint_values, limit_refusal, pose_matrix, ratio_value, stale_refusal
from .kinematics import INTERFACE_DOF, ArmKinematics, body_jacobian, matrix_to_pose7
from .recorder import RecordingUnavailable, open_recorder
from .scene import DEFAULT_SCENE, SceneError, load_scene
from .scenery import CameraSpec, UltrasoundSpec
from .ultrasound_topics import UltrasoundTopics, ultrasound_frame
from .trajectory import BatchedTrajectory
from .topics import (CLOCK_QOS, CLOCK_TOPIC, COMMAND_QOS, CRTK_VERSION, EVENT_QOS, PERIODIC_QOS, SENSOR_TOPICS,
                     TF_STATIC_QOS, TF_STATIC_TOPIC, TF_TOPIC, env_frame_prefix, env_namespaces)

ERROR_INTERVAL_S = 0.05  # the same refusal (env, kind) goes to `error` at most this often
LOG_THROTTLE_S = 1.0


class ConfigError(RuntimeError):
    """A bad start-up configuration (parameter or scene); the node does not start."""


def guarded(kind: str):
    """Wraps a subscription callback `fn(self, env, msg)`: nothing it raises escapes."""

    def wrap(fn):
        @functools.wraps(fn)
        def callback(self, env, msg):
            try:
                self._record_command(env, kind, msg)
                fn(self, env, msg)
            except Exception as exc:  # noqa: BLE001 - the node must survive any message
                self._refuse(env, kind, f"{kind}: internal error, command ignored ({type(exc).__name__}: {exc})")
                self.get_logger().error(traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)

        return callback

    return wrap


class TwinNode(Node):
    def __init__(self, **kwargs):
        super().__init__("cressim_twin", **kwargs)
        self.refusals = collections.Counter()  # (env, kind) -> count, reported at shutdown
        self._last_error = {}  # (env, kind) -> (wall time, suppressed count)
        self.recorder = None
        self._read_parameters()
        self._build()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(
            f"cressim twin ready: {self.num_envs} x {self.robot} ({self.cfg['dynamics']} arm) as "
            f"{', '.join(n for ns in self.namespaces for n in ns)} at {self.cfg['publish_rate']:g} Hz "
            f"(physics {self.cfg['physics_rate']:g} Hz, device {self.device})")

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
                self.recorder = new_recorder
                self._record(TF_STATIC_TOPIC, self.static_tf)  # a bag is self-contained
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
        if "publish_rate" in changes:
            self._set_rate()
        if "sensors" in changes:
            self._create_sensor_publishers()
        return SetParametersResult(successful=True)

    # ------------------------------------------------------------------ building
    def _build(self):
        cfg, scene = self.cfg, self.scene
        self.num_envs, self.arm, self.robot = cfg["num_envs"], cfg["arm"], cfg["robot"]
        self.namespaces = env_namespaces(self.arm, self.num_envs)
        urdf = robot_dir() / f"{self.robot}.urdf"
        self.psm = PSM(urdf, dtype=torch.float64)
        initial = np.zeros(INTERFACE_DOF)
        initial[: self.psm.dof] = scene.initial_jp[: self.psm.dof]
        self.bodies = ArmBodies(urdf, self.num_envs, base_position=scene.base_position,
                                base_rotation=scene.base_rotation, publish_rate=cfg["publish_rate"],
                                physics_rate=cfg["physics_rate"], initial_q=initial,
                                initial_jaw=scene.initial_jaw if self.psm.has_jaw else 0.0, dof=self.psm.dof,
                                dynamics=cfg["dynamics"], camera=CameraSpec(
                                    width=cfg["camera_width"], height=cfg["camera_height"], fov_y=scene.camera_fov_y,
                                    position=scene.camera_position, look_at=scene.camera_look_at),
                                # the probe and its scatterers exist when the node starts with the group
                                ultrasound=UltrasoundSpec() if "ultrasound" in cfg["sensors"] else None)
        self.dynamic = self.bodies.dynamic
        self.step_hooks = []  # fn(node) run in each tick before the targets are written (module docstring)
        self.device = self.bodies.device
        if self.device.type == "cpu" and "OMP_NUM_THREADS" not in os.environ:
            # the twin's tensors are (N, 6): torch's thread pool only costs here, and its spinning
            # workers starve lavapipe's threads and DDS on a loaded machine (a first tick took
            # minutes on 2 busy cores); set OMP_NUM_THREADS to choose otherwise
            torch.set_num_threads(1)
        self.kin = ArmKinematics(self.psm, self.device)
        problem = limit_refusal(initial, PSM_JOINT_NAMES, self.kin.lower_np, self.kin.upper_np, what="initial_jp")
        if problem:
            raise ConfigError(f"{scene.path}: arm.initial_jp: {problem}")
        if scene.home_jp is not None:
            problem = limit_refusal(np.array(scene.home_jp), PSM_JOINT_NAMES, self.kin.lower_np, self.kin.upper_np,
                                    what="home_jp")
            if problem:
                raise ConfigError(f"{scene.path}: arm.home_jp: {problem}")
        self.jaw_lower, self.jaw_upper = (np.array([v]) for v in (self.psm.jaw_limits or (0.0, 0.0)))

        N, kw = self.num_envs, dict(device=self.device, dtype=torch.float64)
        self.setpoint = torch.as_tensor(initial, **kw).repeat(N, 1)
        self.measured = self.setpoint.clone()
        self.setpoint_v = torch.zeros(N, INTERFACE_DOF, **kw)
        self.measured_v = torch.zeros(N, INTERFACE_DOF, **kw)
        jaw0 = scene.initial_jaw if self.psm.has_jaw else 0.0
        self.jaw_sp = torch.full((N, 1), jaw0, **kw)
        self.jaw_meas = self.jaw_sp.clone()
        self.jaw_sp_v = torch.zeros(N, 1, **kw)
        self.jaw_meas_v = torch.zeros(N, 1, **kw)
        self._last_sp, self._last_jaw_sp = self.setpoint.clone(), self.jaw_sp.clone()
        self.base_frame = torch.eye(4, **kw).repeat(N, 1, 1)  # set_base_frame: measured_cp = base @ local
        self.base_frame_np = np.tile(np.eye(4), (N, 1, 1))
        self.base_frame_id = [f"{env_frame_prefix(i, N)}{self.arm}_base" for i in range(N)]
        self.cp_pending = {}  # env -> local 4x4 target of the newest servo_cp (solved in the tick, batched)

        self.arm_traj = BatchedTrajectory(N, INTERFACE_DOF, device=self.device)
        self.jaw_traj = BatchedTrajectory(N, 1, device=self.device)
        self.states = [ArmState() for _ in range(N)]
        self.arm_motion = [None] * N  # None, "move" or "home": what arm_traj runs for env i
        self.jaw_moving = [False] * N
        self.ratio = np.ones(N)  # trajectory_j/set_ratio
        urdf_v = np.zeros(INTERFACE_DOF)
        joints = {j.name: j for j in self.psm.urdf.robot.joints}
        for i, name in enumerate(self.psm.joint_names):
            urdf_v[i] = joints[name].limit.velocity
        self.v_limit = urdf_v * scene.velocity_ratio
        self.a_limit = self.v_limit * scene.acceleration_ratio
        jaw_v = joints["jaw"].limit.velocity if self.psm.has_jaw else 1.0
        self.jaw_v_limit, self.jaw_a_limit = np.array([jaw_v * scene.velocity_ratio]), np.array(
            [jaw_v * scene.velocity_ratio * scene.acceleration_ratio])

        self.sim_ns = 0
        self.ticks = 0
        self.next_tf_ns = 0
        self.next_sensor_ns = {"camera": 0, "ultrasound": 0}  # 0: due at the next tick
        self._sensed = False
        self._rendered = False
        self.camera = CameraTopics(self, self.bodies.engine, self.bodies.scenery.camera, self.bodies.scenery.labels, N)
        self._create_sensor_publishers()
        self.ultrasound = None
        if self.bodies.scenery.ultrasound is not None:
            self.ultrasound = UltrasoundTopics(self, self.bodies.engine, self.bodies.scenery.ultrasound, N)
        self._tick_times = collections.deque(maxlen=500)
        self._create_event_publishers()
        self._create_subscriptions()
        self._create_services()
        self.clock_pub = self.create_publisher(ClockMsg, CLOCK_TOPIC, CLOCK_QOS)
        self.tf_pub = self.create_publisher(TFMessage, TF_TOPIC, PERIODIC_QOS)
        self.tf_static_pub = self.create_publisher(TFMessage, TF_STATIC_TOPIC, TF_STATIC_QOS)
        self.timer = None
        self._set_rate()
        if self.cfg["record"]:
            try:
                self.recorder = open_recorder(self.cfg["record"])
            except (RecordingUnavailable, OSError, ValueError) as exc:
                raise ConfigError(f"record: {exc}") from None
        self._publish_static_tf()
        for env in range(N):
            self._publish_state(env)

    def _publish_static_tf(self):
        """world -> base (the scene's base pose) and world -> camera of every env, once, latched."""
        stamp, N, scene = self.stamp(), self.num_envs, self.scene
        spec = self.bodies.scenery
        transforms = []
        for env in range(N):
            prefix = env_frame_prefix(env, N)
            transforms.append(_transform(stamp, f"{prefix}world", f"{prefix}{self.arm}_base",
                                         (*scene.base_position, *scene.base_rotation)))
            transforms.append(_transform(stamp, f"{prefix}world", camera_frame(env, N),
                                         (*spec.camera.position, *spec.camera_rotation)))
            if spec.ultrasound is not None:
                position, rotation = spec.probe_pose()
                transforms.append(_transform(stamp, f"{prefix}world", ultrasound_frame(env, N, spec.ultrasound.frame),
                                             (*position, *rotation)))
        self.static_tf = TFMessage(transforms=transforms)
        self.tf_static_pub.publish(self.static_tf)
        if self.recorder is not None:
            self._record(TF_STATIC_TOPIC, self.static_tf)

    def _set_rate(self):
        period = 1.0 / self.cfg["publish_rate"]
        self.period_ns = int(round(period * 1e9))
        substeps = int(round(self.cfg["physics_rate"] / self.cfg["publish_rate"]))
        self.bodies.set_rate(period, substeps)
        if self.timer is not None:
            self.destroy_timer(self.timer)
        self.timer = self.create_timer(period, self._tick, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _create_event_publishers(self):
        self.event_pubs = [[{name: self.create_publisher(msg_type, f"{ns}/{name}", EVENT_QOS)
                             for name, msg_type in (("operating_state", OperatingState), ("desired_state", String),
                                                    ("goal_reached", Bool), ("error", String),
                                                    ("warning", String), ("status", String))}
                            for ns in namespaces] for namespaces in self.namespaces]

    def _create_sensor_publishers(self):
        types = {"measured_js": JointState, "setpoint_js": JointState, "jaw/measured_js": JointState,
                 "jaw/setpoint_js": JointState, "measured_cp": PoseStamped, "setpoint_cp": PoseStamped,
                 "local/measured_cp": PoseStamped, "local/setpoint_cp": PoseStamped, "measured_cv": TwistStamped,
                 "body/measured_cf": WrenchStamped, "spatial/measured_cf": WrenchStamped,
                 "body/jacobian": Float64MultiArray, "spatial/jacobian": Float64MultiArray}
        if not hasattr(self, "sensor_pubs"):
            self.sensor_pubs = [[{} for _ in namespaces] for namespaces in self.namespaces]
        for env, namespaces in enumerate(self.namespaces):  # publishers of newly enabled groups
            for k, ns in enumerate(namespaces):
                for group in self.cfg["sensors"]:
                    for topic in SENSOR_TOPICS.get(group, ()):
                        if topic not in self.sensor_pubs[env][k]:
                            self.sensor_pubs[env][k][topic] = self.create_publisher(
                                types[topic], f"{ns}/{topic}", PERIODIC_QOS)
        if hasattr(self, "camera"):
            self.camera.enable(self.cfg["sensors"])

    def _create_subscriptions(self):
        handlers = (("state_command", StringStamped, self._on_state_command),
                    ("servo_jp", JointState, self._on_servo_jp), ("servo_jr", JointState, self._on_servo_jr),
                    ("move_jp", JointState, self._on_move_jp), ("move_jr", JointState, self._on_move_jr),
                    ("servo_cp", PoseStamped, self._on_servo_cp), ("move_cp", PoseStamped, self._on_move_cp),
                    ("jaw/servo_jp", JointState, self._on_jaw_servo_jp),
                    ("jaw/move_jp", JointState, self._on_jaw_move_jp),
                    ("hold", Empty, self._on_hold), ("free", Empty, self._on_unsupported),
                    ("servo_jf", JointState, self._on_unsupported),
                    ("jaw/servo_jf", JointState, self._on_unsupported),
                    ("body/servo_cf", WrenchStamped, self._on_unsupported),
                    ("spatial/servo_cf", WrenchStamped, self._on_unsupported),
                    ("set_base_frame", PoseStamped, self._on_set_base_frame),
                    ("trajectory_j/set_ratio", Float64, self._on_set_ratio))
        self._command_subs = []
        for env, namespaces in enumerate(self.namespaces):
            for ns in namespaces:
                for topic, msg_type, handler in handlers:
                    callback = functools.partial(handler, env) if topic not in ("free", "servo_jf", "jaw/servo_jf",
                                                                                  "body/servo_cf", "spatial/servo_cf") \
                        else functools.partial(handler, env, topic)
                    self._command_subs.append(self.create_subscription(msg_type, f"{ns}/{topic}", callback,
                                                                        COMMAND_QOS))

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
                    self._service_handles.append(self.create_service(srv_type, f"{ns}/{name}",
                                                              functools.partial(self._guarded_service, name, handler, env)))

    # ------------------------------------------------------------------ time and output helpers
    def stamp(self) -> TimeMsg:
        """Stamp of everything published: the node's clock, or with use_sim_time the simulated
        time this node itself publishes on /clock. Never zero (zero means invalid to clients)."""
        if self.use_sim_time:
            ns = max(self.sim_ns, 1)
        else:
            ns = self.get_clock().now().nanoseconds
            ns = ns if ns > 0 else time.time_ns()
        return TimeMsg(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def now_ns(self) -> int:
        s = self.stamp()
        return s.sec * 1_000_000_000 + s.nanosec

    def _emit(self, env: int, name: str, msg, stamp_ns: int | None = None):
        """Publishes an event message on all of env's namespaces (and records it)."""
        for pubs in self.event_pubs[env]:
            pubs[name].publish(msg)
        if self.recorder is not None:  # under the env's first namespace only (no duplicates)
            self._record(f"{self.namespaces[env][0]}/{name}", msg, stamp_ns)

    def _record(self, topic, msg, stamp_ns=None):
        try:
            self.recorder.write(topic, msg, stamp_ns if stamp_ns is not None else self.now_ns())
        except Exception as exc:  # noqa: BLE001 - a recording problem must not stop the twin
            self.get_logger().error(f"recording failed, stopped: {exc}")
            self._close_recorder()

    def _record_command(self, env, kind, msg):
        if self.recorder is not None:
            self._record(f"{self.namespaces[env][0]}/{kind}", msg)

    def _close_recorder(self):
        recorder, self.recorder = self.recorder, None
        if recorder is not None:
            try:
                recorder.close()
            except Exception as exc:  # noqa: BLE001
                self.get_logger().error(f"closing the recording failed: {exc}")

    def _label(self, env: int) -> str:
        return self.arm if self.num_envs == 1 else f"env{env}/{self.arm}"

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
        line = f"{self._label(env)}: {text}{suffix}"
        self._emit(env, level, String(data=line))
        if level == "error":
            self.get_logger().error(line, throttle_duration_sec=LOG_THROTTLE_S)
        else:
            self.get_logger().warning(line, throttle_duration_sec=LOG_THROTTLE_S)

    def _status(self, env: int, text: str):
        self._emit(env, "status", String(data=f"{self._label(env)}: {text}"))

    def _operating_state(self, env: int) -> OperatingState:
        s = self.states[env]
        msg = OperatingState(state=s.state, is_homed=s.is_homed, is_busy=s.is_busy)
        msg.header.stamp = self.stamp()
        msg.header.frame_id = self.base_frame_id[env]
        return msg

    def _publish_state(self, env: int):
        self._emit(env, "operating_state", self._operating_state(env))

    def _check_stamp(self, env, kind, header) -> bool:
        if self.use_sim_time:
            return True
        problem = stale_refusal(header.stamp, self.now_ns(), self.scene.stale_command_after, what=kind)
        if problem:
            self._refuse(env, kind, problem)
            return False
        return True

    def _ready(self, env, kind) -> bool:
        problem = self.states[env].motion_refusal(kind)
        if problem:
            self._refuse(env, kind, problem)
            return False
        return True

    # ------------------------------------------------------------------ motion bookkeeping
    def _stop_arm_motion(self, env: int, *, reached: bool | None = None):
        """Stops env's arm trajectory where it is (the setpoint keeps its last value)."""
        was = self.arm_motion[env]
        if was is not None:
            self.arm_traj.stop(env)
            self.arm_motion[env] = None
            if was == "move":
                self._emit(env, "goal_reached", Bool(data=bool(reached)))
        self.cp_pending.pop(env, None)

    def _stop_jaw_motion(self, env: int):
        if self.jaw_moving[env]:
            self.jaw_traj.stop(env)
            self.jaw_moving[env] = False
            self._emit(env, "goal_reached", Bool(data=False))

    def _update_busy(self, env: int, *, force: bool = False):
        """Re-derives is_busy; publishes operating_state when it changed (or when forced)."""
        s = self.states[env]
        before = s.is_busy
        s.busy = self.arm_motion[env] == "move" or self.jaw_moving[env]
        if force or s.is_busy != before:
            self._publish_state(env)

    def _start_arm_trajectory(self, env: int, goal: np.ndarray, kind: str):
        self._stop_arm_motion(env, reached=False)
        start = self.setpoint[env].cpu().numpy()
        ratio = self.ratio[env]
        self.arm_traj.start(env, start, goal, self.v_limit * ratio + 1e-12, self.a_limit * ratio + 1e-12,
                            self.sim_ns * 1e-9)
        self.arm_motion[env] = kind

    # ------------------------------------------------------------------ subscriptions
    @guarded("state_command")
    def _on_state_command(self, env, msg):
        if not self._check_stamp(env, "state_command", msg.header):
            return
        transition = self.states[env].command(msg.string.strip())
        if transition.error:
            self._refuse(env, "state_command", transition.error)
            return
        if transition.stop_motion:
            self._stop_arm_motion(env, reached=False)
            self._stop_jaw_motion(env)
        if transition.desired:
            self._emit(env, "desired_state", String(data=transition.desired))
        if transition.start_homing:
            home = self.scene.home_jp
            goal = np.array(home, dtype=np.float64) if home is not None else self.setpoint[env].cpu().numpy()
            goal[self.psm.dof:] = 0.0
            self._start_arm_trajectory(env, goal, "home")
        if transition.status:
            self._status(env, transition.status)
        self._update_busy(env, force=transition.publish)

    def _arm_values(self, env, kind, msg, *, relative=False):
        """Checked joint positions of a JointState arm command, absolute (None if refused)."""
        q, problem = joint_values(msg, what=kind, names=PSM_JOINT_NAMES,
                                  lower=None if relative else self.kin.lower_np,
                                  upper=None if relative else self.kin.upper_np)
        if problem is None and relative:
            q = self.setpoint[env].cpu().numpy() + q
            problem = limit_refusal(q, PSM_JOINT_NAMES, self.kin.lower_np, self.kin.upper_np, what=kind)
        if problem:
            self._refuse(env, kind, problem)
            return None
        return q

    def _servo(self, env, kind, msg, relative):
        if not (self._check_stamp(env, kind, msg.header) and self._ready(env, kind)):
            return
        q = self._arm_values(env, kind, msg, relative=relative)
        if q is None:
            return
        self._stop_arm_motion(env, reached=False)
        self.setpoint[env] = torch.as_tensor(q, dtype=self.setpoint.dtype)
        self._update_busy(env)

    def _move(self, env, kind, msg, relative):
        if not (self._check_stamp(env, kind, msg.header) and self._ready(env, kind)):
            return
        q = self._arm_values(env, kind, msg, relative=relative)
        if q is None:
            return
        self._start_move(env, q)

    def _start_move(self, env, q):
        self._start_arm_trajectory(env, q, "move")
        self._update_busy(env, force=True)  # is_busy=true, stamped after the command

    @guarded("servo_jp")
    def _on_servo_jp(self, env, msg):
        self._servo(env, "servo_jp", msg, relative=False)

    @guarded("servo_jr")
    def _on_servo_jr(self, env, msg):
        self._servo(env, "servo_jr", msg, relative=True)

    @guarded("move_jp")
    def _on_move_jp(self, env, msg):
        self._move(env, "move_jp", msg, relative=False)

    @guarded("move_jr")
    def _on_move_jr(self, env, msg):
        self._move(env, "move_jr", msg, relative=True)

    def _local_pose(self, env, kind, msg):
        """A PoseStamped in the measured_cp frame, checked, as a 4x4 in the RCM frame."""
        T, problem = pose_matrix(msg.pose, what=kind)
        if problem:
            self._refuse(env, kind, problem)
            return None
        return np.linalg.solve(self.base_frame_np[env], T)

    @guarded("servo_cp")
    def _on_servo_cp(self, env, msg):
        if not (self._check_stamp(env, "servo_cp", msg.header) and self._ready(env, "servo_cp")):
            return
        T = self._local_pose(env, "servo_cp", msg)
        if T is not None:  # IK for all envs with a pending servo_cp runs batched in the tick
            self._stop_arm_motion(env, reached=False)
            self.cp_pending[env] = T
            self._update_busy(env)

    @guarded("move_cp")
    def _on_move_cp(self, env, msg):
        if not (self._check_stamp(env, "move_cp", msg.header) and self._ready(env, "move_cp")):
            return
        T = self._local_pose(env, "move_cp", msg)
        if T is None:
            return
        q, ok = self.kin.inverse(torch.as_tensor(T[None]), self.setpoint[env: env + 1])
        if not bool(ok[0]):
            self._refuse(env, "move_cp", f"move_cp refused: pose {_describe_pose(T)} (RCM frame) is not "
                                         "reachable within the joint limits")
            return
        self._start_move(env, q[0].cpu().numpy())

    def _jaw_value(self, env, kind, msg):
        if not self.psm.has_jaw:
            self._refuse(env, kind, f"{kind} refused: the {self.robot} instrument has no jaw")
            return None
        if not (self._check_stamp(env, kind, msg.header) and self._ready(env, kind)):
            return None
        q, problem = joint_values(msg, what=kind, names=("jaw",), lower=self.jaw_lower, upper=self.jaw_upper)
        if problem:
            self._refuse(env, kind, problem)
            return None
        return q

    @guarded("jaw/servo_jp")
    def _on_jaw_servo_jp(self, env, msg):
        q = self._jaw_value(env, "jaw/servo_jp", msg)
        if q is not None:
            self._stop_jaw_motion(env)
            self.jaw_sp[env] = float(q[0])
            self._update_busy(env)

    @guarded("jaw/move_jp")
    def _on_jaw_move_jp(self, env, msg):
        q = self._jaw_value(env, "jaw/move_jp", msg)
        if q is None:
            return
        self._stop_jaw_motion(env)
        ratio = self.ratio[env]
        self.jaw_traj.start(env, self.jaw_sp[env].cpu().numpy(), q, self.jaw_v_limit * ratio,
                            self.jaw_a_limit * ratio, self.sim_ns * 1e-9)
        self.jaw_moving[env] = True
        self._update_busy(env, force=True)

    @guarded("hold")
    def _on_hold(self, env, msg):
        self._stop_arm_motion(env, reached=False)
        self._stop_jaw_motion(env)
        self._update_busy(env)

    def _on_unsupported(self, env, kind, msg):
        try:
            self._record_command(env, kind, msg)
            what = "free (a compliant arm)" if kind == "free" else "effort and force control"
            arm = "joint-driven (position drives)" if self.dynamic else "kinematic"
            self._refuse(env, kind, f"{kind} refused: {what} is not simulated; the twin's arm is {arm}",
                         level="warning")
        except Exception:  # noqa: BLE001
            self.get_logger().error(traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)

    @guarded("set_base_frame")
    def _on_set_base_frame(self, env, msg):
        T, problem = pose_matrix(msg.pose, what="set_base_frame")
        if problem:
            self._refuse(env, "set_base_frame", problem)
            return
        self.base_frame_np[env] = T
        self.base_frame[env] = torch.as_tensor(T, dtype=self.base_frame.dtype)
        if msg.header.frame_id:
            self.base_frame_id[env] = msg.header.frame_id
        self._status(env, f"base frame set ({self.base_frame_id[env]})")

    @guarded("trajectory_j/set_ratio")
    def _on_set_ratio(self, env, msg):
        value, problem = ratio_value(msg.data, what="trajectory_j/set_ratio")
        if problem:
            self._refuse(env, "trajectory_j/set_ratio", problem)
            return
        self.ratio[env] = value

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
        response.operating_state = self._operating_state(env)
        return response

    def _srv_crtk_version(self, env, request, response):
        response.success, response.message = True, CRTK_VERSION
        return response

    def _srv_fk(self, env, request, response, *, local):
        msg = JointState(position=list(request.jp))
        q, problem = joint_values(msg, what="forward_kinematics", names=PSM_JOINT_NAMES,
                                  lower=self.kin.lower_np, upper=self.kin.upper_np)
        if problem:
            response.result, response.message = False, problem
            return response
        T = self.kin.forward(torch.as_tensor(q[None], device=self.device))[0]
        if not local:
            T = self.base_frame[env] @ T
        _fill_pose(response.cp, matrix_to_pose7(T[None])[0].cpu().numpy())
        response.result = True
        return response

    def _srv_ik(self, env, request, response):
        T, problem = pose_matrix(request.cp, what="inverse_kinematics")
        if problem is None and request.jp:
            seed, problem = joint_values(JointState(position=list(request.jp)), what="inverse_kinematics seed",
                                         names=PSM_JOINT_NAMES, lower=None, upper=None)
        else:
            seed = self.setpoint[env].cpu().numpy()
        if problem:
            response.result, response.message = False, problem
            return response
        local = np.linalg.solve(self.base_frame_np[env], T)
        q, ok = self.kin.inverse(torch.as_tensor(local[None]), torch.as_tensor(seed[None]))
        response.jp = q[0].cpu().tolist()
        response.result = bool(ok[0])
        response.message = "" if response.result else "pose not reachable within the joint limits (jp: nearest)"
        return response

    # ------------------------------------------------------------------ the tick
    def _tick(self):
        started = time.perf_counter()
        try:
            finished, jfinished, faults = self._advance()
            self._publish()
            # events after the data of the same tick: a client that sees is_busy=false then
            # reads measured/setpoint gets the values at the goal
            self._finish_motions(finished, jfinished)
            for env, flags in faults:
                self._fault(env, flags)
        except Exception:  # noqa: BLE001 - a failing tick is reported and the next one runs
            self.get_logger().error("tick failed: " + traceback.format_exc(), throttle_duration_sec=LOG_THROTTLE_S)
        self._tick_times.append(time.perf_counter() - started)

    def _advance(self):
        dt = self.period_ns * 1e-9
        self.sim_ns += self.period_ns
        self.ticks += 1
        now = self.sim_ns * 1e-9
        if self.cp_pending:
            self._solve_servo_cp()
        q, qd, moving, finished = self.arm_traj.evaluate(now)
        jq, jqd, jmoving, jfinished = self.jaw_traj.evaluate(now)
        self.setpoint = torch.where(moving[:, None], q, self.setpoint)
        self.jaw_sp = torch.where(jmoving[:, None], jq, self.jaw_sp)
        for hook in self.step_hooks:  # in-process drivers write the setpoints of their envs here
            hook(self)
        self.setpoint_v = torch.where(moving[:, None], qd, (self.setpoint - self._last_sp) / dt)
        self.jaw_sp_v = torch.where(jmoving[:, None], jqd, (self.jaw_sp - self._last_jaw_sp) / dt)
        self._last_sp, self._last_jaw_sp = self.setpoint.clone(), self.jaw_sp.clone()
        # sensors run in the same submit as the physics of the tick they are due in
        self._rendered = any(p in self.cfg["sensors"] for p in PRODUCTS) and self._due("camera")
        self._sensed = self.ultrasound is not None and "ultrasound" in self.cfg["sensors"] and self._due("ultrasound")
        render, sense = self._rendered, self._sensed
        if self.dynamic:
            # the engine's joint drives track the setpoint; kinematic links follow measured
            self.bodies.set_targets(self.setpoint, self.jaw_sp)
            self.bodies.write(self.measured, self.jaw_meas)
            self.bodies.step(render, sense)
            q_m, qd_m, jaw_m, jawd_m = self.bodies.read_joints()
            dof = self.psm.dof
            self.measured, self.measured_v = self.measured.clone(), self.measured_v.clone()
            self.measured[:, :dof], self.measured_v[:, :dof] = q_m, qd_m
            self.jaw_meas, self.jaw_meas_v = jaw_m, jawd_m
        else:
            # measured follows setpoint through a first-order lag (exact for tau = 0)
            tau = self.scene.measured_lag
            alpha = 1.0 if tau <= 0 else 1.0 - math.exp(-dt / tau)
            new_meas = self.measured + alpha * (self.setpoint - self.measured)
            new_jaw = self.jaw_meas + alpha * (self.jaw_sp - self.jaw_meas)
            self.measured_v, self.jaw_meas_v = (new_meas - self.measured) / dt, (new_jaw - self.jaw_meas) / dt
            self.measured, self.jaw_meas = new_meas, new_jaw
            self.bodies.write(self.measured, self.jaw_meas)
            self.bodies.step(render, sense)
        faults = self._check_health()
        return finished, jfinished, faults

    def _due(self, sensor: str) -> bool:
        """Whether `sensor` runs this tick: on average at its rate (frames fall on ticks), never
        faster, and without a burst after a slower rate or a pause."""
        next_ns = self.next_sensor_ns[sensor]
        if self.sim_ns < next_ns:
            return False
        period = int(round(1e9 / self.cfg[f"{sensor}_rate"]))
        next_ns = (next_ns or self.sim_ns) + period
        self.next_sensor_ns[sensor] = next_ns if next_ns > self.sim_ns else self.sim_ns + period
        return True

    def _check_health(self):
        """Envs the engine flagged this frame: [(env, flags)]. Their measured state (NaN or
        exploded in dynamic mode) is replaced by the setpoint at rest, which is also where the
        engine's reset at the start of the next frame puts the arm."""
        flags = self.bodies.health_flags()
        bad = flags != 0
        if not bool(bad.any()):  # one small device -> host read per tick
            return []
        envs = torch.nonzero(bad).flatten()
        self.measured[envs] = self.setpoint[envs]
        self.measured_v[envs] = 0.0
        self.jaw_meas[envs] = self.jaw_sp[envs]
        self.jaw_meas_v[envs] = 0.0
        self.bodies.prepare_reset(envs, self.setpoint[envs], self.jaw_sp[envs])
        return list(zip(envs.tolist(), flags[envs].tolist()))

    def _fault(self, env: int, flags: int):
        """The engine flagged env: FAULT (motion stops), the reason on `error` once per fault."""
        what = describe_health(flags)
        self.get_logger().error(f"{self._label(env)}: physics fault: {what} (env.health = {flags})",
                                throttle_duration_sec=LOG_THROTTLE_S)
        if self.states[env].state == FAULT:
            return  # still faulting: reported when it started
        self._stop_arm_motion(env, reached=False)
        self._stop_jaw_motion(env)
        self.states[env].fault()
        self._update_busy(env, force=True)
        self._emit(env, "error", String(data=f"{self._label(env)}: physics fault: the engine flagged {what} "
                                             f"(env.health = {flags}) and reset the env; the arm is FAULT, "
                                             "send enable to clear it"))

    def reset_envs(self, envs, q=None, jaw=None):
        """In-process API: resets `envs` (a list or long tensor) in the engine at the next step,
        with the arm at joint values q (len(envs), 6) and jaw (len(envs), 1) at rest (default:
        their current setpoints). Setpoints and measured follow; running motions of these envs
        stop. Call it from a step hook (or between ticks)."""
        envs = torch.as_tensor(envs, device=self.device, dtype=torch.long).reshape(-1)
        kw = dict(device=self.device, dtype=torch.float64)
        q = self.setpoint[envs] if q is None else torch.as_tensor(q, **kw).reshape(len(envs), INTERFACE_DOF)
        jaw = self.jaw_sp[envs] if jaw is None else torch.as_tensor(jaw, **kw).reshape(len(envs), 1)
        for env in envs.tolist():
            self._stop_arm_motion(env, reached=False)
            self._stop_jaw_motion(env)
        for name in ("setpoint", "measured", "_last_sp"):
            getattr(self, name)[envs] = q
        for name in ("jaw_sp", "jaw_meas", "_last_jaw_sp"):
            getattr(self, name)[envs] = jaw
        for name in ("setpoint_v", "measured_v", "jaw_sp_v", "jaw_meas_v"):
            getattr(self, name)[envs] = 0.0
        self.bodies.prepare_reset(envs, q, jaw)
        self.bodies.engine.reset_envs(envs.tolist())

    def _finish_motions(self, finished, jfinished):
        """Events of trajectories that reached their goal this tick (arm, jaw: (N,) bool)."""
        if not (bool(finished.any()) or bool(jfinished.any())):
            return
        for env in torch.nonzero(finished).flatten().tolist():
            self._arm_finished(env)
        for env in torch.nonzero(jfinished).flatten().tolist():
            self.jaw_moving[env] = False
            self._emit(env, "goal_reached", Bool(data=True))
            self._update_busy(env)

    def _arm_finished(self, env):
        kind, self.arm_motion[env] = self.arm_motion[env], None
        if kind == "home":
            self.states[env].homing_done()
            self._status(env, "homed")
            self._update_busy(env, force=True)
        else:
            self._emit(env, "goal_reached", Bool(data=True))
            self._update_busy(env)

    def _solve_servo_cp(self):
        envs = list(self.cp_pending)
        T = torch.as_tensor(np.stack([self.cp_pending[e] for e in envs]), device=self.device)
        self.cp_pending.clear()
        idx = torch.as_tensor(envs, device=self.device)
        q, ok = self.kin.inverse(T, self.setpoint[idx])
        self.setpoint[idx] = torch.where(ok[:, None], q, self.setpoint[idx])
        if not bool(ok.all()):
            for k in torch.nonzero(~ok).flatten().tolist():
                self._refuse(envs[k], "servo_cp", f"servo_cp refused: pose {_describe_pose(T[k].cpu().numpy())} "
                                                  "(RCM frame) is not reachable within the joint limits")

    def _publish(self):
        groups = set(self.cfg["sensors"])
        N = self.num_envs
        stamp = self.stamp()
        stamp_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        # everything published, packed into one tensor: one device -> host copy per tick
        parts = [self.measured, self.measured_v, self.setpoint, self.setpoint_v, self.jaw_meas, self.jaw_meas_v,
                 self.jaw_sp, self.jaw_sp_v]
        need_cp = bool(groups & {"cartesian", "velocity", "jacobian", "tf"})
        if need_cp:
            # one Jacobian/FK call for measured and setpoint together, one quaternion conversion
            J2, T2 = self.kin.jacobian(torch.cat([self.measured, self.setpoint]))
            J, T_meas = J2[:N], T2[:N]
            base = self.base_frame
            poses = matrix_to_pose7(torch.cat([T2, base.repeat(2, 1, 1) @ T2])).reshape(4, N, 7)
            parts += list(poses)  # local measured, local setpoint, measured, setpoint
            twist = J @ self.measured_v[:, :, None]  # (N, 6, 1) in the RCM frame
            R = base[:, :3, :3]
            parts += [(R @ twist[:, :3]).squeeze(-1), (R @ twist[:, 3:]).squeeze(-1)]
            if "jacobian" in groups:
                parts += [J.reshape(N, 36), body_jacobian(J, T_meas).reshape(N, 36)]
        host = torch.cat(parts, dim=1).cpu().numpy()
        names, jaw_names = list(PSM_JOINT_NAMES), ["jaw"]
        zeros6, zeros1 = array("d", [0.0] * 6), array("d", [0.0])
        publish_tf = "tf" in groups and self.sim_ns >= self.next_tf_ns
        if publish_tf:
            self.next_tf_ns = self.sim_ns + int(1e9 / self.cfg["tf_rate"])
        transforms = []
        for env in range(N):
            row = host[env]
            msgs = {}
            if "joints" in groups:
                msgs["measured_js"] = _joint_state(stamp, names, row[0:6], row[6:12], zeros6)
                msgs["setpoint_js"] = _joint_state(stamp, names, row[12:18], row[18:24], zeros6)
                msgs["jaw/measured_js"] = _joint_state(stamp, jaw_names, row[24:25], row[25:26], zeros1)
                msgs["jaw/setpoint_js"] = _joint_state(stamp, jaw_names, row[26:27], row[27:28], zeros1)
            prefix = env_frame_prefix(env, N)
            local_frame, base_frame, tip_frame = f"{prefix}{self.arm}_base", self.base_frame_id[env], f"{prefix}{self.arm}"
            if need_cp:
                o = 28
                if "cartesian" in groups:
                    msgs["local/measured_cp"] = _pose_stamped(stamp, local_frame, row[o:o + 7])
                    msgs["local/setpoint_cp"] = _pose_stamped(stamp, local_frame, row[o + 7:o + 14])
                    msgs["measured_cp"] = _pose_stamped(stamp, base_frame, row[o + 14:o + 21])
                    msgs["setpoint_cp"] = _pose_stamped(stamp, base_frame, row[o + 21:o + 28])
                if "velocity" in groups:
                    m = TwistStamped()
                    m.header.stamp, m.header.frame_id = stamp, base_frame
                    v, w = row[o + 28:o + 31], row[o + 31:o + 34]
                    m.twist.linear.x, m.twist.linear.y, m.twist.linear.z = float(v[0]), float(v[1]), float(v[2])
                    m.twist.angular.x, m.twist.angular.y, m.twist.angular.z = float(w[0]), float(w[1]), float(w[2])
                    msgs["measured_cv"] = m
                if "jacobian" in groups:
                    msgs["spatial/jacobian"] = _matrix_msg(row[o + 34:o + 70])
                    msgs["body/jacobian"] = _matrix_msg(row[o + 70:o + 106])
                if publish_tf:
                    transforms.append(_transform(stamp, local_frame, tip_frame, row[o:o + 7]))
            if "wrench" in groups:  # the kinematic arm senses no force
                msgs["spatial/measured_cf"] = _wrench(stamp, base_frame)
                msgs["body/measured_cf"] = _wrench(stamp, tip_frame)
            for k, pubs in enumerate(self.sensor_pubs[env]):
                for topic, msg in msgs.items():
                    pub = pubs.get(topic)
                    if pub is not None:
                        pub.publish(msg)
                        if self.recorder is not None and k == 0:
                            self._record(f"{self.namespaces[env][0]}/{topic}", msg, stamp_ns)
        if transforms:  # all envs' base -> tip in one message
            tf = TFMessage(transforms=transforms)
            self.tf_pub.publish(tf)
            if self.recorder is not None:
                self._record(TF_TOPIC, tf, stamp_ns)
        record = None
        if self.recorder is not None:
            def record(topic, msg):
                self._record(topic, msg, stamp_ns)
        if self._rendered:
            self.camera.publish(self.cfg["sensors"], stamp, record)
        if self._sensed:
            self.ultrasound.publish(stamp, record)
        if "clock" in groups:
            clock = ClockMsg()
            clock.clock = TimeMsg(sec=self.sim_ns // 1_000_000_000, nanosec=self.sim_ns % 1_000_000_000)
            self.clock_pub.publish(clock)

    # ------------------------------------------------------------------ shutdown
    def close(self):
        self._close_recorder()
        if self.refusals:
            summary = ", ".join(f"{self._label(env)} {kind}: {n}" for (env, kind), n in sorted(self.refusals.items()))
            self.get_logger().info(f"refused commands: {summary}")
        if self._tick_times:
            ticks = np.array(self._tick_times) * 1e3
            self.get_logger().info(f"tick time over the last {len(ticks)}: mean {ticks.mean():.2f} ms, "
                                   f"max {ticks.max():.2f} ms")


def _transform(stamp, parent, child, p) -> TransformStamped:
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (float(p[0]), float(p[1]),
                                                                                       float(p[2]))
    r = t.transform.rotation
    r.x, r.y, r.z, r.w = float(p[3]), float(p[4]), float(p[5]), float(p[6])
    return t


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
    _fill_pose(m.pose, p)
    return m


def _fill_pose(pose, p):
    pose.position.x, pose.position.y, pose.position.z = float(p[0]), float(p[1]), float(p[2])
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (
        float(p[3]), float(p[4]), float(p[5]), float(p[6]))


def _wrench(stamp, frame) -> WrenchStamped:
    m = WrenchStamped()
    m.header.stamp, m.header.frame_id = stamp, frame
    return m


def _matrix_msg(values) -> Float64MultiArray:
    m = Float64MultiArray()
    m.layout.dim = [MultiArrayDimension(label="rows", size=6, stride=36),
                    MultiArrayDimension(label="columns", size=6, stride=6)]
    m.data = array("d", values)
    return m


def _describe_pose(T) -> str:
    p = np.asarray(T)[:3, 3]
    return f"at ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) m"


def main(args=None) -> int:
    """Entry point `cressim_twin` (and `python -m cressim_ros`)."""
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    # rclpy.init() of this rclpy (the Jazzy wheels) returns None, not the context manager newer
    # demos use with `with`; try/finally does the same.
    torch.set_num_threads(1)  # tensors of a few envs: threads only contend with DDS and the engine
    rclpy.init(args=args)
    try:
        try:
            node = TwinNode()
        except ConfigError as exc:
            rclpy.logging.get_logger("cressim_twin").fatal(f"not started: {exc}")
            return 2
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        try:
            executor.spin()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            node.close()
            node.destroy_node()
    finally:
        rclpy.try_shutdown()
    return 0


__all__ = ["ConfigError", "TwinNode", "main"]
