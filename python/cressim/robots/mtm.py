"""The dVRK master tool manipulator (MTM): FK and Jacobian of robots/dvrk_mtm/mtml.urdf and
mtmr.urdf on the one kinematics (cressim.robots.chain), and a numerical IK.

The URDFs are the dVRK's standard-DH tables (mtml.json, mtmr.json: 7 revolute joints; MTML and
MTMR differ only in the outer yaw's and the wrist platform's limits), written by
robots/dvrk_mtm/tools from cressim.robots.dvrk_dh, which tests/robots check them against. Frame 0
is the MTM's DH base (`<side>_base`), frame 7 the grip (the dVRK's local/measured_cp).

The arm has one joint more than the grip's pose needs (the wrist platform), so the inverse
(`mtm_inverse_kinematics`) is numerical: damped least squares from a seed (the last joints),
clamped to the limits, the redundancy resolved by the smallest joint motion.
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from .chain import Chain
from .dvrk import MTM_JOINTS
from .psm import robot_dir

MTM_JOINT_NAMES = MTM_JOINTS
MTM_HOME = np.zeros(7)  # where the dVRK homes an MTM


def mtm_side(name: str) -> str:
    """MTML or MTMR (an MTM named otherwise, `MTMR2` say, by its side's letter)."""
    return "MTML" if name.upper().startswith("MTML") else "MTMR"


def mtm_urdf(name: str) -> Path:
    return robot_dir().parent / "dvrk_mtm" / f"{mtm_side(name).lower()}.urdf"


@functools.cache
def _chain(side: str) -> Chain:
    frames = tuple(f"{side}_{joint}_link" for joint in MTM_JOINTS)  # DH frames 1..7
    return Chain(mtm_urdf(side), sources=MTM_JOINTS, base=f"{side}_base", tip=frames[-1], links=frames)


def mtm_chain(name: str) -> Chain:
    return _chain(mtm_side(name))


def mtm_limits(name: str) -> tuple[np.ndarray, np.ndarray]:
    chain = mtm_chain(name)
    return chain.lower.copy(), chain.upper.copy()


def mtm_forward_kinematics(name: str, q, *, all_frames: bool = False) -> np.ndarray:
    """(7,) joint values -> (4, 4) grip (frame 7) in the MTM's DH base, or (7, 4, 4) frames 1..7."""
    chain = mtm_chain(name)
    q = np.asarray(q, dtype=np.float64)
    return chain.link_poses(q) if all_frames else chain.forward(q)


def mtm_jacobian(name: str, q) -> tuple[np.ndarray, np.ndarray]:
    """(6, 7) geometric Jacobian of the grip (linear, angular; base axes) and the grip (4, 4)."""
    return mtm_chain(name).jacobian(np.asarray(q, dtype=np.float64))


def _rotation_error(R_goal, R):
    """The rotation vector (base axes) that turns R onto R_goal. The angle from atan2 of the
    antisymmetric part and the trace: acos of the trace alone is blind below about 1e-8 rad."""
    E = R_goal @ R.T
    axis = np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])  # 2 sin(angle) along the axis
    n = float(np.linalg.norm(axis))
    c = (np.trace(E) - 1.0) / 2.0
    if n < 1e-12:
        if c > 0.0:
            return axis / 2.0  # (next to) no turn
        # a half turn: the axis is the column of (E + I) / 2 with the largest norm
        B = (E + np.eye(3)) / 2.0
        axis = B[:, int(np.argmax(np.linalg.norm(B, axis=0)))]
        return math.pi * axis / np.linalg.norm(axis)
    return math.atan2(n / 2.0, c) * axis / n


def mtm_inverse_kinematics(name: str, T_goal: np.ndarray, seed, *, iterations: int = 50, position_tol: float = 1e-10,
                           rotation_tol: float = 1e-9, damping: float = 1e-3) -> tuple[np.ndarray, bool]:
    """Joint values whose grip is T_goal ((4, 4) in the DH base), from `seed`, within the limits:
    (q, reached: within position_tol m and rotation_tol rad). Not reached (out of the workspace or
    limits, or more iterations needed): q is the nearest found."""
    lower, upper = mtm_limits(name)
    q = np.clip(np.asarray(seed, dtype=np.float64), lower, upper)
    for _ in range(iterations):
        J, T = mtm_jacobian(name, q)
        e = np.concatenate([T_goal[:3, 3] - T[:3, 3], _rotation_error(T_goal[:3, :3], T[:3, :3])])
        if np.linalg.norm(e[:3]) < position_tol and np.linalg.norm(e[3:]) < rotation_tol:
            return q, True
        dq = J.T @ np.linalg.solve(J @ J.T + damping ** 2 * np.eye(6), e)
        q = np.clip(q + dq, lower, upper)
    return q, False


__all__ = ["MTM_HOME", "MTM_JOINT_NAMES", "mtm_chain", "mtm_forward_kinematics", "mtm_inverse_kinematics",
           "mtm_jacobian", "mtm_limits", "mtm_side", "mtm_urdf"]
