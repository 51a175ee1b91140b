"""The dVRK endoscope camera manipulator (ECM): modified-DH table, batched forward kinematics.

Facts from the dVRK's own kinematics file (sawIntuitiveResearchKit share/kinematic/ecm.json,
dVRK 2.3 joint names); the code is ours. Same conventions as cressim.robots.dh (Craig's modified
DH, T_i = Rx(alpha) Tx(a) Rz(theta) Tz(d)). Frame 0 (`ECM_base`) is the ECM's remote centre of
motion; the tip frame is DH frame 4 (a straight, 0 degree endoscope): z looks out of the scope,
which is where the stereo cameras look (cressim.twin.cart).
"""
from __future__ import annotations

import math

import numpy as np
import torch

from .dh import DHRow, dh_transform

ECM_DH = (
    DHRow("yaw", "outer_yaw", "revolute", math.pi / 2, 0.0, 0.0, math.pi / 2, -1.5708, 1.5708, 26.93208),
    DHRow("pitch", "outer_pitch", "revolute", -math.pi / 2, 0.0, 0.0, -math.pi / 2, -0.76794, 1.1344, 26.93208),
    DHRow("insertion", "insertion", "prismatic", math.pi / 2, 0.0, 0.0, -0.3822, 0.0, 0.255, 80.6589483),
    DHRow("roll", "outer_roll", "revolute", 0.0, 0.0, 0.3829, 0.0, -1.552, 1.552, 0.87658808),
)
ECM_JOINT_NAMES = tuple(r.name for r in ECM_DH)
ECM_LOWER = np.array([r.lower for r in ECM_DH])
ECM_UPPER = np.array([r.upper for r in ECM_DH])
# the twin's trajectory limits (rad/s, m/s): the dVRK ECM moves slowly; our own choice
ECM_VELOCITY = np.array([1.0, 1.0, 0.2, 1.0])


def ecm_forward_kinematics(q, *, all_frames: bool = False):
    """(..., 4) joint values (numpy or torch) -> (..., 4, 4) tip (DH frame 4) in ECM_base, or
    with all_frames (..., 4, 4, 4) for frames 1..4; numpy in gives numpy out (float64)."""
    if not torch.is_tensor(q) and np.ndim(q) == 1:
        return _one_ecm(np.asarray(q, dtype=np.float64), all_frames)  # the twin's tick: one ECM, no tensors
    is_numpy = not torch.is_tensor(q)
    qt = torch.as_tensor(np.asarray(q, dtype=np.float64)) if is_numpy else q
    T = torch.eye(4, dtype=qt.dtype, device=qt.device).expand(*qt.shape[:-1], 4, 4)
    frames = []
    for i, r in enumerate(ECM_DH):
        qi = qt[..., i]
        if r.type == "prismatic":
            theta, d = torch.zeros_like(qi), qi + r.offset + r.d
        else:
            theta, d = qi + r.offset, torch.full_like(qi, r.d)
        T = T @ dh_transform(r.alpha, r.a, theta, d)
        frames.append(T)
    out = torch.stack(frames, dim=-3) if all_frames else T
    return out.numpy() if is_numpy else out


def _one_ecm(q: np.ndarray, all_frames: bool) -> np.ndarray:
    """ecm_forward_kinematics of one joint vector in numpy (a few microseconds, where the batched
    torch path costs a tick's worth of small tensor ops)."""
    T, frames = np.eye(4), []
    for qi, r in zip(q, ECM_DH):
        theta, d = (0.0, qi + r.offset + r.d) if r.type == "prismatic" else (qi + r.offset, r.d)
        ca, sa, ct, st = math.cos(r.alpha), math.sin(r.alpha), math.cos(theta), math.sin(theta)
        T = T @ np.array([[ct, -st, 0.0, r.a],  # Rx(alpha) Tx(a) Rz(theta) Tz(d)
                          [st * ca, ct * ca, -sa, -sa * d],
                          [st * sa, ct * sa, ca, ca * d],
                          [0.0, 0.0, 0.0, 1.0]])
        frames.append(T)
    return np.stack(frames) if all_frames else T


def ecm_inverse_kinematics(T, *, position_tol: float = 1e-5, rotation_tol: float = 1e-4):
    """(4, 4) tip pose in ECM_base -> (q (4,), reachable). Closed form: the scope passes through
    the RCM, so the tip's position gives yaw, pitch (the shaft's direction, which from the DH table
    is z3 = (sin q1 cos q2, -sin q2, -cos q1 cos q2)) and insertion (the tip is 0.3829 - 0.3822 m
    beyond the RCM at q3 = 0); the roll turns frame 3 about the shaft onto the pose's x. A pose
    whose z is off the shaft (4 joints reach no other) or that needs joints beyond their limits
    is not reachable; q is then the nearest in the limits."""
    T = np.asarray(T, dtype=np.float64)
    p = T[:3, 3]
    r = float(np.linalg.norm(p))
    z3 = p / r if r > 1e-9 else T[:3, 2]
    q = np.zeros(4)
    q[1] = math.atan2(-z3[1], math.hypot(z3[0], z3[2]))
    q[0] = math.atan2(z3[0], -z3[2])
    q[2] = r - (ECM_DH[3].d + ECM_DH[2].offset)
    R3 = ecm_forward_kinematics(np.array([q[0], q[1], q[2], 0.0]))[:3, :3]
    M = R3.T @ T[:3, :3]  # frame 3 -> the pose: Rz(roll) when the pose is reachable
    q[3] = math.atan2(M[1, 0], M[0, 0])
    q = np.clip(q, ECM_LOWER, ECM_UPPER)
    F = ecm_forward_kinematics(q)
    R = F[:3, :3].T @ T[:3, :3]
    angle = math.atan2(np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2,
                       (np.trace(R) - 1) / 2)
    return q, bool(np.linalg.norm(F[:3, 3] - p) < position_tol and angle < rotation_tol)


__all__ = ["ecm_inverse_kinematics", "ECM_DH", "ECM_JOINT_NAMES", "ECM_LOWER", "ECM_UPPER", "ECM_VELOCITY", "ecm_forward_kinematics"]
