"""The dVRK PSM modified-DH table and a batched reference forward kinematics.

This is the ground truth that our URDFs (robots/dvrk_psm) are tested against. Facts are from
the dVRK (2.3+) PSM kinematics with the Large Needle Driver (400006); the code is ours.
Convention: modified DH (Craig), T_i = Rx(alpha) Tx(a) Rz(theta) Tz(d), angles in radians,
lengths in metres; a revolute joint adds q to theta, a prismatic one adds q to d.

Depends only on numpy and torch so that robots/dvrk_psm/tools can load it by file path.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import torch


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
PSM_JOINT_NAMES = tuple(r.name for r in PSM_DH)
PSM_OLD_JOINT_NAMES = tuple(r.old_name for r in PSM_DH)

JAW_LIMITS = (-0.698132, 1.39626)  # opening angle between the two jaws, rad
JAW_EFFORT = 0.16

# Rotation from DH frame 6 to the tool-tip frame (Large Needle Driver 400006). Rotation only:
# the tip frame's origin is frame 6's (the jaw pivot).
TOOL_TIP_OFFSET = np.array(
    [[0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)


def dh_transform(alpha, a, theta, d):
    """Batched modified-DH link transform Rx(alpha) Tx(a) Rz(theta) Tz(d).

    alpha and a are floats; theta and d are tensors of one shape (...); returns (..., 4, 4).
    """
    ct, st = torch.cos(theta), torch.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    zero, one = torch.zeros_like(ct), torch.ones_like(ct)
    rows = (
        (ct, -st, zero, zero + a),
        (st * ca, ct * ca, zero - sa, -sa * d),
        (st * sa, ct * sa, zero + ca, ca * d),
        (zero, zero, zero, one),
    )
    return torch.stack([torch.stack(r, dim=-1) for r in rows], dim=-2)


def _fixed_parts() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per joint: Rx(alpha) Tx(a) (6, 4, 4), whether it slides, and theta and d at q = 0."""
    zero = torch.zeros((), dtype=torch.float64)
    fixed = np.stack([dh_transform(r.alpha, r.a, zero, zero).numpy() for r in PSM_DH])
    prismatic = np.array([r.type == "prismatic" for r in PSM_DH])
    theta0 = np.array([0.0 if r.type == "prismatic" else r.offset for r in PSM_DH])
    d0 = np.array([r.d + (r.offset if r.type == "prismatic" else 0.0) for r in PSM_DH])
    return fixed, prismatic, theta0, d0


_FIXED, _PRISMATIC, _THETA0, _D0 = _fixed_parts()
_ON = {}  # (dtype, device) -> the fixed parts as tensors there


def dh_forward_kinematics(q, *, tool_tip=TOOL_TIP_OFFSET, all_frames=False):
    """Reference FK of the PSM: tool-tip pose in PSM1_base (the RCM frame).

    q: (..., n) joint values with n <= 6 in PSM_JOINT_NAMES order (numpy or torch); a shorter q
    (a wrist-less tool) leaves the missing joints at 0. tool_tip: 4x4 applied after frame 6
    (None for frame 6 itself). Returns (..., 4, 4), or with all_frames (..., 6, 4, 4) for
    frames 1..6 (no tool tip); numpy in gives numpy out (float64), torch keeps dtype/device.
    Every joint's Rz(theta) Tz(d) at once, then one product down the chain: the twin calls this a
    few times a tick, and a link at a time cost a hundred small tensor ops.
    """
    is_numpy = not torch.is_tensor(q)
    qt = torch.as_tensor(np.asarray(q, dtype=np.float64)) if is_numpy else q
    n = len(PSM_DH)
    if qt.shape[-1] < n:
        qt = torch.cat([qt, qt.new_zeros(*qt.shape[:-1], n - qt.shape[-1])], dim=-1)
    key = (qt.dtype, qt.device)
    if key not in _ON:
        _ON[key] = tuple(torch.as_tensor(a, device=qt.device).to(qt.dtype if a.dtype == np.float64 else torch.bool)
                         for a in (_FIXED, _PRISMATIC, _THETA0, _D0))
    fixed, prismatic, theta0, d0 = _ON[key]
    theta = theta0 + torch.where(prismatic, torch.zeros_like(qt), qt)
    d = d0 + torch.where(prismatic, qt, torch.zeros_like(qt))
    c, s = torch.cos(theta), torch.sin(theta)
    moving = qt.new_zeros(*qt.shape, 4, 4)  # Rz(theta) Tz(d) per joint
    moving[..., 0, 0], moving[..., 0, 1], moving[..., 1, 0], moving[..., 1, 1] = c, -s, s, c
    moving[..., 2, 2], moving[..., 3, 3], moving[..., 2, 3] = 1.0, 1.0, d
    links = fixed @ moving  # (..., 6, 4, 4)
    frames = [links[..., 0, :, :]]
    for i in range(1, n):
        frames.append(frames[-1] @ links[..., i, :, :])
    if all_frames:
        out = torch.stack(frames, dim=-3)
    elif tool_tip is not None:
        out = frames[-1] @ torch.as_tensor(np.asarray(tool_tip), dtype=qt.dtype, device=qt.device)
    else:
        out = frames[-1]
    return out.numpy() if is_numpy else out


__all__ = [
    "DHRow",
    "JAW_EFFORT",
    "JAW_LIMITS",
    "PSM_DH",
    "PSM_JOINT_NAMES",
    "PSM_OLD_JOINT_NAMES",
    "TOOL_TIP_OFFSET",
    "dh_forward_kinematics",
    "dh_transform",
]
