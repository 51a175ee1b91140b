"""Batched kinematics the twin publishes: tool-tip FK, geometric Jacobian, IK, pose conversions.

FK and the Jacobian are the URDF chain's (cressim.robots.chain) over the 6-joint interface; the
twin computes both every tick for a few arms, which the compiled chain does in about 0.1-0.2 ms.
IK is cressim.robots.PSM's closed form (limits and a reachable flag).

The twin always speaks the 6-joint dVRK interface; a 4-dof (wrist-less) tool has its wrist
joints fixed at 0 (their limits are [0, 0]).
"""
from __future__ import annotations

import numpy as np
import torch

from .chain import Chain, rotation_xyzw
from .dvrk import PSM_JOINTS
from .psm import BASE_LINK, PSM, SHAFT_LINK, TIP_LINK

INTERFACE_DOF = len(PSM_JOINTS)


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
        # the 6 interface columns; a wrist-less tool's URDF has no wrist joints to read theirs
        self.chain = Chain(psm.urdf, sources=PSM_JOINTS, base=BASE_LINK, tip=TIP_LINK, links=(SHAFT_LINK, TIP_LINK))
        self.present = torch.arange(INTERFACE_DOF, device=self.device) < self.dof  # joints this tool has

    def forward(self, q: torch.Tensor) -> torch.Tensor:
        """(M, 6) -> (M, 4, 4): tool tip in the RCM frame (PSM1_base)."""
        return self.chain.forward(q)

    def jacobian(self, q: torch.Tensor):
        """(M, 6) -> (J (M, 6, 6), T (M, 4, 4)): spatial Jacobian [v; w] of the tip in PSM1_base.
        Joints the tool lacks get 0."""
        return self.chain.jacobian(q)

    def instrument(self, q: torch.Tensor) -> torch.Tensor:
        """(M, 6) -> (M, 2, 3): where the instrument's shaft starts (the tool base, DH frame 3's
        origin) and ends (the tip: the jaw pivot, or a straight tool's end) in PSM1_base."""
        return self.chain.link_poses(q)[..., :3, 3]

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


__all__ = ["INTERFACE_DOF", "ArmKinematics", "body_jacobian", "matrix_to_pose7", "pose7_to_matrix", "rotation_xyzw"]
