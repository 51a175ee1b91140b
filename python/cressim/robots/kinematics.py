"""Batched kinematics the twin publishes: tool-tip FK, geometric Jacobian, IK, pose conversions.

FK and the Jacobian come from the DH frames (cressim.robots.dh), which tests/robots check
against the URDF to 1e-7 m: computing the Jacobian from the frames' z axes takes 0.3 ms for
a batch where pytorch-kinematics' jacobian_tensor takes 17 ms on this CPU, and the twin does
it every tick. IK is cressim.robots.PSM's closed form (limits and a reachable flag).

The twin always speaks the 6-joint dVRK interface; a 4-dof (wrist-less) tool has its wrist
joints fixed at 0 (their limits are [0, 0]).
"""
from __future__ import annotations

import numpy as np
import torch

from pytorch_kinematics.transforms import matrix_to_quaternion

from .dh import PSM_DH, PSM_JOINT_NAMES, TOOL_TIP_OFFSET, dh_forward_kinematics
from .psm import PSM

INTERFACE_DOF = len(PSM_JOINT_NAMES)


class ArmKinematics:
    def __init__(self, psm: PSM, device, dtype=torch.float64):
        self.psm, self.dof, self.device, self.dtype = psm, psm.dof, torch.device(device), dtype
        kw = dict(device=self.device, dtype=dtype)
        lower = torch.zeros(INTERFACE_DOF, **kw)
        upper = torch.zeros(INTERFACE_DOF, **kw)
        lower[: self.dof], upper[: self.dof] = psm.lower.to(**kw), psm.upper.to(**kw)
        self.lower, self.upper = lower, upper
        self.lower_np, self.upper_np = lower.cpu().numpy(), upper.cpu().numpy()
        self.jaw_limits = psm.jaw_limits  # None for a tool without jaws
        self.tip = torch.as_tensor(TOOL_TIP_OFFSET, **kw)
        self.prismatic = torch.tensor([row.type == "prismatic" for row in PSM_DH], device=self.device)
        self.present = torch.arange(INTERFACE_DOF, device=self.device) < self.dof  # joints this tool has

    def forward(self, q: torch.Tensor) -> torch.Tensor:
        """(M, 6) -> (M, 4, 4): tool tip in the RCM frame (PSM1_base)."""
        return dh_forward_kinematics(q * self.present, tool_tip=None) @ self.tip

    def jacobian(self, q: torch.Tensor):
        """(M, 6) -> (J (M, 6, 6), T (M, 4, 4)): spatial Jacobian [v; w] of the tip in PSM1_base.

        Modified DH: joint i turns about (or slides along) z of frame i. Absent joints get 0.
        """
        frames = dh_forward_kinematics(q * self.present, all_frames=True)  # (M, 6, 4, 4)
        z = frames[..., :3, 2]  # (M, 6, 3)
        origins = frames[..., :3, 3]
        tip = frames[:, -1] @ self.tip
        lever = tip[:, None, :3, 3] - origins
        revolute_v = torch.linalg.cross(z, lever, dim=-1)
        v = torch.where(self.prismatic[None, :, None], z, revolute_v)
        w = torch.where(self.prismatic[None, :, None], torch.zeros_like(z), z)
        J = torch.cat([v, w], dim=-1).transpose(1, 2) * self.present  # (M, 6, 6)
        return J, tip

    def inverse(self, T: torch.Tensor, seed: torch.Tensor):
        """(M, 4, 4), seed (M, 6) -> (q (M, 6), reachable (M,) bool)."""
        ik = self.psm.inverse_kinematics(T.to(self.psm.device), seed=seed[:, : self.dof].to(self.psm.device))
        q = torch.zeros(T.shape[0], INTERFACE_DOF, device=self.device, dtype=self.dtype)
        q[:, : self.dof] = ik.q.to(device=self.device, dtype=self.dtype)
        return q, ik.reachable.to(self.device)


def body_jacobian(J: torch.Tensor, T: torch.Tensor) -> torch.Tensor:
    """Spatial (base-frame) Jacobian -> the same twist expressed in the tip frame."""
    Rt = T[:, :3, :3].transpose(1, 2)
    return torch.cat([Rt @ J[:, :3], Rt @ J[:, 3:]], dim=1)


def matrix_to_pose7(T: torch.Tensor) -> torch.Tensor:
    """(M, 4, 4) -> (M, 7): x, y, z, qx, qy, qz, qw (qw >= 0), batched."""
    R = T[:, :3, :3]
    # Shepperd's method, every branch computed and the best conditioned one picked per row
    tr = R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2]
    cands = torch.stack([
        torch.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1], 1 + tr], -1),
        torch.stack([1 + 2 * R[:, 0, 0] - tr, R[:, 0, 1] + R[:, 1, 0], R[:, 0, 2] + R[:, 2, 0],
                     R[:, 2, 1] - R[:, 1, 2]], -1),
        torch.stack([R[:, 0, 1] + R[:, 1, 0], 1 + 2 * R[:, 1, 1] - tr, R[:, 1, 2] + R[:, 2, 1],
                     R[:, 0, 2] - R[:, 2, 0]], -1),
        torch.stack([R[:, 0, 2] + R[:, 2, 0], R[:, 1, 2] + R[:, 2, 1], 1 + 2 * R[:, 2, 2] - tr,
                     R[:, 1, 0] - R[:, 0, 1]], -1),
    ], 1)  # (M, 4, 4): candidate k has its large component at index (3, 0, 1, 2)[k]
    pick = torch.stack([tr, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], -1).argmax(-1)
    quat = cands[torch.arange(R.shape[0], device=R.device), pick]
    quat = quat / quat.norm(dim=-1, keepdim=True)
    quat = torch.where(quat[:, 3:4] < 0, -quat, quat)
    return torch.cat([T[:, :3, 3], quat], dim=-1)


def pose7_to_matrix(p: np.ndarray) -> np.ndarray:
    x, y, z, w = p[3:]
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = p[:3]
    return T


def rotation_xyzw(R) -> tuple:
    """x, y, z, w of a 3x3 rotation matrix (the engine's quaternion order)."""
    q = matrix_to_quaternion(torch.as_tensor(np.asarray(R), dtype=torch.float64))  # w, x, y, z
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


__all__ = ["INTERFACE_DOF", "ArmKinematics", "body_jacobian", "matrix_to_pose7", "pose7_to_matrix", "rotation_xyzw"]
