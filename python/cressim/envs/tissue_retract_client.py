"""TissueRetract's CRTK observation and action on the client's side (no engine, no ROS): what a
dVRK client computes from `measured_cp` and its own commands so that a policy trained with
`TissueRetract(observation="crtk")` runs against the twin or a real PSM unchanged
(ros_ws/src/cressim_ros/examples/sim_to_real.py wires it to the dVRK's Python client).

Per control step (the task's frame, 1/60 s): `observation(measured_cp)` -> the 29 values the
task's HLSL `observe` writes; `act(action)` -> (joint targets for servo_jp, jaw angle for
jaw/servo_jp), stepping the targets exactly as the task's `apply_action` does. Positions are in
the world of the twin's scene (measured_cp is in the arm's base frame; the scene file gives the
base pose).
"""
from __future__ import annotations

import numpy as np
import torch

from cressim.robots import JAW_GRASP_POINT, JAW_LINK, PSM, TIP_LINK, pose7_to_matrix
from cressim.twin_scene_file import load_scene

from .tissue_retract import ACTION_SCALE, FRAME, JAW_CLOSED, JAW_OPEN, SCENE


class TissueRetractClient:
    def __init__(self, target, *, scene: str = SCENE, start_q=None, target_lift: float = 0.02):
        """`target`: the point to grasp (world, m: the flap edge particle's rest position, as a
        camera would register it); `start_q`: the joints the arm is at (default the scene's home)."""
        twin = load_scene(scene)
        self.base = pose7_to_matrix(np.array([*twin.base_position, *twin.base_rotation]))
        self.psm = PSM(f"{twin.robot}.urdf", dtype=torch.float64)
        self.lower, self.upper = self.psm.lower.numpy().astype(np.float64), self.psm.upper.numpy().astype(np.float64)
        self.jaw_in_tip = self._jaw_in_tip()
        self.target = np.asarray(target, np.float64)
        self.target_lift = float(target_lift)
        self.q = np.asarray(start_q if start_q is not None else twin.home_jp, np.float64)[:6].copy()
        self.dq = np.zeros(6)
        self.closed = False
        self.closed_z = 0.0
        self._tip = None

    def _jaw_in_tip(self) -> np.ndarray:
        """JAW_LINK in TIP_LINK's frame (both ride on the wrist yaw link: a constant)."""
        q = np.zeros(self.psm.dof)
        tip, jaw = (self.psm.link_pose(name, q).double().numpy() for name in (TIP_LINK, JAW_LINK))
        return np.linalg.solve(tip, jaw)

    def observation(self, measured_cp) -> np.ndarray:
        """(29,) float32 from measured_cp (4x4, the tool tip in the arm's base frame)."""
        jaw = self.base @ np.asarray(measured_cp, np.float64) @ self.jaw_in_tip
        tip = jaw[:3, :3] @ np.asarray(JAW_GRASP_POINT) + jaw[:3, 3]
        self._tip = tip
        lifted = float(np.clip((tip[2] - self.closed_z) / self.target_lift, 0.0, 1.0)) if self.closed else 0.0
        return np.concatenate([self.q, self.dq, self.target, tip, jaw[:3, 0], jaw[:3, 1], self.target - tip,
                               [float(self.closed), lifted]]).astype(np.float32)

    def act(self, action) -> tuple[np.ndarray, float]:
        """The policy's action (7) -> (joint targets (6) for servo_jp, jaw angle (rad))."""
        a = np.clip(np.nan_to_num(np.asarray(action, np.float64), nan=0.0), -1.0, 1.0)
        target = np.clip(self.q + a[:6] * np.asarray(ACTION_SCALE), self.lower, self.upper)
        self.dq, self.q = (target - self.q) / FRAME, target
        closed = a[6] > 0 or (a[6] == 0 and self.closed)
        if closed and not self.closed and self._tip is not None:
            self.closed_z = float(self._tip[2])  # the lift counts from where the jaws closed
        self.closed = bool(closed)
        return self.q.copy(), JAW_CLOSED if self.closed else JAW_OPEN
