"""The surgeon's console without ROS: simulated MTMs (MTML, MTMR) and the operator who holds them.

    mtm = MtmArm("MTMR")
    mtm.state_command("enable"); mtm.state_command("home")   # the dVRK's state machine
    operator = Operator(["MTML", "MTMR"])
    operator.hands["MTMR"] = np.array([0.01, 0.0, 0.0])       # where the hand holds the grip (m)
    operator.grips["MTMR"] = 0.5                                # gripper angle (rad)
    operator.clutch = True                                      # the pedals and the head sensor
    mtm.tick(dt, operator)                                      # the MTM follows the hand

An MTM here is its 7-joint arm (the dVRK's DH tables, cressim.robots.mtm) and its gripper. The
operator's hand sets the grip's position and the gripper angle; the arm's wrist motors set the
grip's orientation (`move_cp` / `servo_cp`: a teleoperation client aligns the MTM to its PSM that
way), held by `lock_orientation`; with no hand on it, they set the position too. Each change of
that goal pose is solved for the joints (numerical IK from the last joints, within the limits),
and what is published follows from the joints: `measured_js` / `setpoint_js` (7 joints; the
twin's MTM has no lag), `local/measured_cp` (the grip in the DH base, the FK of measured_js) and
`measured_cp` / `setpoint_cp` (the grip in `MTMx_base`, `base @ local` within the IK's 1e-10 m
and 1e-9 rad: the goal itself where it was reached; the frame the dVRK's
console aligns with the display, here put so that the grip at the dVRK's home joints (zero) is
at its origin with its axes, so a teleoperation client's motions are the operator's in the
camera's view); `gripper/measured_js`. A goal out of reach leaves the grip where the IK got.
`body/servo_cf` (the clients send a zero wrench: let the hand move it) and
`use_gravity_compensation` are kept. Who drives the operator: a script from the scene file
(`ScriptedOperator`) or an input device over ROS (cressim_ros.console_topics).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from cressim.robots.mtm import MTM_HOME, mtm_forward_kinematics, mtm_inverse_kinematics
# the scene file's operator script is read below the twin (tasks share that file)
from cressim.twin_scene_file import GRIPPER_LIMITS, Keyframe

from .arm_state import ArmState
from .command_checks import pose_matrix
from .messages import StateReport

HOME = np.eye(4)  # the grip at home: at the base frame's origin, axes aligned with it


class MtmArm:
    def __init__(self, name: str):
        self.name = name
        self.base = np.linalg.inv(mtm_forward_kinematics(name, MTM_HOME))  # MTMx_base in the DH base: HOME at home
        self.restart()

    def restart(self):
        self._set_joints(MTM_HOME)
        self.q_v = np.zeros(7)
        self.goal = self.pose.copy()  # where the hand and the wrist want the grip (the IK's target)
        self.gripper = 0.0
        self.gripper_v = 0.0
        self.state = ArmState()
        self.locked = None  # a 3x3 rotation held by lock_orientation
        self.wrench_free = True  # body/servo_cf last given (zero: the hand moves it)
        self.gravity_compensation = True
        self.commanded_position = None  # where move_cp / servo_cp put the grip (used while no hand holds it)

    def report(self):
        s = self.state
        return StateReport(s.state, s.is_homed, s.is_busy)

    def state_command(self, command: str):
        """enable, disable, home (the grip to its home pose at once), unhome, pause, resume."""
        t = self.state.command(command.strip())
        if t.error:
            return [("error", t.error)]
        events = [("desired_state", t.desired)] if t.desired else []
        if t.start_homing:
            self._set_joints(MTM_HOME)
            self.goal = self.pose.copy()
            self.state.homing_done()
        if t.status:
            events.append(("status", f"{self.name}: {t.status}"))
        events.append(("operating_state", self.report()))
        return events

    def move_cp(self, pose, *, kind: str = "move_cp"):
        """The wrist turns the grip to the pose's orientation (and the arm moves it there when no
        hand holds it; a held orientation stays)."""
        problem = self.state.motion_refusal(kind)
        T, problem = (None, problem) if problem else pose_matrix(pose, what=kind)
        if problem:
            return [("error", problem)]
        if self.locked is None:
            self.goal[:3, :3] = T[:3, :3]
            self._solve()
        self.commanded_position = T[:3, 3].copy()
        events = [("goal_reached", True)] if kind == "move_cp" else []
        return events

    def lock_orientation(self, quaternion_xyzw):
        q = np.asarray(quaternion_xyzw, dtype=np.float64)
        n = float(np.linalg.norm(q)) if np.isfinite(q).all() else 0.0
        if abs(n - 1.0) > 1e-3:
            return [("error", f"lock_orientation refused: quaternion of norm {n:.6g}, 1 expected")]
        x, y, z, w = q / n
        self.locked = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        self.goal[:3, :3] = self.locked
        self._solve()
        return []

    def unlock_orientation(self):
        self.locked = None
        return []

    def servo_cf(self, wrench):
        values = np.asarray(wrench, dtype=np.float64)
        if values.shape != (6,) or not np.isfinite(values).all():
            return [("error", "body/servo_cf refused: 6 finite values expected")]
        self.wrench_free = not np.any(values != 0.0)
        return [] if self.wrench_free else [("warning", "body/servo_cf: the twin's MTM applies no force "
                                                         "(a zero wrench lets the hand move it)")]

    def tick(self, dt: float, operator: "Operator"):
        """The grip where the operator's hand holds it; with no hand, where move_cp put it."""
        hand = operator.hands.get(self.name)
        if hand is not None:
            self.goal[:3, 3] = hand
        elif self.commanded_position is not None:
            self.goal[:3, 3] = self.commanded_position
        before = self.q
        self._solve()
        self.q_v = (self.q - before) / dt
        grip = float(np.clip(operator.grips.get(self.name, self.gripper), *GRIPPER_LIMITS))
        self.gripper_v, self.gripper = (grip - self.gripper) / dt, grip


    def _set_joints(self, q, pose=None):
        """The arm at joints q: the grip at their FK, or at `pose` (MTMx_base) where the IK reached it
        (within 1e-10 m and 1e-9 rad of the FK: the commanded orientation itself, as a client that
        aligns to it compares them exactly)."""
        self.q = np.asarray(q, dtype=np.float64).copy()
        self.local = mtm_forward_kinematics(self.name, self.q)  # the grip in the DH base (local/measured_cp)
        self.pose = self.base @ self.local if pose is None else pose.copy()  # measured_cp; measured = setpoint
        self._solved = None

    def _solve(self):
        """The joints that put the grip at the goal (from the last joints); unchanged goals are not
        solved again (one out of reach would cost the IK's every iteration each tick)."""
        if self._solved is not None and np.array_equal(self._solved, self.goal):
            return
        if not np.allclose(self.goal, self.pose, rtol=0.0, atol=1e-12):
            q, reached = mtm_inverse_kinematics(self.name, np.linalg.solve(self.base, self.goal), self.q)
            self._set_joints(q, self.goal if reached else None)
        self._solved = self.goal.copy()


@dataclass
class Operator:
    """The surgeon at the console: each hand's grip position (None: not holding it) and angle, the
    clutch and camera pedals, the head sensor (operator present)."""
    names: list
    hands: dict = field(default_factory=dict)  # MTM name -> (3,) position in its base frame, m
    grips: dict = field(default_factory=dict)  # MTM name -> gripper angle, rad
    clutch: bool = False
    camera: bool = False
    present: bool = False

    def pedals(self) -> dict:
        """The console's buttons as the dVRK publishes them (topic tail -> pressed)."""
        return {"clutch": self.clutch, "camera": self.camera, "operator_present": self.present}


class ScriptedOperator:
    """An operator who follows keyframes (scene file `operator:`; times in simulated seconds from
    the twin's start): hand positions and grips interpolated linearly, pedals switched at their
    keyframe. After the last keyframe the operator holds still."""

    def __init__(self, keyframes: list[Keyframe]):
        self.keyframes = sorted(keyframes, key=lambda k: k.at)

    def apply(self, t: float, operator: Operator):
        frames = self.keyframes
        if not frames:
            return
        for k in frames:  # the pedals of the latest keyframe reached
            if k.at <= t:
                for name, value in k.pedals.items():
                    setattr(operator, name, value)
        for channel, out in (("hands", operator.hands), ("grips", operator.grips)):
            names = {n for k in frames for n in getattr(k, channel)}
            for name in names:
                keyed = [(k.at, np.asarray(getattr(k, channel)[name], dtype=np.float64)) for k in frames
                         if name in getattr(k, channel)]
                times = [a for a, _ in keyed]
                if t <= times[0]:
                    value = keyed[0][1] if t >= times[0] else None
                elif t >= times[-1]:
                    value = keyed[-1][1]
                else:
                    i = int(np.searchsorted(times, t)) - 1
                    (a0, v0), (a1, v1) = keyed[i], keyed[i + 1]
                    value = v0 + (v1 - v0) * (t - a0) / (a1 - a0)
                if value is not None:
                    out[name] = value if channel == "hands" else float(value)


__all__ = ["GRIPPER_LIMITS", "Keyframe", "MtmArm", "Operator", "ScriptedOperator"]
