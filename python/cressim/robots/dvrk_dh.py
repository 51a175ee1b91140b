"""The dVRK's DH tables and a reference forward kinematics: ground truth, not the twin's model.

The package's kinematics are the URDFs' (cressim.robots.chain). These tables are what they are
checked against (tests/robots), what robots/dvrk_psm/tools and robots/dvrk_ecm/tools write the
URDFs from, and the synthetic recorder's stand-in for the real arm's own kinematics
(cressim.record.synthetic: a "real" recording made by a model independent of our URDF). Facts
are from the dVRK (2.3+) PSM kinematics with the Large Needle Driver (400006) and the ECM's
ecm.json; the code is ours. Convention: modified DH (Craig), T_i = Rx(alpha) Tx(a) Rz(theta)
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


__all__ = ["DHRow", "ECM_DH", "JAW_EFFORT", "JAW_LIMITS", "PSM_DH", "TOOL_TIP_OFFSET", "dh_forward_kinematics",
           "ecm_forward_kinematics", "modified_dh"]
