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


def _columns(name: str):
    """The table as arrays (alpha's cosine and sine, a, d, offset), made once per side."""
    table = mtm_table(name)
    if table not in _COLUMNS:
        alpha = np.array([r.alpha for r in table])
        _COLUMNS[table] = (np.cos(alpha), np.sin(alpha), np.array([r.a for r in table]), np.array([r.d for r in table]),
                           np.array([r.offset for r in table]))
    return _COLUMNS[table]


_COLUMNS = {}


def mtm_forward_kinematics(name: str, q, *, all_frames: bool = False) -> np.ndarray:
    """(7,) joint values -> (4, 4) grip (frame 7) in the MTM's DH base, or (7, 4, 4) frames 1..7.
    Every link's Rz(theta) Tz(d) Tx(a) Rx(alpha) at once, then the product down the chain (the IK
    calls this a few times a tick)."""
    ca, sa, a, d, offset = _columns(name)
    theta = np.asarray(q, dtype=np.float64) + offset
    ct, st = np.cos(theta), np.sin(theta)
    L = np.zeros((7, 4, 4))
    L[:, 0, 0], L[:, 0, 1], L[:, 0, 2], L[:, 0, 3] = ct, -st * ca, st * sa, a * ct
    L[:, 1, 0], L[:, 1, 1], L[:, 1, 2], L[:, 1, 3] = st, ct * ca, -ct * sa, a * st
    L[:, 2, 1], L[:, 2, 2], L[:, 2, 3], L[:, 3, 3] = sa, ca, d, 1.0
    for i in range(1, 7):
        L[i] = L[i - 1] @ L[i]
    return L if all_frames else L[-1]


def mtm_jacobian(name: str, q) -> tuple[np.ndarray, np.ndarray]:
    """(6, 7) geometric Jacobian of the grip (linear, angular; base axes) and the grip (4, 4)."""
    F = mtm_forward_kinematics(name, q, all_frames=True)
    J = np.empty((6, 7))
    z, r = J[3:], np.empty((3, 7))  # joint i turns about frame i-1's z, at frame i-1's origin
    z[:, 0], z[:, 1:] = (0.0, 0.0, 1.0), F[:-1, :3, 2].T
    r[:, 0], r[:, 1:] = F[-1, :3, 3], F[-1, :3, 3, None] - F[:-1, :3, 3].T  # to the grip
    J[0], J[1], J[2] = z[1] * r[2] - z[2] * r[1], z[2] * r[0] - z[0] * r[2], z[0] * r[1] - z[1] * r[0]
    return J, F[-1]


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


__all__ = ["MTM_DH", "MTM_HOME", "MTM_JOINT_NAMES", "mtm_forward_kinematics", "mtm_inverse_kinematics",
           "mtm_jacobian", "mtm_limits", "mtm_table"]
