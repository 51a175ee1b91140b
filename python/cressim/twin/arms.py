"""N simulated dVRK PSMs as batched state, spoken to in the dVRK's terms, without ROS.

    arms = TwinArms(TwinConfig(num_envs=4))       # the scene file's arm, an engine with its bodies
    events = arms.state_command(0, "enable")       # commands return events, or a refusal event
    events = arms.move_jp(0, JointCommand(position=[0.1, 0, 0.12, 0, 0, 0]))
    events = arms.tick()                           # one control period for every env
    snap = arms.snapshot()                         # what a tick publishes (host numpy, one copy)

State. Every env's joints are rows of batched CPU tensors (a tick's arm math costs less than a
GPU launch; the engine's buffers stay on its device, one copy each way per frame): setpoint and
measured (N, 6), jaw (N, 1), their velocities, the base frames (N, 4, 4), the trajectories. A
command for env i validates its input (O(dof), numpy) and writes row i; `tick` advances all envs
together: trajectories, measured (a first-order lag of the setpoint, or the engine's jointed arm
in `dynamic` mode), health flags. Only the caller's publishing loops over envs.

Events. Every command and tick returns `Event(env, topic, value)`s in the order a client must
see them: `operating_state` (a `StateReport`), `desired_state`, `goal_reached`, `error`,
`warning`, `status` (str) and `trajectory_j/ratio` (float). The ROS node turns them into
messages on the arm's topics; a test reads them directly.

Behaviour (the dVRK's; docs/twin.md lists it): DISABLED at start, not homed; `home` moves the
joints to the scene's home_jp (is_busy while they move; homing an arm that is homed and idle
answers at once); motion commands need ENABLED and homed; jaw commands are clipped to the jaw's
limits; a servo, hold, pause, disable or new move stops a running move (`goal_reached` false).

The engine. `bodies` (cressim.robots.ArmBodies) holds the arm's links and the scenery. A
kinematic arm over a still world only needs posing when a sensor renders, so the engine is
stepped by whoever renders (`step_engine`, cressim.twin.SensorLoop); a dynamic arm's physics, and
any arm's in a world that moves by itself (tissue, blood: the scene's `world` file), runs in
`tick`, every tick. `engine_lock` serialises the two.

Instruments. What the arm's tool does to the world (the jaws' grasp of tissue, a needle in them,
suction, cautery, the contact wrench on the tool) are plug-ins (cressim.twin.instruments), built
where the tool and the world have what each needs, hooked around the tick's one engine frame
(`_step_world`); their commands come through `instrument_command` (`suction/servo_jp`,
`footpedals/coag`) and their state through `instrument(name)`.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

import numpy as np
import torch

from cressim.robots import PSM, PSM_JOINT_NAMES, robot_dir
from cressim.robots.arm_bodies import ArmBodies, describe_health
from cressim.robots.kinematics import INTERFACE_DOF, ArmKinematics, body_jacobian, matrix_to_pose7

from .arm_state import FAULT, ArmState
from .command_checks import joint_values, limit_refusal, pose_matrix, ratio_value
from .instruments import build_instruments, command_plugin
from .messages import ConfigError, Event, JointCommand, Snapshot, StateReport
from .scene import Scene, rates_problem
from .scenery import CameraSpec, SceneryPlan, UltrasoundSpec
from .sensor_loop import process_threads
from .trajectory import BatchedTrajectory


@dataclass
class TwinConfig:
    """What sizes a TwinArms; every field defaults to the scene file's value."""
    scene: Scene = field(default_factory=Scene)
    num_envs: int | None = None
    robot: str | None = None
    dynamics: str | None = None
    arm: str | None = None
    physics_rate: float | None = None
    particle_rate: float | None = None  # 0: physics_rate
    publish_rate: float | None = None
    camera_width: int | None = None
    camera_height: int | None = None
    cameras: bool = True  # author a camera per env (and the scenery it sees)
    ultrasound: bool = False  # author a probe and scatterers per env
    device: str | None = None

    def value(self, name):
        own = getattr(self, name)
        return getattr(self.scene, name) if own is None else own


class TwinArms:
    def __init__(self, config: TwinConfig, bodies: ArmBodies | None = None, *, initial_jp=None, home_jp=None,
                 names: list[str] | None = None):
        """`bodies`: the arms' links already in an engine shared with other arms (a patient
        cart's PSMs, cressim.twin.arm_rows.ArmRows: one row per arm; the cart steps that engine);
        default: an engine of its own. `initial_jp`, `home_jp`: (num_envs, 6) per row (a cart's arms each
        have their own; a NaN row homes where it is); default: the scene's for every row.
        `names`: each row's name in messages (a cart's PSM1, PSM2); default `env{i}/arm`."""
        self.names = names
        scene = config.scene
        self.scene = scene
        self.num_envs, self.arm, self.robot = config.value("num_envs"), config.value("arm"), config.value("robot")
        self.publish_rate, self.physics_rate = config.value("publish_rate"), config.value("physics_rate")
        self.particle_rate = config.value("particle_rate") or self.physics_rate
        problem = rates_problem(self.physics_rate, self.publish_rate, self.particle_rate)
        if problem:
            raise ConfigError(f"{problem[0]}: {problem[1]}")
        urdf = robot_dir() / f"{self.robot}.urdf"
        self.psm = PSM(urdf, dtype=torch.float64)
        N, dof = self.num_envs, self.psm.dof
        initial = np.zeros((N, INTERFACE_DOF))
        initial[:, :dof] = np.asarray(scene.initial_jp if initial_jp is None else initial_jp, dtype=np.float64)[..., :dof]
        home = scene.home_jp if home_jp is None else home_jp
        self.home_q = None if home is None else np.broadcast_to(np.asarray(home, dtype=np.float64),
                                                                (N, INTERFACE_DOF)).copy()
        lower, upper = np.zeros(INTERFACE_DOF), np.zeros(INTERFACE_DOF)
        lower[:dof], upper[:dof] = self.psm.lower.numpy(), self.psm.upper.numpy()
        for what, rows in (("initial_jp", initial), ("home_jp", self.home_q)):
            for values in () if rows is None else rows[~np.isnan(rows).any(1)]:
                problem = limit_refusal(values, PSM_JOINT_NAMES, lower, upper, what=what)
                if problem:
                    raise ConfigError(f"{scene.path}: arm.{what}: {problem}")
        camera = CameraSpec(width=config.value("camera_width"), height=config.value("camera_height"),
                            fov_y=scene.camera_fov_y, position=scene.camera_position, look_at=scene.camera_look_at)
        plan = SceneryPlan(camera, UltrasoundSpec() if config.ultrasound else None, scene.world) if config.cameras else None
        jaw0 = scene.initial_jaw if self.psm.has_jaw else 0.0
        before = process_threads()
        if bodies is None:
            bodies = ArmBodies(urdf, self.num_envs, base_position=scene.base_position,
                               base_rotation=scene.base_rotation, publish_rate=self.publish_rate,
                               physics_rate=self.physics_rate, particle_rate=self.particle_rate,
                               initial_q=initial[0], initial_jaw=jaw0,
                               dof=self.psm.dof, dynamics=config.value("dynamics"), scenery=plan,
                               device=config.device, needle=scene.needle if self.psm.has_jaw and plan else None)
        self.bodies = bodies
        self.engine_threads = process_threads() - before  # the Vulkan driver's (SensorLoop.lower_priority)
        self.dynamic = self.bodies.dynamic
        self.simulated = self.bodies.simulated  # the world moves: the engine steps in every tick
        self.engine_lock = threading.Lock()
        # the arms' state is (N, 6) rows and a few (N, 4, 4): kernel launches and syncs would cost a
        # GPU more than the math, so it lives on the CPU; the engine's buffers stay on its device
        self.device = torch.device("cpu")
        self.kin = ArmKinematics(self.psm, self.device)
        self.jaw_lower, self.jaw_upper = self.psm.jaw_limits or (0.0, 0.0)

        kw = dict(device=self.device, dtype=torch.float64)
        self._initial_q, self._initial_jaw = torch.as_tensor(initial, **kw), jaw0  # restart() returns to them
        self.setpoint = self._initial_q.clone()
        self.measured = self.setpoint.clone()
        self.setpoint_v = torch.zeros(N, INTERFACE_DOF, **kw)
        self.measured_v = torch.zeros(N, INTERFACE_DOF, **kw)
        self.jaw_sp = torch.full((N, 1), jaw0, **kw)
        self.jaw_meas = self.jaw_sp.clone()
        self.jaw_sp_v = torch.zeros(N, 1, **kw)
        self.jaw_meas_v = torch.zeros(N, 1, **kw)
        self._last_sp, self._last_jaw_sp = self.setpoint.clone(), self.jaw_sp.clone()
        self.base_frame = torch.eye(4, **kw).repeat(N, 1, 1)  # set_base_frame: measured_cp = base @ local
        self.base_frame_np = np.tile(np.eye(4), (N, 1, 1))
        self.cp_pending = {}  # env -> local 4x4 target of the newest servo_cp (solved in the tick, batched)
        self.cv = torch.zeros(N, 6, **kw)  # servo_cv twist (RCM frame) integrated each tick
        self.cv_on = np.zeros(N, dtype=bool)

        self.arm_traj = BatchedTrajectory(N, INTERFACE_DOF, device=self.device)
        self.jaw_traj = BatchedTrajectory(N, 1, device=self.device)
        self.states = [ArmState() for _ in range(N)]
        self.arm_motion = [None] * N  # None, "move" or "home": what arm_traj runs for env i
        self.jaw_moving = [False] * N
        self.ratio_v, self.ratio_a = np.ones(N), np.ones(N)  # trajectory_j/set_ratio_v, _a (set_ratio: both)
        self.flags = [dict(use_gravity_compensation=True, body_cf_orientation_absolute=False, tool_present=True,
                           adapter_present=True) for _ in range(N)]
        joints = {j.name: j for j in self.psm.urdf.robot.joints}
        urdf_v = np.zeros(INTERFACE_DOF)
        for i, name in enumerate(self.psm.joint_names):
            urdf_v[i] = joints[name].limit.velocity
        self.v_limit = urdf_v * scene.velocity_ratio
        self.a_limit = self.v_limit * scene.acceleration_ratio
        jaw_v = joints["jaw"].limit.velocity if self.psm.has_jaw else 1.0
        self.jaw_v_limit = np.array([jaw_v * scene.velocity_ratio])
        self.jaw_a_limit = self.jaw_v_limit * scene.acceleration_ratio

        self.period_ns = 0
        self.set_rate(self.publish_rate)
        self.sim_ns = 0
        self.ticks = 0
        self.step_hooks = []  # fn(arms) run in each tick before the targets are written ("Training beside the twin")
        self._faults = []  # (env, flags) seen by whoever stepped the engine, reported by the next tick
        self._faults_lock = threading.Lock()
        self.instruments = build_instruments(self)  # the tool's functions (twin/instruments), by name

    # ------------------------------------------------------------------ helpers
    def set_rate(self, publish_rate: float):
        self.publish_rate = publish_rate
        self.period_ns = int(round(1e9 / publish_rate))
        substeps = int(round(self.physics_rate / publish_rate))
        self.bodies.set_rate(1.0 / publish_rate, substeps, int(round(self.particle_rate / publish_rate)))

    def link_named(self, ending: str) -> str | None:
        """The arm's first link whose name ends so (None: its tool has none)."""
        return next((n for n in self.bodies.link_names if n.endswith(ending)), None)

    def instrument(self, name: str):
        """The instrument plug-in of that name (twin/instruments), or None where the arm has none."""
        return self.instruments.get(name)

    def instrument_command(self, env: int, kind: str, value) -> list[Event]:
        """A client's command to the arm's instrument (`suction/servo_jp`, `footpedals/coag`): taken
        by the plug-in that has it, or refused with why the arm's tool or world lacks it."""
        plugin = command_plugin(kind)
        if plugin is None:
            return self._refusal(env, f"{kind} refused: no instrument takes it")
        instrument = self.instruments.get(plugin.name)
        if instrument is None:
            return plugin.absent(self, env, kind, value)
        return getattr(instrument, plugin.commands[kind])(self, env, value)

    def label(self, env: int) -> str:
        if self.names is not None:
            return self.names[env]
        return self.arm if self.num_envs == 1 else f"env{env}/{self.arm}"

    def report(self, env: int) -> StateReport:
        s = self.states[env]
        return StateReport(s.state, s.is_homed, s.is_busy)

    def _state_event(self, env) -> Event:
        return Event(env, "operating_state", self.report(env))

    def _refusal(self, env, text, level="error") -> list[Event]:
        return [Event(env, level, text)]

    def _ready(self, env, kind) -> str | None:
        return self.states[env].motion_refusal(kind)

    def _stop_arm_motion(self, env: int, events: list, *, reached: bool = False):
        """Stops env's arm trajectory where it is (the setpoint keeps its last value)."""
        was = self.arm_motion[env]
        if was is not None:
            self.arm_traj.stop(env)
            self.arm_motion[env] = None
            if was == "move":
                events.append(Event(env, "goal_reached", bool(reached)))
            else:  # homing interrupted
                self.states[env].homing = False
        self.cp_pending.pop(env, None)
        self.cv_on[env] = False

    def _stop_jaw_motion(self, env: int, events: list):
        if self.jaw_moving[env]:
            self.jaw_traj.stop(env)
            self.jaw_moving[env] = False
            events.append(Event(env, "goal_reached", False))

    def _update_busy(self, env: int, events: list, *, force: bool = False):
        """Re-derives is_busy; an operating_state event when it changed (or when forced)."""
        s = self.states[env]
        before = s.is_busy
        s.busy = self.arm_motion[env] == "move" or self.jaw_moving[env]
        if force or s.is_busy != before:
            events.append(self._state_event(env))

    def _start_arm_trajectory(self, env: int, goal: np.ndarray, kind: str, events: list):
        self._stop_arm_motion(env, events)
        start = self.setpoint[env].cpu().numpy()
        self.arm_traj.start(env, start, goal, self.v_limit * self.ratio_v[env] + 1e-12,
                            self.a_limit * self.ratio_a[env] + 1e-12, self.sim_ns * 1e-9)
        self.arm_motion[env] = kind

    def _joints(self, env, kind, cmd, *, relative=False):
        """(absolute joint values, None) of a joint command, checked, or (None, reason)."""
        q, problem = joint_values(cmd, what=kind, names=PSM_JOINT_NAMES,
                                  lower=None if relative else self.kin.lower_np,
                                  upper=None if relative else self.kin.upper_np)
        if problem is None and relative:
            q = self.setpoint[env].cpu().numpy() + q
            problem = limit_refusal(q, PSM_JOINT_NAMES, self.kin.lower_np, self.kin.upper_np, what=kind)
        return (None, problem) if problem else (q, None)

    # ------------------------------------------------------------------ state commands
    def state_command(self, env: int, command: str) -> list[Event]:
        s, events = self.states[env], []
        command = command.strip()
        if command == "home" and s.state == "ENABLED" and s.is_homed and not s.is_busy:
            # homed and idle: the dVRK answers at once and stays where it is
            return [Event(env, "desired_state", "HOMED"), self._state_event(env)]
        transition = s.command(command)
        if transition.error:
            return self._refusal(env, transition.error)
        if transition.stop_motion:
            self._stop_arm_motion(env, events)
            self._stop_jaw_motion(env, events)
        if transition.desired:
            events.append(Event(env, "desired_state", transition.desired))
        if transition.start_homing:
            home = None if self.home_q is None or np.isnan(self.home_q[env]).any() else self.home_q[env]
            goal = home.copy() if home is not None else self.setpoint[env].cpu().numpy()
            goal[self.psm.dof:] = 0.0
            s.homing = True
            self._start_arm_trajectory(env, goal, "home", events)
        if transition.status:
            events.append(Event(env, "status", f"{self.label(env)}: {transition.status}"))
        self._update_busy(env, events, force=transition.publish)
        return events

    # ------------------------------------------------------------------ motion commands
    def servo_jp(self, env: int, cmd, *, relative: bool = False) -> list[Event]:
        kind = "servo_jr" if relative else "servo_jp"
        problem = self._ready(env, kind)
        q, problem = (None, problem) if problem else self._joints(env, kind, cmd, relative=relative)
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_arm_motion(env, events)
        self.setpoint[env] = torch.as_tensor(q, dtype=self.setpoint.dtype)
        self._update_busy(env, events)
        return events

    def move_jp(self, env: int, cmd, *, relative: bool = False) -> list[Event]:
        kind = "move_jr" if relative else "move_jp"
        problem = self._ready(env, kind)
        q, problem = (None, problem) if problem else self._joints(env, kind, cmd, relative=relative)
        if problem:
            return self._refusal(env, problem)
        return self._start_move(env, q)

    def _start_move(self, env, q) -> list[Event]:
        events = []
        self._start_arm_trajectory(env, q, "move", events)
        self._update_busy(env, events, force=True)  # is_busy=true, stamped after the command
        return events

    def _local_pose(self, env, kind, pose):
        """A Pose in the measured_cp frame, checked, as a 4x4 in the RCM frame (or the refusal)."""
        T, problem = pose_matrix(pose, what=kind)
        return (None, problem) if problem else (np.linalg.solve(self.base_frame_np[env], T), None)

    def servo_cp(self, env: int, pose) -> list[Event]:
        problem = self._ready(env, "servo_cp")
        T, problem = (None, problem) if problem else self._local_pose(env, "servo_cp", pose)
        if problem:
            return self._refusal(env, problem)
        events = []  # the IK of every env with a pending servo_cp runs batched in the tick
        self._stop_arm_motion(env, events)
        self.cp_pending[env] = T
        self._update_busy(env, events)
        return events

    def servo_cv(self, env: int, twist) -> list[Event]:
        """A tool-tip twist (linear m/s, angular rad/s, in the measured_cp frame) that each tick
        turns into joint rates (the Jacobian's least-squares inverse), held until the next
        command (a zero twist, hold, another servo or move); the joints stop at their limits."""
        problem = self._ready(env, "servo_cv")
        values = np.array([twist.linear.x, twist.linear.y, twist.linear.z,
                           twist.angular.x, twist.angular.y, twist.angular.z], dtype=np.float64)
        if problem is None and not np.isfinite(values).all():
            problem = "servo_cv refused: the twist is not finite"
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_arm_motion(env, events)
        R = self.base_frame_np[env][:3, :3]  # into the RCM frame
        self.cv[env] = torch.as_tensor(np.concatenate([R.T @ values[:3], R.T @ values[3:]]), dtype=self.cv.dtype)
        self.cv_on[env] = bool(np.any(values != 0.0))
        self._update_busy(env, events)
        return events

    def _integrate_servo_cv(self, dt: float):
        envs = np.flatnonzero(self.cv_on)
        if envs.size == 0:
            return
        idx = torch.as_tensor(envs, device=self.device)
        J, _ = self.kin.jacobian(self.setpoint[idx])
        qd = torch.linalg.lstsq(J, self.cv[idx][:, :, None]).solution[:, :, 0]
        q = torch.minimum(torch.maximum(self.setpoint[idx] + qd * dt, self.kin.lower), self.kin.upper)
        self.setpoint[idx] = q

    def move_cp(self, env: int, pose) -> list[Event]:
        problem = self._ready(env, "move_cp")
        T, problem = (None, problem) if problem else self._local_pose(env, "move_cp", pose)
        if problem:
            return self._refusal(env, problem)
        q, ok = self.kin.inverse(torch.as_tensor(T[None]), self.setpoint[env: env + 1])
        if not bool(ok[0]):
            return self._refusal(env, f"move_cp refused: pose {_describe_pose(T)} (RCM frame) is not reachable "
                                      "within the joint limits")
        return self._start_move(env, q[0].cpu().numpy())

    def _jaw(self, env, kind, cmd):
        """(clipped jaw value, None) or (None, reason). The dVRK clips jaw commands to the
        jaw's limits (a gripper closed on something is commanded past closed)."""
        if not self.psm.has_jaw:
            return None, f"{kind} refused: the {self.robot} instrument has no jaw"
        problem = self._ready(env, kind)
        if problem:
            return None, problem
        q, problem = joint_values(cmd, what=kind, names=("jaw",), lower=None, upper=None)
        if problem:
            return None, problem
        return float(np.clip(q[0], self.jaw_lower, self.jaw_upper)), None

    def jaw_servo_jp(self, env: int, cmd) -> list[Event]:
        value, problem = self._jaw(env, "jaw/servo_jp", cmd)
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_jaw_motion(env, events)
        self.jaw_sp[env] = value
        self._update_busy(env, events)
        return events

    def jaw_move_jp(self, env: int, cmd) -> list[Event]:
        value, problem = self._jaw(env, "jaw/move_jp", cmd)
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_jaw_motion(env, events)
        self.jaw_traj.start(env, self.jaw_sp[env].cpu().numpy(), np.array([value]),
                            self.jaw_v_limit * self.ratio_v[env], self.jaw_a_limit * self.ratio_a[env],
                            self.sim_ns * 1e-9)
        self.jaw_moving[env] = True
        self._update_busy(env, events, force=True)
        return events

    def hold(self, env: int) -> list[Event]:
        events = []
        self._stop_arm_motion(env, events)
        self._stop_jaw_motion(env, events)
        self._update_busy(env, events)
        return events

    # ------------------------------------------------------------------ settings
    def set_base_frame(self, env: int, pose) -> list[Event]:
        T, problem = pose_matrix(pose, what="set_base_frame")
        if problem:
            return self._refusal(env, problem)
        self.base_frame_np[env] = T
        self.base_frame[env] = torch.as_tensor(T, dtype=self.base_frame.dtype)
        return []

    def set_ratio(self, env: int, value: float, *, which: str = "") -> list[Event]:
        """trajectory_j/set_ratio (which ""): velocity and acceleration; "_v" or "_a": one of them.
        Scales the limits of later moves (the dVRK's ratios, in (0, 1])."""
        value, problem = ratio_value(value, what=f"trajectory_j/set_ratio{which}")
        if problem:
            return self._refusal(env, problem)
        if which in ("", "_v"):
            self.ratio_v[env] = value
        if which in ("", "_a"):
            self.ratio_a[env] = value
        return self.ratio_events(env)

    def ratio_events(self, env: int) -> list[Event]:
        v, a = float(self.ratio_v[env]), float(self.ratio_a[env])
        return [Event(env, "trajectory_j/ratio", min(v, a)), Event(env, "trajectory_j/ratio_v", v),
                Event(env, "trajectory_j/ratio_a", a)]

    def set_flag(self, env: int, name: str, value: bool) -> list[Event]:
        """use_gravity_compensation, body_cf_orientation_absolute, tool_present, adapter_present:
        kept and reported (the twin's arm has no effort control for them to change)."""
        self.flags[env][name] = bool(value)
        return [Event(env, "status", f"{self.label(env)}: {name} {'on' if value else 'off'}")]

    # ------------------------------------------------------------------ services
    def forward(self, env: int, cmd, *, local: bool) -> tuple[np.ndarray | None, str | None]:
        """(7-vector pose of the tool tip for the joint values, None) or (None, reason)."""
        q, problem = joint_values(cmd, what="forward_kinematics", names=PSM_JOINT_NAMES,
                                  lower=self.kin.lower_np, upper=self.kin.upper_np)
        if problem:
            return None, problem
        T = self.kin.forward(torch.as_tensor(q[None], device=self.device))[0]
        if not local:
            T = self.base_frame[env] @ T
        return matrix_to_pose7(T[None])[0].cpu().numpy(), None

    def inverse(self, env: int, pose, seed=None):
        """(joint values, reachable, message) for a Pose in the measured_cp frame."""
        T, problem = pose_matrix(pose, what="inverse_kinematics")
        if problem is None and seed is not None and len(seed):
            seed, problem = joint_values(JointCommand(position=list(seed)), what="inverse_kinematics seed",
                                         names=PSM_JOINT_NAMES, lower=None, upper=None)
        elif problem is None:
            seed = self.setpoint[env].cpu().numpy()
        if problem:
            return [], False, problem
        local = np.linalg.solve(self.base_frame_np[env], T)
        q, ok = self.kin.inverse(torch.as_tensor(local[None]), torch.as_tensor(seed[None]))
        ok = bool(ok[0])
        return q[0].cpu().tolist(), ok, "" if ok else "pose not reachable within the joint limits (jp: nearest)"

    # ------------------------------------------------------------------ the tick
    def tick(self) -> list[Event]:
        """One control period of every env. Returns the events of motions that ended and of
        faults; publish the tick's data (snapshot) before them, so that a client that sees
        is_busy=false then reads measured/setpoint at the goal."""
        dt = self.period_ns * 1e-9
        self.sim_ns += self.period_ns
        self.ticks += 1
        now = self.sim_ns * 1e-9
        events = []
        if self.cp_pending:
            events += self._solve_servo_cp()
        self._integrate_servo_cv(dt)
        q, qd, moving, finished = self.arm_traj.evaluate(now)
        jq, jqd, jmoving, jfinished = self.jaw_traj.evaluate(now)
        self.setpoint = torch.where(moving[:, None], q, self.setpoint)
        self.jaw_sp = torch.where(jmoving[:, None], jq, self.jaw_sp)
        for hook in self.step_hooks:  # in-process drivers write the setpoints of their envs here
            hook(self)
        self.setpoint_v = torch.where(moving[:, None], qd, (self.setpoint - self._last_sp) / dt)
        self.jaw_sp_v = torch.where(jmoving[:, None], jqd, (self.jaw_sp - self._last_jaw_sp) / dt)
        self._last_sp, self._last_jaw_sp = self.setpoint.clone(), self.jaw_sp.clone()
        if not self.dynamic:  # measured follows setpoint through a first-order lag (exact for tau = 0)
            tau = self.scene.measured_lag
            alpha = 1.0 if tau <= 0 else 1.0 - math.exp(-dt / tau)
            new_meas = self.measured + alpha * (self.setpoint - self.measured)
            new_jaw = self.jaw_meas + alpha * (self.jaw_sp - self.jaw_meas)
            self.measured_v, self.jaw_meas_v = (new_meas - self.measured) / dt, (new_jaw - self.jaw_meas) / dt
            self.measured, self.jaw_meas = new_meas, new_jaw
        if self.dynamic or self.simulated:  # the arm's or the world's physics: one engine frame every tick
            with self.engine_lock:
                self._step_world()
        events += self._finish_motions(finished, jfinished)
        for env, flags in self._take_faults():
            events += self._fault(env, flags)
        return events

    def _step_world(self):
        """The tick's engine frame: the joint drives track the setpoint (dynamic) and the links
        follow measured, the instruments' before-step, physics, their after-step; then a dynamic
        arm's measured joints and every env's health."""
        if self.dynamic:
            self.bodies.set_targets(self.setpoint, self.jaw_sp)
        self.bodies.write(self.measured, self.jaw_meas)
        for instrument in self.instruments.values():
            instrument.before_step(self)
        self.bodies.step()
        for instrument in self.instruments.values():
            instrument.after_step(self)
        if self.dynamic:
            q_m, qd_m, jaw_m, jawd_m = (t.cpu() for t in self.bodies.read_joints())
            dof = self.psm.dof
            self.measured, self.measured_v = self.measured.clone(), self.measured_v.clone()
            self.measured[:, :dof], self.measured_v[:, :dof] = q_m, qd_m
            self.jaw_meas, self.jaw_meas_v = jaw_m, jawd_m
        self._collect_faults()

    def step_engine(self, *, render: bool = False, sense: bool = False):
        """Engine work outside the tick (a sensor frame): a kinematic arm's links are posed at
        the measured joints and stepped with the sensors; a dynamic arm's physics ran in the
        tick, so only the sensors run. Call with `engine_lock` held."""
        posed_here = not self.dynamic and not self.simulated
        if posed_here:
            self.bodies.write(self.measured, self.jaw_meas)
            self.bodies.engine.step_physics()
        if render:
            self.bodies.engine.step_visual_sensors()
        if sense:
            self.bodies.engine.step_simulation_sensors()
        self.bodies.engine.end_frame()
        if posed_here:
            self._collect_faults()

    def _collect_faults(self):
        """Envs the engine flagged in the frame just run (one small read); their measured state
        (NaN or exploded in dynamic mode) becomes the setpoint at rest, which is also where the
        engine's reset at the start of the next frame puts the arm."""
        flags = self.bodies.health_flags().cpu()
        bad = flags != 0
        if not bool(bad.any()):
            return
        envs = torch.nonzero(bad).flatten()
        self.measured[envs] = self.setpoint[envs]
        self.measured_v[envs] = 0.0
        self.jaw_meas[envs] = self.jaw_sp[envs]
        self.jaw_meas_v[envs] = 0.0
        self.bodies.prepare_reset(envs, self.setpoint[envs], self.jaw_sp[envs])
        self._reset_instruments(envs)
        with self._faults_lock:
            self._faults += list(zip(envs.tolist(), flags[envs].tolist()))

    def _reset_instruments(self, envs: torch.Tensor):
        for instrument in self.instruments.values():
            instrument.reset(self, envs)

    def _take_faults(self):
        with self._faults_lock:
            faults, self._faults = self._faults, []
        return faults

    def _fault(self, env: int, flags: int) -> list[Event]:
        """The engine flagged env: FAULT (motion stops), the reason on `error` once per fault."""
        if self.states[env].state == FAULT:
            return []  # still faulting: reported when it started
        events = []
        self._stop_arm_motion(env, events)
        self._stop_jaw_motion(env, events)
        self.states[env].fault()
        self._update_busy(env, events, force=True)
        events.append(Event(env, "error", f"{self.label(env)}: physics fault: the engine flagged "
                                          f"{describe_health(flags)} (env.health = {flags}) and reset the env; "
                                          "the arm is FAULT, send enable to clear it"))
        return events

    def _finish_motions(self, finished, jfinished) -> list[Event]:
        events = []
        if not (bool(finished.any()) or bool(jfinished.any())):
            return events
        for env in torch.nonzero(finished).flatten().tolist():
            kind, self.arm_motion[env] = self.arm_motion[env], None
            if kind == "home":
                self.states[env].homing_done()
                events.append(Event(env, "status", f"{self.label(env)}: homed"))
                self._update_busy(env, events, force=True)
            else:
                events.append(Event(env, "goal_reached", True))
                self._update_busy(env, events)
        for env in torch.nonzero(jfinished).flatten().tolist():
            self.jaw_moving[env] = False
            events.append(Event(env, "goal_reached", True))
            self._update_busy(env, events)
        return events

    def _solve_servo_cp(self) -> list[Event]:
        envs = list(self.cp_pending)
        T = torch.as_tensor(np.stack([self.cp_pending[e] for e in envs]), device=self.device)
        self.cp_pending.clear()
        idx = torch.as_tensor(envs, device=self.device)
        q, ok = self.kin.inverse(T, self.setpoint[idx])
        self.setpoint[idx] = torch.where(ok[:, None], q, self.setpoint[idx])
        return [Event(envs[k], "error", f"servo_cp refused: pose {_describe_pose(T[k].cpu().numpy())} (RCM frame) "
                                        "is not reachable within the joint limits")
                for k in torch.nonzero(~ok).flatten().tolist()]

    def reset_envs(self, envs, q=None, jaw=None):
        """Resets `envs` (a list or long tensor) in the engine at the next step, with the arm at
        rest at joint values q (len(envs), 6) and jaw (len(envs), 1) (default: their setpoints).
        Setpoints and measured follow; running motions of these envs stop. Call it from a step
        hook (or between ticks)."""
        envs = torch.as_tensor(envs, device=self.device, dtype=torch.long).reshape(-1)
        kw = dict(device=self.device, dtype=torch.float64)
        q = self.setpoint[envs] if q is None else torch.as_tensor(q, **kw).reshape(len(envs), INTERFACE_DOF)
        jaw = self.jaw_sp[envs] if jaw is None else torch.as_tensor(jaw, **kw).reshape(len(envs), 1)
        for env in envs.tolist():
            self._stop_arm_motion(env, [])
            self._stop_jaw_motion(env, [])
        for name in ("setpoint", "measured", "_last_sp"):
            getattr(self, name)[envs] = q
        for name in ("jaw_sp", "jaw_meas", "_last_jaw_sp"):
            getattr(self, name)[envs] = jaw
        for name in ("setpoint_v", "measured_v", "jaw_sp_v", "jaw_meas_v"):
            getattr(self, name)[envs] = 0.0
        with self.engine_lock:
            self.bodies.prepare_reset(envs, q, jaw)
            self._reset_instruments(envs)
            self.bodies.reset(envs.tolist())

    # ------------------------------------------------------------------ simulation control
    def restart(self, *, clock: bool = True):
        """Every env as the twin started, between ticks: the world reset (tissue, fluid, needle in
        the jaws), the arms at rest at the scene's initial joints and jaw, DISABLED and not homed,
        base frames, ratios, pedals and valves as at start, pending commands dropped; with `clock`,
        the simulated time back at 0."""
        N, kw = self.num_envs, dict(device=self.device, dtype=torch.float64)
        self.reset_envs(torch.arange(N), q=self._initial_q, jaw=torch.full((N, 1), self._initial_jaw, **kw))
        self.states = [ArmState() for _ in range(N)]
        self.base_frame[:] = torch.eye(4, **kw)
        self.base_frame_np[:] = np.eye(4)
        self.cp_pending.clear()
        self.cv.zero_()
        self.cv_on[:] = False
        self.ratio_v[:], self.ratio_a[:] = 1.0, 1.0
        for instrument in self.instruments.values():
            instrument.restart(self)
        if clock:
            self.sim_ns, self.ticks = 0, 0

    # ------------------------------------------------------------------ what a tick publishes
    def snapshot(self, *, cartesian: bool = True, jacobian: bool = True) -> "Snapshot":
        """Every env's published state as host numpy arrays, in one device -> host copy."""
        N = self.num_envs
        names = ["measured", "measured_v", "setpoint", "setpoint_v", "jaw_meas", "jaw_meas_v", "jaw_sp", "jaw_sp_v"]
        parts = [getattr(self, n) for n in names]
        for instrument in self.instruments.values():
            for name, value in instrument.fields(self).items():
                names.append(name)
                parts.append(value)
        widths = [p.shape[1] for p in parts]
        if cartesian or jacobian:
            # one Jacobian/FK call for measured and setpoint together, one quaternion conversion
            J2, T2 = self.kin.jacobian(torch.cat([self.measured, self.setpoint]))
            J, T_meas = J2[:N], T2[:N]
            base = self.base_frame
            poses = matrix_to_pose7(torch.cat([T2, base.repeat(2, 1, 1) @ T2])).reshape(4, N, 7)
            twist = J @ self.measured_v[:, :, None]  # (N, 6, 1) in the RCM frame
            R = base[:, :3, :3]
            parts += list(poses) + [(R @ twist[:, :3]).squeeze(-1), (R @ twist[:, 3:]).squeeze(-1)]
            names += ["local_measured_cp", "local_setpoint_cp", "measured_cp", "setpoint_cp", "measured_v_linear",
                      "measured_v_angular"]
            widths += [7, 7, 7, 7, 3, 3]
            if jacobian:
                parts += [J.reshape(N, 36), body_jacobian(J, T_meas).reshape(N, 36)]
                names += ["spatial_jacobian", "body_jacobian"]
                widths += [36, 36]
            # the tool's contact wrench: world axes -> the RCM frame -> measured_cp's frame, and the tip's
            wrench = self.instruments["contact"].wrench
            R_world = self.bodies.base[..., :3, :3].to(wrench)  # one base, or one per row (ArmRows)
            local = (R_world.mT @ wrench.reshape(N, 2, 3).transpose(1, 2)).transpose(1, 2)  # (N, 2, 3)
            spatial = (base[:, None, :3, :3] @ local[..., None]).squeeze(-1)
            body = (T_meas[:, None, :3, :3].transpose(-1, -2) @ local[..., None]).squeeze(-1)
            parts += [spatial.reshape(N, 6), body.reshape(N, 6)]
            names += ["spatial_cf", "body_cf"]
            widths += [6, 6]
        host = torch.cat(parts, dim=1).cpu().numpy()
        fields, o = {}, 0
        for name, width in zip(names, widths):
            fields[name] = host[:, o:o + width]
            o += width
        return Snapshot(self.sim_ns, fields)


def _describe_pose(T) -> str:
    p = np.asarray(T)[:3, 3]
    return f"at ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) m"


__all__ = ["TwinArms", "TwinConfig"]
