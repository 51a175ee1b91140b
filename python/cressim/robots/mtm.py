"""The dVRK master tool manipulator (MTM): standard-DH tables, forward kinematics, Jacobian, IK.

Facts from the dVRK's own kinematics files (sawIntuitiveResearchKit share/kinematic/mtml.json and
mtmr.json: 7 revolute joints, standard DH, T_i = Rz(theta) Tz(d) Tx(a) Rx(alpha) with theta =
q + offset; MTML and MTMR differ only in the outer yaw's and the wrist platform's limits); the
code is ours. Frame 0 is the MTM's DH base, frame 7 the grip (the dVRK's local/measured_cp).

The arm has one joint more than the grip's pose needs (the wrist platform), so the inverse
(`mtm_inverse_kinematics`) is numerical: damped least squares from a seed (the last joints),
clamped to the limits, the redundancy resolved by the smallest joint motion.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class MtmRow(NamedTuple):
    name: str
    alpha: float
    a: float
    d: float
    offset: float
    lower: float
    upper: float


def _table(yaw_limits, platform_limits):
    h = math.pi / 2
    return (MtmRow("outer_yaw", h, 0.0, 0.0, -h, *yaw_limits),
            MtmRow("shoulder_pitch", 0.0, 0.2794, 0.0, -h, -0.261799, 0.872665),
            MtmRow("elbow_pitch", -h, 0.3645, 0.0, h, -0.872665, 0.610865),
            MtmRow("wrist_platform", h, 0.0, 0.1506, 0.0, *platform_limits),
            MtmRow("wrist_pitch", -h, 0.0, 0.0, 0.0, -1.5708, 3.14159),
            MtmRow("wrist_yaw", h, 0.0, 0.0, -h, -0.785398, 0.785398),
            MtmRow("wrist_roll", 0.0, 0.0, 0.0, h, -8.37758, 7.85398))


MTM_DH = {"MTML": _table((-0.698132, 1.13446), (-3.49066, 1.5708)),
          "MTMR": _table((-1.13446, 0.698132), (-1.22173, 4.01426))}
MTM_JOINT_NAMES = tuple(r.name for r in MTM_DH["MTMR"])
MTM_HOME = np.zeros(7)  # where the dVRK homes an MTM


def mtm_table(name: str):
    """The DH table of MTML or MTMR (an MTM named otherwise, `MTMR2` say, by its side's letter)."""
    side = "MTML" if name.upper().startswith("MTML") else "MTMR"
    return MTM_DH[side]


def mtm_limits(name: str) -> tuple[np.ndarray, np.ndarray]:
    table = mtm_table(name)
    return np.array([r.lower for r in table]), np.array([r.upper for r in table])


def mtm_forward_kinematics(name: str, q, *, all_frames: bool = False) -> np.ndarray:
    """(7,) joint values -> (4, 4) grip (frame 7) in the MTM's DH base, or (7, 4, 4) frames 1..7."""
    T, frames = np.eye(4), []
    for r, qi in zip(mtm_table(name), np.asarray(q, dtype=np.float64)):
        ct, st = math.cos(qi + r.offset), math.sin(qi + r.offset)
        ca, sa = math.cos(r.alpha), math.sin(r.alpha)
        T = T @ np.array([[ct, -st * ca, st * sa, r.a * ct],
                          [st, ct * ca, -ct * sa, r.a * st],
                          [0.0, sa, ca, r.d],
                          [0.0, 0.0, 0.0, 1.0]])
        frames.append(T)
    return np.stack(frames) if all_frames else T


def mtm_jacobian(name: str, q) -> tuple[np.ndarray, np.ndarray]:
    """(6, 7) geometric Jacobian of the grip (linear, angular; base axes) and the grip (4, 4)."""
    F = mtm_forward_kinematics(name, q, all_frames=True)
    z = np.vstack([[0.0, 0.0, 1.0], F[:-1, :3, 2]])  # joint i turns about frame i-1's z
    o = np.vstack([[0.0, 0.0, 0.0], F[:-1, :3, 3]])
    p = F[-1, :3, 3]
    return np.vstack([np.cross(z, p - o).T, z.T]), F[-1]


def _rotation_error(R_goal, R):
    """The rotation vector (base axes) that turns R onto R_goal."""
    E = R_goal @ R.T
    angle = math.acos(max(-1.0, min(1.0, (np.trace(E) - 1.0) / 2.0)))
    axis = np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
    n = np.linalg.norm(axis)
    if n < 1e-12:
        if angle < 1e-6:
            return np.zeros(3)
        # a half turn: the axis is the column of (E + I) / 2 with the largest norm
        B = (E + np.eye(3)) / 2.0
        axis = B[:, int(np.argmax(np.linalg.norm(B, axis=0)))]
        return angle * axis / np.linalg.norm(axis)
    return angle * axis / n


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


__all__ = ["MTM_DH", "MTM_HOME", "MTM_JOINT_NAMES", "mtm_forward_kinematics", "mtm_inverse_kinematics",
           "mtm_jacobian", "mtm_limits", "mtm_table"]
