"""The dVRK's DH tables and a reference forward kinematics: ground truth, not the twin's model.

The package's kinematics are the URDFs' (cressim.robots.chain). These tables are what they are
checked against (tests/robots), what the generators in robots/*/tools write the URDFs from, and the synthetic recorder's stand-in for the real arm's own kinematics
(cressim.record.synthetic: a "real" recording made by a model independent of our URDF). Facts
are from the dVRK (2.3+) kinematics files (the PSM with the Large Needle Driver 400006, the ECM,
the MTMs, the Classic setup joints); the code is ours. Convention: modified DH (Craig), T_i = Rx(alpha) Tx(a) Rz(theta)
Tz(d), angles in radians, lengths in metres; a revolute joint adds q to theta, a prismatic one
adds q to d.

Numpy only (torch tensors in give tensors out), so that the recorder and the URDF generators (by
file path) load it without torch.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class DHRow(NamedTuple):
    name: str
    old_name: str  # dVRK 2.2 and earlier
    type: str  # "revolute" or "prismatic"
    alpha: float
    a: float
    d: float
    offset: float  # added to q: theta = q + offset (revolute), d = q + offset + d (prismatic)
    lower: float
    upper: float
    effort: float  # max joint effort, N m or N


PSM_DH = (
    DHRow("yaw", "outer_yaw", "revolute", math.pi / 2, 0.0, 0.0, math.pi / 2, -1.588, 1.588, 3.316),
    DHRow("pitch", "outer_pitch", "revolute", -math.pi / 2, 0.0, 0.0, -math.pi / 2, -0.925025, 0.925025, 3.316),
    DHRow("insertion", "outer_insertion", "prismatic", math.pi / 2, 0.0, 0.0, -0.4318, 0.0, 0.24, 9.878),
    DHRow("roll", "outer_roll", "revolute", 0.0, 0.0, 0.4162, 0.0, -4.53786, 4.53786, 0.33),
    DHRow("wrist_pitch", "outer_wrist_pitch", "revolute", -math.pi / 2, 0.0, 0.0, -math.pi / 2, -1.39626, 1.39626, 0.25),
    DHRow("wrist_yaw", "outer_wrist_yaw", "revolute", -math.pi / 2, 0.0091, 0.0, -math.pi / 2, -1.39626, 1.39626, 0.20),
)
JAW_LIMITS = (-0.698132, 1.39626)  # opening angle between the two jaws, rad
JAW_EFFORT = 0.16

# Rotation from DH frame 6 to the tool-tip frame (Large Needle Driver 400006). Rotation only:
# the tip frame's origin is frame 6's (the jaw pivot).
TOOL_TIP_OFFSET = np.array(
    [[0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)

# The ECM: frame 0 (`ECM_base`) is its RCM, frame 4 the tip of a straight (0 degree) endoscope.
ECM_DH = (
    DHRow("yaw", "outer_yaw", "revolute", math.pi / 2, 0.0, 0.0, math.pi / 2, -1.5708, 1.5708, 26.93208),
    DHRow("pitch", "outer_pitch", "revolute", -math.pi / 2, 0.0, 0.0, -math.pi / 2, -0.76794, 1.1344, 26.93208),
    DHRow("insertion", "insertion", "prismatic", math.pi / 2, 0.0, 0.0, -0.3822, 0.0, 0.255, 80.6589483),
    DHRow("roll", "outer_roll", "revolute", 0.0, 0.0, 0.3829, 0.0, -1.552, 1.552, 0.87658808),
)


def modified_dh(table, q, *, tool_tip=None, all_frames: bool = False):
    """Frames of a modified-DH table: q (..., n <= len(table)) -> (..., 4, 4) the last frame (times
    tool_tip), or with all_frames (..., len(table), 4, 4) frames 1..n (no tool tip). Missing
    trailing joints are 0 (a wrist-less tool). Numpy float64; a torch tensor in gives one out."""
    like = None if isinstance(q, np.ndarray) or not hasattr(q, "detach") else q
    q = np.asarray(q.detach().cpu().double() if like is not None else q, dtype=np.float64)
    lead = q.shape[:-1]
    q = q.reshape(-1, q.shape[-1])
    if q.shape[1] < len(table):
        q = np.concatenate([q, np.zeros((len(q), len(table) - q.shape[1]))], axis=1)
    T = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
    frames = []
    for i, row in enumerate(table):
        prismatic = row.type == "prismatic"
        theta = np.zeros(len(q)) if prismatic else q[:, i] + row.offset
        d = q[:, i] + row.offset + row.d if prismatic else np.full(len(q), row.d)
        ct, st, ca, sa = np.cos(theta), np.sin(theta), math.cos(row.alpha), math.sin(row.alpha)
        Ti = np.zeros((len(q), 4, 4))
        Ti[:, 0, 0], Ti[:, 0, 1], Ti[:, 0, 3] = ct, -st, row.a
        Ti[:, 1, 0], Ti[:, 1, 1], Ti[:, 1, 2], Ti[:, 1, 3] = st * ca, ct * ca, -sa, -sa * d
        Ti[:, 2, 0], Ti[:, 2, 1], Ti[:, 2, 2], Ti[:, 2, 3] = st * sa, ct * sa, ca, ca * d
        Ti[:, 3, 3] = 1.0
        T = T @ Ti
        frames.append(T)
    if all_frames:
        out = np.stack(frames, axis=1).reshape(*lead, len(table), 4, 4)
    else:
        out = (T if tool_tip is None else T @ np.asarray(tool_tip)).reshape(*lead, 4, 4)
    if like is None:
        return out
    import torch

    return torch.as_tensor(out, dtype=like.dtype, device=like.device)


def dh_forward_kinematics(q, *, tool_tip=TOOL_TIP_OFFSET, all_frames=False):
    """The PSM's tool tip in PSM1_base (the RCM frame): (..., n <= 6) in PSM_DH order -> (..., 4, 4),
    or with all_frames (..., 6, 4, 4) frames 1..6; tool_tip None: frame 6 itself."""
    return modified_dh(PSM_DH, q, tool_tip=tool_tip, all_frames=all_frames)


def ecm_forward_kinematics(q, *, all_frames: bool = False):
    """The ECM's tip (DH frame 4) in ECM_base: (..., 4) -> (..., 4, 4), or (..., 4, 4, 4) frames 1..4."""
    return modified_dh(ECM_DH, q, all_frames=all_frames)


# The MTMs (sawIntuitiveResearchKit share/kinematic/mtml.json and mtmr.json): 7 revolute joints,
# standard DH, T_i = Rz(theta) Tz(d) Tx(a) Rx(alpha) with theta = q + offset; MTML and MTMR
# differ only in the outer yaw's and the wrist platform's limits. Frame 0 is the MTM's DH base,
# frame 7 the grip (the dVRK's local/measured_cp).
class MtmRow(NamedTuple):
    name: str
    alpha: float
    a: float
    d: float
    offset: float
    lower: float
    upper: float


def _mtm_table(yaw_limits, platform_limits):
    h = math.pi / 2
    return (MtmRow("outer_yaw", h, 0.0, 0.0, -h, *yaw_limits),
            MtmRow("shoulder_pitch", 0.0, 0.2794, 0.0, -h, -0.261799, 0.872665),
            MtmRow("elbow_pitch", -h, 0.3645, 0.0, h, -0.872665, 0.610865),
            MtmRow("wrist_platform", h, 0.0, 0.1506, 0.0, *platform_limits),
            MtmRow("wrist_pitch", -h, 0.0, 0.0, 0.0, -1.5708, 3.14159),
            MtmRow("wrist_yaw", h, 0.0, 0.0, -h, -0.785398, 0.785398),
            MtmRow("wrist_roll", 0.0, 0.0, 0.0, h, -8.37758, 7.85398))


MTM_DH = {"MTML": _mtm_table((-0.698132, 1.13446), (-3.49066, 1.5708)),
          "MTMR": _mtm_table((-1.13446, 0.698132), (-1.22173, 4.01426))}


def standard_dh_link(row, q: float) -> np.ndarray:
    """Rz(q + offset) Tz(d) Tx(a) Rx(alpha)."""
    ct, st = math.cos(q + row.offset), math.sin(q + row.offset)
    ca, sa = math.cos(row.alpha), math.sin(row.alpha)
    return np.array([[ct, -st * ca, st * sa, row.a * ct], [st, ct * ca, -ct * sa, row.a * st],
                     [0.0, sa, ca, row.d], [0.0, 0.0, 0.0, 1.0]])


def mtm_dh_forward_kinematics(side: str, q, *, all_frames: bool = False) -> np.ndarray:
    """(7,) -> (4, 4) the grip (frame 7) of MTML or MTMR in its DH base, or (7, 4, 4) frames 1..7."""
    T, frames = np.eye(4), []
    for row, value in zip(MTM_DH[side], np.asarray(q, dtype=np.float64)):
        T = T @ standard_dh_link(row, float(value))
        frames.append(T)
    return np.stack(frames) if all_frames else T


# The dVRK Classic setup joints (sawIntuitiveResearchKit share/arm/suj-simulated.json): each SUJ
# a modified-DH chain (a prismatic column, then revolute joints) mounted at `world-origin-to-suj`
# on the cart (z up) and ending at `suj-tip-to-tool-origin`, the arm's base frame (its RCM).
class SujLink(NamedTuple):
    alpha: float
    a: float
    d: float
    prismatic: bool
    offset: float


_SUJ_PSM12 = (SujLink(0.0, 0.0896, 0.0, True, 0.0), SujLink(0.0, 0.0, 0.4166, False, 0.0),
              SujLink(0.0, 0.4318, 0.1429, False, 0.0), SujLink(0.0, 0.4318, -0.1302, False, math.pi / 2),
              SujLink(math.pi / 2, 0.0, 0.4089, False, 0.0), SujLink(-math.pi / 2, 0.0, -0.1029, False, -math.pi / 2))
SUJ_DH = {
    "ECM": (SujLink(0.0, 0.0896, 0.0, True, 0.0), SujLink(0.0, 0.0, 0.4166, False, 0.0),
            SujLink(0.0, 0.4318, 0.1429, False, 0.0), SujLink(0.0, 0.4318, -0.3459, False, math.pi / 2),
            SujLink(-0.7853, 0.0, 0.0, False, math.pi / 2), SujLink(0.0, -0.0667, 0.0, False, 0.0)),
    "PSM1": _SUJ_PSM12,
    "PSM2": _SUJ_PSM12,
    "PSM3": (SujLink(0.0, 0.0896, 0.0, True, 0.0), SujLink(0.0, 0.0, 0.3404, False, 0.0),
             SujLink(0.0, 0.5842, 0.1429, False, 0.0), SujLink(0.0, 0.4318, 0.2571, False, math.pi / 2),
             SujLink(math.pi / 2, 0.0, 0.4089, False, 0.0), SujLink(-math.pi / 2, 0.0, -0.1029, False, -math.pi / 2)),
}


def _frame(translation, rotation) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation, translation
    return T


_RZ90 = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
_RZ180 = [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
_RZ_90 = [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
CART_TO_SUJ = {"ECM": _frame([0.0, 0.0, 0.43], _RZ90), "PSM1": _frame([-0.1016, -0.1016, 0.43], _RZ180),
               "PSM2": _frame([0.1016, -0.1016, 0.43], np.eye(3)), "PSM3": _frame([0.0, 0.0, 0.1264], _RZ90)}
SUJ_TIP_TO_BASE = {"ECM": _frame([0.6126, 0.0, 0.1016], _RZ_90), "PSM1": _frame([0.4864, 0.0, 0.1524], _RZ_90),
                   "PSM2": _frame([0.4864, 0.0, 0.1524], _RZ_90), "PSM3": _frame([0.4864, 0.0, 0.1524], _RZ_90)}


def suj_link(link: SujLink, q: float) -> np.ndarray:
    """Rx(alpha) Tx(a) Rz(theta) Tz(d) (modified DH)."""
    theta, d = (link.offset, link.d + q) if link.prismatic else (q + link.offset, link.d)
    ca, sa, ct, st = math.cos(link.alpha), math.sin(link.alpha), math.cos(theta), math.sin(theta)
    return np.array([[ct, -st, 0.0, link.a], [st * ca, ct * ca, -sa, -sa * d], [st * sa, ct * sa, ca, ca * d],
                     [0.0, 0.0, 0.0, 1.0]])


def suj_dh_base(arm: str, q) -> np.ndarray:
    """(4, 4): the base frame (RCM) of `arm` in the cart's frame for setup-joint values q (6)."""
    T = CART_TO_SUJ[arm].copy()
    for link, value in zip(SUJ_DH[arm], np.asarray(q, dtype=np.float64)):
        T = T @ suj_link(link, float(value))
    return T @ SUJ_TIP_TO_BASE[arm]


__all__ = ["CART_TO_SUJ", "DHRow", "ECM_DH", "JAW_EFFORT", "JAW_LIMITS", "MTM_DH", "MtmRow", "PSM_DH", "SUJ_DH",
           "SUJ_TIP_TO_BASE", "SujLink", "TOOL_TIP_OFFSET", "dh_forward_kinematics", "ecm_forward_kinematics",
           "modified_dh", "mtm_dh_forward_kinematics", "standard_dh_link", "suj_dh_base", "suj_link"]
