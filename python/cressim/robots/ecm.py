"""The dVRK endoscope camera manipulator (ECM): FK and Jacobian of robots/dvrk_ecm/ecm.urdf on the
one kinematics (cressim.robots.chain), and its closed-form IK.

Frame 0 (`ECM_base`) is the ECM's remote centre of motion; the tip is `ECM_roll_link` (a
straight, 0 degree endoscope): z looks out of the scope, which is where the stereo cameras look
(cressim.twin.cart). The URDF's yaw, pitch, insertion and roll links are the dVRK's DH frames 1..4
(tests/robots check it against the dVRK's ecm.json table).
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from .chain import Chain
from .dvrk import ECM_JOINTS
from .psm import robot_dir

ECM_JOINT_NAMES = ECM_JOINTS
BASE_LINK = "ECM_base"
TIP_LINK = "ECM_roll_link"
FRAME_LINKS = ("ECM_yaw_link", "ECM_pitch_link", "ECM_insertion_link", TIP_LINK)  # DH frames 1..4
# the twin's trajectory limits (rad/s, m/s): the dVRK ECM moves slowly; our own choice
ECM_VELOCITY = np.array([1.0, 1.0, 0.2, 1.0])


def ecm_urdf() -> Path:
    return robot_dir().parent / "dvrk_ecm" / "ecm.urdf"


@functools.cache
def ecm_chain() -> Chain:
    return Chain(ecm_urdf(), sources=ECM_JOINTS, base=BASE_LINK, tip=TIP_LINK, links=FRAME_LINKS)


def __getattr__(name):  # the limits are the URDF's, read on first use
    if name == "ECM_LOWER":
        return ecm_chain().lower.copy()
    if name == "ECM_UPPER":
        return ecm_chain().upper.copy()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def ecm_forward_kinematics(q, *, all_frames: bool = False):
    """(..., 4) joint values (numpy or torch) -> (..., 4, 4) tip in ECM_base, or with all_frames
    (..., 4, 4, 4) for DH frames 1..4; numpy in gives numpy out (float64)."""
    chain = ecm_chain()
    return chain.link_poses(q) if all_frames else chain.forward(q)


def ecm_jacobian(q):
    """(..., 4) -> (J (..., 6, 4), T (..., 4, 4)): [v; w] of the tip in ECM_base axes, and the tip."""
    return ecm_chain().jacobian(q)


@functools.cache
def _tip_at_zero() -> float:
    """How far beyond the RCM the tip sits along the scope at insertion 0 (m)."""
    T = ecm_forward_kinematics(np.zeros(4))
    return float(T[:3, 3] @ T[:3, 2])


def ecm_inverse_kinematics(T, *, position_tol: float = 1e-5, rotation_tol: float = 1e-4):
    """(4, 4) tip pose in ECM_base -> (q (4,), reachable). Closed form: the scope passes through
    the RCM, so the tip's position gives yaw, pitch (the shaft's direction, which in the DH frames
    is z3 = (sin q1 cos q2, -sin q2, -cos q1 cos q2)) and insertion (the tip is 0.7 mm beyond the
    RCM at q3 = 0); the roll turns frame 3 about the shaft onto the pose's x. A pose whose z is off
    the shaft (4 joints reach no other) or that needs joints beyond their limits is not
    reachable; q is then the nearest in the limits."""
    chain = ecm_chain()
    T = np.asarray(T, dtype=np.float64)
    p = T[:3, 3]
    r = float(np.linalg.norm(p))
    z3 = p / r if r > 1e-9 else T[:3, 2]
    q = np.zeros(4)
    q[1] = math.atan2(-z3[1], math.hypot(z3[0], z3[2]))
    q[0] = math.atan2(z3[0], -z3[2])
    q[2] = r - _tip_at_zero()
    R3 = ecm_forward_kinematics(np.array([q[0], q[1], q[2], 0.0]))[:3, :3]
    M = R3.T @ T[:3, :3]  # frame 3 -> the pose: Rz(roll) when the pose is reachable
    q[3] = math.atan2(M[1, 0], M[0, 0])
    q = np.clip(q, chain.lower, chain.upper)
    F = ecm_forward_kinematics(q)
    R = F[:3, :3].T @ T[:3, :3]
    angle = math.atan2(np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2,
                       (np.trace(R) - 1) / 2)
    return q, bool(np.linalg.norm(F[:3, 3] - p) < position_tol and angle < rotation_tol)


__all__ = ["BASE_LINK", "ECM_JOINT_NAMES", "ECM_LOWER", "ECM_UPPER", "ECM_VELOCITY", "FRAME_LINKS", "TIP_LINK",
           "ecm_chain", "ecm_forward_kinematics", "ecm_inverse_kinematics", "ecm_jacobian", "ecm_urdf"]
