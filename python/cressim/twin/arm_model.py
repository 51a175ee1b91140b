"""N arms of one kind as rows of batched state, with the dVRK's state machine and the CRTK
commands written once, without ROS or an engine.

    model = ArmModel(kin, joint_names, num_envs=N, initial_q=q0, home_q=home, v_limit=v, a_limit=a, name="PSM1")
    events = model.state_command(env, "enable")     # commands return events, or a refusal event
    events = model.move_jp(env, JointCommand(position=[...]))
    events = model.tick()                            # one control period of every row

Subclasses are the arm kinds: TwinArms (the PSMs, over an engine with instruments) and EcmArm
(the cart's endoscope holder). `kin` is the kind's kinematics: `lower`/`upper`
(torch) and `lower_np`/`upper_np`, `forward(q) -> (M, 4, 4)` (the tip in the base frame, the
RCM), `jacobian(q) -> (J, T)` (for servo_cv) and `inverse(T, seed) -> (q, ok)`.

State: every row's joints are rows of CPU tensors (a tick's arm math costs less than a GPU
launch): setpoint and measured (N, D), the jaw (N, 1) where the arm has one, their velocities,
base frames (N, 4, 4), trajectories. A command for row i validates its input (O(dof), numpy) and
writes row i; `tick` advances every row together; only a caller's publishing loops over rows.

Events: `Event(env, topic, value)` in the order a client must see them: `operating_state` (a
StateReport), `desired_state`, `goal_reached`, `error`, `warning`, `status` (str) and
`trajectory_j/ratio` (float).

Behaviour (the dVRK's; docs/twin.md lists it): DISABLED at start, not homed; `home` moves the
joints to home_q (is_busy while they move; homing an arm that is homed and idle answers at once);
motion commands need ENABLED and homed; jaw commands are clipped to the jaw's limits; a servo,
hold, pause, disable or new move stops a running move (`goal_reached` false).
"""
from __future__ import annotations

import math

import numpy as np
import torch

from cressim.robots.kinematics import matrix_to_pose7

from .arm_state import ArmState
from .command_checks import joint_values, limit_refusal, pose_matrix, ratio_value
from .messages import Event, JointCommand, StateReport
from .trajectory import BatchedTrajectory


class ArmModel:
    def __init__(self, kin, joint_names, *, num_envs: int, initial_q, home_q, v_limit, a_limit, period_ns: int,
                 name: str, names: list[str] | None = None, measured_lag: float = 0.0,
                 jaw_limits=None, initial_jaw: float = 0.0, jaw_v_limit=None, jaw_a_limit=None):
        """`initial_q` (N, D) where the rows start (restart returns there); `home_q` (N, D) or None
        (a NaN row, or None: home where it is); `v_limit`, `a_limit` (D,) the trajectories' limits;
        `jaw_limits` (lower, upper) or None for an arm without a jaw; `names`: each row's name in
        messages (default `name`, or `env{i}/name` for several rows); `measured_lag` (s): measured
        follows setpoint through a first-order lag where no engine measures it."""
        N = num_envs
        self.kin, self.num_envs, self.arm, self.names = kin, N, name, names
        self.measured_lag = measured_lag
        self.device = torch.device("cpu")
        kw = dict(device=self.device, dtype=torch.float64)
        self.joint_names = tuple(joint_names)
        self.dof = len(self.joint_names)
        self.home_q = None if home_q is None else np.broadcast_to(np.asarray(home_q, dtype=np.float64),
                                                                  (N, self.dof)).copy()
        self.v_limit, self.a_limit = np.asarray(v_limit, dtype=np.float64), np.asarray(a_limit, dtype=np.float64)
        self.has_jaw = jaw_limits is not None
        self.jaw_lower, self.jaw_upper = jaw_limits or (0.0, 0.0)
        self.jaw_v_limit = np.array([1.0 if jaw_v_limit is None else float(jaw_v_limit)])
        self.jaw_a_limit = np.array([1.0 if jaw_a_limit is None else float(jaw_a_limit)])
        self._initial_q = torch.as_tensor(np.broadcast_to(initial_q, (N, self.dof)).copy(), **kw)
        self._initial_jaw = initial_jaw
        self.setpoint = self._initial_q.clone()
        self.measured = self.setpoint.clone()
        self.setpoint_v = torch.zeros(N, self.dof, **kw)
        self.measured_v = torch.zeros(N, self.dof, **kw)
        self.jaw_sp = torch.full((N, 1), initial_jaw, **kw)
        self.jaw_meas = self.jaw_sp.clone()
        self.jaw_sp_v = torch.zeros(N, 1, **kw)
        self.jaw_meas_v = torch.zeros(N, 1, **kw)
        self._last_sp, self._last_jaw_sp = self.setpoint.clone(), self.jaw_sp.clone()
        self.base_frame = torch.eye(4, **kw).repeat(N, 1, 1)  # set_base_frame: measured_cp = base @ local
        self.base_frame_np = np.tile(np.eye(4), (N, 1, 1))
        self.cp_pending = {}  # env -> local 4x4 target of the newest servo_cp (solved in the tick, batched)
        self.cv = torch.zeros(N, 6, **kw)  # servo_cv twist (RCM frame) integrated each tick
        self.cv_on = np.zeros(N, dtype=bool)
        self.arm_traj = BatchedTrajectory(N, self.dof, device=self.device)
        self.jaw_traj = BatchedTrajectory(N, 1, device=self.device)
        self.states = [ArmState() for _ in range(N)]
        self.arm_motion = [None] * N  # None, "move" or "home": what arm_traj runs for env i
        self.jaw_moving = [False] * N
        self.ratio_v, self.ratio_a = np.ones(N), np.ones(N)  # trajectory_j/set_ratio_v, _a (set_ratio: both)
        self.flags = [dict(use_gravity_compensation=True, body_cf_orientation_absolute=False, tool_present=True,
                           adapter_present=True) for _ in range(N)]
        self.period_ns = period_ns
        self.sim_ns = 0
        self.ticks = 0

    # ------------------------------------------------------------------ helpers
    def label(self, env: int) -> str:
        if self.names is not None:
            return self.names[env]
        return self.arm if self.num_envs == 1 else f"env{env}/{self.arm}"

    def report(self, env: int = 0) -> StateReport:
        s = self.states[env]
        return StateReport(s.state, s.is_homed, s.is_busy)

    def _state_event(self, env) -> Event:
        return Event(env, "operating_state", self.report(env))

    def _refusal(self, env, text, level="error") -> list[Event]:
        return [Event(env, level, text)]

    def _stop_motion(self, env: int, events: list, *, jaw: bool = True):
        """Stops env's arm trajectory where it is (the setpoint keeps its last value), a pending
        servo_cp and servo_cv, and with `jaw` the jaw's move."""
        was = self.arm_motion[env]
        if was is not None:
            self.arm_traj.stop(env)
            self.arm_motion[env] = None
            if was == "move":
                events.append(Event(env, "goal_reached", False))
            else:  # homing interrupted
                self.states[env].homing = False
        self.cp_pending.pop(env, None)
        self.cv_on[env] = False
        if jaw and self.jaw_moving[env]:
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
        self._stop_motion(env, events, jaw=False)
        start = self.setpoint[env].cpu().numpy()
        self.arm_traj.start(env, start, goal, self.v_limit * self.ratio_v[env] + 1e-12,
                            self.a_limit * self.ratio_a[env] + 1e-12, self.sim_ns * 1e-9)
        self.arm_motion[env] = kind

    def _joints(self, env, kind, cmd, *, relative=False):
        """(absolute joint values, None) of a joint command, checked, or (None, reason)."""
        names = self.joint_names
        q, problem = joint_values(cmd, what=kind, names=names, lower=None if relative else self.kin.lower_np,
                                  upper=None if relative else self.kin.upper_np)
        if problem is None and relative:
            q = self.setpoint[env].cpu().numpy() + q
            problem = limit_refusal(q, names, self.kin.lower_np, self.kin.upper_np, what=kind)
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
            self._stop_motion(env, events)
        if transition.desired:
            events.append(Event(env, "desired_state", transition.desired))
        if transition.start_homing:
            home = None if self.home_q is None or np.isnan(self.home_q[env]).any() else self.home_q[env]
            goal = home.copy() if home is not None else self.setpoint[env].cpu().numpy()
            goal = np.clip(goal, self.kin.lower_np, self.kin.upper_np)  # a joint the tool lacks (limits 0, 0) at 0
            s.homing = True
            self._start_arm_trajectory(env, goal, "home", events)
        if transition.status:
            events.append(Event(env, "status", f"{self.label(env)}: {transition.status}"))
        self._update_busy(env, events, force=transition.publish)
        return events

    # ------------------------------------------------------------------ motion commands
    def servo_jp(self, env: int, cmd, *, relative: bool = False) -> list[Event]:
        kind = "servo_jr" if relative else "servo_jp"
        problem = self.states[env].motion_refusal(kind)
        q, problem = (None, problem) if problem else self._joints(env, kind, cmd, relative=relative)
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_motion(env, events, jaw=False)
        self.setpoint[env] = torch.as_tensor(q, dtype=self.setpoint.dtype)
        self._update_busy(env, events)
        return events

    def move_jp(self, env: int, cmd, *, relative: bool = False) -> list[Event]:
        kind = "move_jr" if relative else "move_jp"
        problem = self.states[env].motion_refusal(kind)
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
        """A Pose in the measured_cp frame, checked, as a 4x4 in the base (RCM) frame (or the refusal)."""
        problem = self.states[env].motion_refusal(kind)
        T, problem = (None, problem) if problem else pose_matrix(pose, what=kind)
        return (None, problem) if problem else (np.linalg.solve(self.base_frame_np[env], T), None)

    unreachable = "(RCM frame) is not reachable within the joint limits"  # what a refusal says of a pose

    def _unreachable(self, kind, T) -> str:
        p = np.asarray(T)[:3, 3]
        return f"{kind} refused: pose at ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) m {self.unreachable}"

    def servo_cp(self, env: int, pose) -> list[Event]:
        T, problem = self._local_pose(env, "servo_cp", pose)
        if problem:
            return self._refusal(env, problem)
        events = []  # the IK of every env with a pending servo_cp runs batched in the tick
        self._stop_motion(env, events, jaw=False)
        self.cp_pending[env] = T
        self._update_busy(env, events)
        return events

    def move_cp(self, env: int, pose) -> list[Event]:
        T, problem = self._local_pose(env, "move_cp", pose)
        if problem:
            return self._refusal(env, problem)
        q, ok = self.kin.inverse(torch.as_tensor(T[None]), self.setpoint[env: env + 1])
        if not bool(ok[0]):
            return self._refusal(env, self._unreachable("move_cp", T))
        return self._start_move(env, q[0].cpu().numpy())

    def servo_cv(self, env: int, twist) -> list[Event]:
        """A tool-tip twist (linear m/s, angular rad/s, in the measured_cp frame) that each tick
        turns into joint rates (the Jacobian's least-squares inverse), held until the next
        command (a zero twist, hold, another servo or move); the joints stop at their limits."""
        problem = self.states[env].motion_refusal("servo_cv")
        values = np.array([twist.linear.x, twist.linear.y, twist.linear.z,
                           twist.angular.x, twist.angular.y, twist.angular.z], dtype=np.float64)
        if problem is None and not np.isfinite(values).all():
            problem = "servo_cv refused: the twist is not finite"
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_motion(env, events, jaw=False)
        R = self.base_frame_np[env][:3, :3]  # into the RCM frame
        self.cv[env] = torch.as_tensor(np.concatenate([R.T @ values[:3], R.T @ values[3:]]), dtype=self.cv.dtype)
        self.cv_on[env] = bool(np.any(values != 0.0))
        self._update_busy(env, events)
        return events

    def _jaw(self, env, kind, cmd):
        """(clipped jaw value, None) or (None, reason). The dVRK clips jaw commands to the
        jaw's limits (a gripper closed on something is commanded past closed)."""
        if not self.has_jaw:
            return None, f"{kind} refused: {self.jaw_absent}"
        problem = self.states[env].motion_refusal(kind)
        if problem:
            return None, problem
        q, problem = joint_values(cmd, what=kind, names=("jaw",), lower=None, upper=None)
        if problem:
            return None, problem
        return float(np.clip(q[0], self.jaw_lower, self.jaw_upper)), None

    @property
    def jaw_absent(self) -> str:
        return f"the {self.arm} has no jaw"

    def jaw_servo_jp(self, env: int, cmd) -> list[Event]:
        value, problem = self._jaw(env, "jaw/servo_jp", cmd)
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_jaw(env, events)
        self.jaw_sp[env] = value
        self._update_busy(env, events)
        return events

    def jaw_move_jp(self, env: int, cmd) -> list[Event]:
        value, problem = self._jaw(env, "jaw/move_jp", cmd)
        if problem:
            return self._refusal(env, problem)
        events = []
        self._stop_jaw(env, events)
        self.jaw_traj.start(env, self.jaw_sp[env].cpu().numpy(), np.array([value]),
                            self.jaw_v_limit * self.ratio_v[env], self.jaw_a_limit * self.ratio_a[env],
                            self.sim_ns * 1e-9)
        self.jaw_moving[env] = True
        self._update_busy(env, events, force=True)
        return events

    def _stop_jaw(self, env, events):
        if self.jaw_moving[env]:
            self.jaw_traj.stop(env)
            self.jaw_moving[env] = False
            events.append(Event(env, "goal_reached", False))

    def hold(self, env: int) -> list[Event]:
        events = []
        self._stop_motion(env, events)
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
        """(7-vector pose of the tip for the joint values, None) or (None, reason)."""
        q, problem = joint_values(cmd, what="forward_kinematics", names=self.joint_names,
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
                                         names=self.joint_names, lower=None, upper=None)
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
        """One control period of every row: the setpoints (servo_cp's batched IK, servo_cv, the
        running trajectories), `_measure` (what measured becomes), then the events of motions
        that ended and `_after_tick`'s. Publish the tick's data before its events, so that a
        client that sees is_busy=false then reads measured/setpoint at the goal."""
        dt = self.period_ns * 1e-9
        self.sim_ns += self.period_ns
        self.ticks += 1
        now = self.sim_ns * 1e-9
        events = self._solve_servo_cp() if self.cp_pending else []
        self._integrate_servo_cv(dt)
        q, qd, moving, finished = self.arm_traj.evaluate(now)
        jq, jqd, jmoving, jfinished = self.jaw_traj.evaluate(now)
        self.setpoint = torch.where(moving[:, None], q, self.setpoint)
        self.jaw_sp = torch.where(jmoving[:, None], jq, self.jaw_sp)
        self._before_velocities()
        self.setpoint_v = torch.where(moving[:, None], qd, (self.setpoint - self._last_sp) / dt)
        self.jaw_sp_v = torch.where(jmoving[:, None], jqd, (self.jaw_sp - self._last_jaw_sp) / dt)
        self._last_sp, self._last_jaw_sp = self.setpoint.clone(), self.jaw_sp.clone()
        self._measure(dt)
        events += self._finish_motions(finished, jfinished)
        return events + self._after_tick()

    def _before_velocities(self):
        """Where a subclass lets in-process drivers write setpoints (TwinArms' step hooks)."""

    def _measure(self, dt: float):
        """Measured follows setpoint through a first-order lag (exact for a lag of 0)."""
        tau = self.measured_lag
        alpha = 1.0 if tau <= 0 else 1.0 - math.exp(-dt / tau)
        new_meas = self.measured + alpha * (self.setpoint - self.measured)
        new_jaw = self.jaw_meas + alpha * (self.jaw_sp - self.jaw_meas)
        self.measured_v, self.jaw_meas_v = (new_meas - self.measured) / dt, (new_jaw - self.jaw_meas) / dt
        self.measured, self.jaw_meas = new_meas, new_jaw

    def _after_tick(self) -> list[Event]:
        return []

    def _integrate_servo_cv(self, dt: float):
        envs = np.flatnonzero(self.cv_on)
        if envs.size == 0:
            return
        idx = torch.as_tensor(envs, device=self.device)
        J, _ = self.kin.jacobian(self.setpoint[idx])
        qd = torch.linalg.lstsq(J, self.cv[idx][:, :, None]).solution[:, :, 0]
        q = torch.minimum(torch.maximum(self.setpoint[idx] + qd * dt, self.kin.lower), self.kin.upper)
        self.setpoint[idx] = q

    def _solve_servo_cp(self) -> list[Event]:
        envs = list(self.cp_pending)
        T = torch.as_tensor(np.stack([self.cp_pending[e] for e in envs]), device=self.device)
        self.cp_pending.clear()
        idx = torch.as_tensor(envs, device=self.device)
        q, ok = self.kin.inverse(T, self.setpoint[idx])
        self.setpoint[idx] = torch.where(ok[:, None], q, self.setpoint[idx])
        return [Event(envs[k], "error", self._unreachable("servo_cp", T[k].cpu().numpy()))
                for k in torch.nonzero(~ok).flatten().tolist()]

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

    # ------------------------------------------------------------------ resets
    def _reset_rows(self, envs: torch.Tensor, q: torch.Tensor, jaw: torch.Tensor):
        """Rows `envs` at rest at q and jaw; their motions stop."""
        for env in envs.tolist():
            self._stop_motion(env, [])
        for name in ("setpoint", "measured", "_last_sp"):
            getattr(self, name)[envs] = q
        for name in ("jaw_sp", "jaw_meas", "_last_jaw_sp"):
            getattr(self, name)[envs] = jaw
        for name in ("setpoint_v", "measured_v", "jaw_sp_v", "jaw_meas_v"):
            getattr(self, name)[envs] = 0.0

    def restart(self, *, clock: bool = True):
        """Every row as at start: at rest at the initial joints and jaw, then `_restart_state`;
        with `clock`, the simulated time back at 0."""
        N, kw = self.num_envs, dict(device=self.device, dtype=torch.float64)
        self._reset_rows(torch.arange(N), self._initial_q, torch.full((N, 1), self._initial_jaw, **kw))
        self._restart_state(clock=clock)

    def _restart_state(self, *, clock: bool):
        """DISABLED and not homed, base frames and ratios as at start, pending commands dropped."""
        N, kw = self.num_envs, dict(device=self.device, dtype=torch.float64)
        self.states = [ArmState() for _ in range(N)]
        self.base_frame[:] = torch.eye(4, **kw)
        self.base_frame_np[:] = np.eye(4)
        self.cp_pending.clear()
        self.cv.zero_()
        self.cv_on[:] = False
        self.ratio_v[:], self.ratio_a[:] = 1.0, 1.0
        if clock:
            self.sim_ns, self.ticks = 0, 0

__all__ = ["ArmModel"]
