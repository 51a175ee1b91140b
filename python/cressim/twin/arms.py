"""N simulated dVRK PSMs as batched state, spoken to in the dVRK's terms, without ROS.

    arms = TwinArms(TwinConfig(num_envs=4))       # the scene file's arm, an engine with its bodies
    events = arms.state_command(0, "enable")       # commands return events, or a refusal event
    events = arms.move_jp(0, JointCommand(position=[0.1, 0, 0.12, 0, 0, 0]))
    events = arms.tick()                           # one control period for every env
    snap = arms.snapshot()                         # what a tick publishes (host numpy, one copy)

The arm model. TwinArms is the PSM kind of cressim.twin.arm_model.ArmModel: the batched state,
the dVRK's state machine, the CRTK commands and the tick's motions are the model's (written once
for every arm kind); this class adds the PSM's kinematics and limits from its URDF, the engine
that measures a dynamic arm and moves the world, and the instrument's plug-ins.

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

import threading
from dataclasses import dataclass, field

import numpy as np
import torch

from cressim.robots import PSM, robot_dir
from cressim.robots.dvrk import PSM_JOINTS
from cressim.robots.arm_bodies import ArmBodies, describe_health
from cressim.robots.kinematics import INTERFACE_DOF, ArmKinematics, body_jacobian, matrix_to_pose7

from .arm_model import ArmModel
from .arm_state import FAULT
from .command_checks import limit_refusal
from .instruments import build_instruments, command_plugin
from .messages import ConfigError, Event, Snapshot
from cressim.twin_scene_file import Scene, rates_problem
from .scenery import CameraSpec, SceneryPlan, UltrasoundSpec
from .sensor_loop import process_threads


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


class TwinArms(ArmModel):
    def __init__(self, config: TwinConfig, bodies: ArmBodies | None = None, *, initial_jp=None, home_jp=None,
                 names: list[str] | None = None):
        """`bodies`: the arms' links already in an engine shared with other arms (a patient
        cart's PSMs, cressim.twin.arm_rows.ArmRows: one row per arm; the cart steps that engine);
        default: an engine of its own. `initial_jp`, `home_jp`: (num_envs, 6) per row (a cart's arms each
        have their own; a NaN row homes where it is); default: the scene's for every row.
        `names`: each row's name in messages (a cart's PSM1, PSM2); default `env{i}/arm`."""
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
        home = None if home is None else np.broadcast_to(np.asarray(home, dtype=np.float64), (N, INTERFACE_DOF))
        lower, upper = np.zeros(INTERFACE_DOF), np.zeros(INTERFACE_DOF)
        lower[:dof], upper[:dof] = self.psm.lower.numpy(), self.psm.upper.numpy()
        for what, rows in (("initial_jp", initial), ("home_jp", home)):
            for values in () if rows is None else rows[~np.isnan(rows).any(1)]:
                problem = limit_refusal(values, PSM_JOINTS, lower, upper, what=what)
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
        joints = {j.name: j for j in self.psm.urdf.robot.joints}
        urdf_v = np.zeros(INTERFACE_DOF)
        for i, name in enumerate(self.psm.joint_names):
            urdf_v[i] = joints[name].limit.velocity
        v_limit = urdf_v * scene.velocity_ratio
        jaw_v = (joints["jaw"].limit.velocity if self.psm.has_jaw else 1.0) * scene.velocity_ratio
        # the arms' state is (N, 6) rows and a few (N, 4, 4): kernel launches and syncs would cost a
        # GPU more than the math, so it lives on the CPU; the engine's buffers stay on its device
        super().__init__(ArmKinematics(self.psm, "cpu"), PSM_JOINTS, num_envs=N, initial_q=initial,
                         home_q=home, v_limit=v_limit, a_limit=v_limit * scene.acceleration_ratio, period_ns=0,
                         name=self.arm, names=names, measured_lag=scene.measured_lag, jaw_limits=self.psm.jaw_limits,
                         initial_jaw=jaw0, jaw_v_limit=jaw_v, jaw_a_limit=jaw_v * scene.acceleration_ratio)
        self.set_rate(self.publish_rate)
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

    @property
    def jaw_absent(self) -> str:
        return f"the {self.robot} instrument has no jaw"

    # ------------------------------------------------------------------ the tick (ArmModel.tick's steps)
    def _before_velocities(self):
        for hook in self.step_hooks:  # in-process drivers write the setpoints of their envs here
            hook(self)

    def _measure(self, dt: float):
        """A kinematic arm's measured lags its setpoint; a dynamic arm's is the engine's. The
        arm's or the world's physics (a world that moves by itself) steps once, every tick."""
        if not self.dynamic:
            super()._measure(dt)
        if self.dynamic or self.simulated:
            with self.engine_lock:
                self._step_world()

    def _after_tick(self) -> list[Event]:
        events = []
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
        self._stop_motion(env, events)
        self.states[env].fault()
        self._update_busy(env, events, force=True)
        events.append(Event(env, "error", f"{self.label(env)}: physics fault: the engine flagged "
                                          f"{describe_health(flags)} (env.health = {flags}) and reset the env; "
                                          "the arm is FAULT, send enable to clear it"))
        return events

    def reset_envs(self, envs, q=None, jaw=None):
        """Resets `envs` (a list or long tensor) in the engine at the next step, with the arm at
        rest at joint values q (len(envs), 6) and jaw (len(envs), 1) (default: their setpoints).
        Setpoints and measured follow; running motions of these envs stop. Call it from a step
        hook (or between ticks)."""
        envs = torch.as_tensor(envs, device=self.device, dtype=torch.long).reshape(-1)
        kw = dict(device=self.device, dtype=torch.float64)
        q = self.setpoint[envs] if q is None else torch.as_tensor(q, **kw).reshape(len(envs), INTERFACE_DOF)
        jaw = self.jaw_sp[envs] if jaw is None else torch.as_tensor(jaw, **kw).reshape(len(envs), 1)
        self._reset_rows(envs, q, jaw)
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
        self._restart_state(clock=clock)
        for instrument in self.instruments.values():
            instrument.restart(self)

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


__all__ = ["TwinArms", "TwinConfig"]
