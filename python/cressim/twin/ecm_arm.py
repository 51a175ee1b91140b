"""The patient cart's ECM in the dVRK's terms, without ROS: its joints, state and commands.

    ecm = EcmArm(initial_jp, home_jp, publish_rate=100.0)
    events = ecm.state_command("enable")      # the dVRK's state machine (cressim.twin.arm_state)
    events = ecm.move_jp(JointCommand(position=[0.1, 0.2, 0.08, 0.0]))
    events = ecm.tick(dt)                      # trajectories; measured follows setpoint (lag)

Events are (topic, value) pairs as TwinArms' (`operating_state` a StateReport, `goal_reached`,
`desired_state`, `status`, `error`). The ECM is kinematic: the cart poses its links and the
stereo cameras on its tip from `measured` (cressim.twin.cart). Cartesian commands (move_cp,
servo_cp, a pose of the tip in measured_cp's frame) go through the ECM's closed-form IK
(cressim.robots.ecm): a pose its 4 joints cannot reach (its z off the line through the RCM, or
beyond the limits) is refused with that reason.
"""
from __future__ import annotations

import math

import numpy as np

from cressim.robots.ecm import (ECM_JOINT_NAMES, ECM_LOWER, ECM_UPPER, ECM_VELOCITY, ecm_forward_kinematics,
                                ecm_inverse_kinematics)

from .arm_state import ArmState
from .arms import StateReport  # the one StateReport the node turns into messages
from .command_checks import joint_values, pose_matrix
from .trajectory import BatchedTrajectory

ACCELERATION_RATIO = 4.0  # acceleration limit = ratio x velocity limit, per second (as the PSM's default)


class EcmArm:
    def __init__(self, initial_jp, home_jp, *, measured_lag: float = 0.005, name: str = "ECM"):
        self.name, self.measured_lag = name, measured_lag
        self.home_jp = np.asarray(home_jp, dtype=np.float64)
        self.initial = np.asarray(initial_jp, dtype=np.float64)
        for what, q in (("initial_jp", self.initial), ("home_jp", self.home_jp)):
            if np.any(q < ECM_LOWER) or np.any(q > ECM_UPPER):
                raise ValueError(f"cart.{name}.{what} {q.tolist()} is outside the ECM's joint limits "
                                 f"{ECM_LOWER.tolist()} .. {ECM_UPPER.tolist()}")
        self.restart()

    def restart(self):
        self.setpoint, self.measured = self.initial.copy(), self.initial.copy()
        self.setpoint_v, self.measured_v = np.zeros(4), np.zeros(4)
        self.state = ArmState()
        self.traj = BatchedTrajectory(1, 4)
        self.motion = None  # None, "move" or "home"
        self.base_frame = np.eye(4)  # set_base_frame: measured_cp = base_frame @ local
        self.time = 0.0

    def report(self):
        s = self.state
        return StateReport(s.state, s.is_homed, s.is_busy)

    def _stop(self, events, reached=False):
        if self.motion is not None:
            self.traj.stop(0)
            if self.motion == "move":
                events.append(("goal_reached", bool(reached)))
            else:
                self.state.homing = False
            self.motion = None

    def _start(self, goal, kind, events):
        self._stop(events)
        self.traj.start(0, self.setpoint, goal, ECM_VELOCITY, ECM_VELOCITY * ACCELERATION_RATIO, self.time)
        self.motion = kind

    def _busy(self, events, force=False):
        before = self.state.is_busy
        self.state.busy = self.motion == "move"
        if force or before != self.state.is_busy:
            events.append(("operating_state", self.report()))

    def state_command(self, command: str):
        s, events = self.state, []
        command = command.strip()
        if command == "home" and s.state == "ENABLED" and s.is_homed and not s.is_busy:
            return [("desired_state", "HOMED"), ("operating_state", self.report())]
        t = s.command(command)
        if t.error:
            return [("error", t.error)]
        if t.stop_motion:
            self._stop(events)
        if t.desired:
            events.append(("desired_state", t.desired))
        if t.start_homing:
            s.homing = True
            self._start(self.home_jp, "home", events)
        if t.status:
            events.append(("status", f"{self.name}: {t.status}"))
        self._busy(events, force=t.publish)
        return events

    def _joints(self, kind, cmd):
        problem = self.state.motion_refusal(kind)
        if problem:
            return None, problem
        return joint_values(cmd, what=kind, names=ECM_JOINT_NAMES, lower=ECM_LOWER, upper=ECM_UPPER)

    def servo_jp(self, cmd):
        q, problem = self._joints("servo_jp", cmd)
        if problem:
            return [("error", problem)]
        events = []
        self._stop(events)
        self.setpoint = q
        self._busy(events)
        return events

    def move_jp(self, cmd):
        q, problem = self._joints("move_jp", cmd)
        if problem:
            return [("error", problem)]
        events = []
        self._start(q, "move", events)
        self._busy(events, force=True)
        return events

    def hold(self):
        events = []
        self._stop(events)
        self._busy(events)
        return events

    def _cartesian(self, kind, pose):
        """(joint values, None) for a tip pose in measured_cp's frame, or (None, reason)."""
        problem = self.state.motion_refusal(kind)
        T, problem = (None, problem) if problem else pose_matrix(pose, what=kind)
        if problem:
            return None, problem
        local = np.linalg.solve(self.base_frame, T)
        q, ok = ecm_inverse_kinematics(local)
        if not ok:
            p = local[:3, 3]
            return None, (f"{kind} refused: pose at ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) m (ECM_base) is not "
                          "reachable: its z must point along the line from the RCM, within the joint limits")
        return q, None

    def servo_cp(self, pose):
        q, problem = self._cartesian("servo_cp", pose)
        if problem:
            return [("error", problem)]
        events = []
        self._stop(events)
        self.setpoint = q
        self._busy(events)
        return events

    def move_cp(self, pose):
        q, problem = self._cartesian("move_cp", pose)
        if problem:
            return [("error", problem)]
        events = []
        self._start(q, "move", events)
        self._busy(events, force=True)
        return events

    def set_base_frame(self, pose):
        T, problem = pose_matrix(pose, what="set_base_frame")
        if problem:
            return [("error", problem)]
        self.base_frame = T
        return [("status", f"{self.name}: base frame set")]

    def tick(self, dt: float):
        """One control period: the running trajectory, measured a first-order lag of setpoint."""
        self.time += dt
        events = []
        q, qd, moving, finished = self.traj.evaluate(self.time)
        last = self.setpoint.copy()
        if bool(moving[0]):
            self.setpoint = q[0].numpy().copy()
        self.setpoint_v = qd[0].numpy().copy() if bool(moving[0]) else (self.setpoint - last) / dt
        tau = self.measured_lag
        alpha = 1.0 if tau <= 0 else 1.0 - math.exp(-dt / tau)
        new = self.measured + alpha * (self.setpoint - self.measured)
        self.measured_v, self.measured = (new - self.measured) / dt, new
        if bool(finished[0]):
            kind, self.motion = self.motion, None
            if kind == "home":
                self.state.homing_done()
                events.append(("status", f"{self.name}: homed"))
                self._busy(events, force=True)
            else:
                events.append(("goal_reached", True))
                self._busy(events)
        return events

    def local_cp(self, which: str = "measured") -> np.ndarray:
        """(4, 4): the endoscope's tip (DH frame 4) in ECM_base (the RCM)."""
        return ecm_forward_kinematics(getattr(self, which))

    def cp(self, which: str = "measured") -> np.ndarray:
        return self.base_frame @ self.local_cp(which)


__all__ = ["EcmArm"]
