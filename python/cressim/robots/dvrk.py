"""The dVRK's names, in one place: arms, joints of both generations, the jaw, joint units.

dVRK 2.3 and later name the PSM's joints `yaw, pitch, insertion, ...`; 2.2 and earlier used
`outer_yaw, outer_pitch, ...` (accepted on input). No dependencies: the recorder's topic table
and the scene parser import it without torch.
"""
from __future__ import annotations

# the patient cart's arms (the dVRK Classic) and the console's masters
PSM_ARMS = ("PSM1", "PSM2", "PSM3")
ECM_ARMS = ("ECM",)
MTM_ARMS = ("MTML", "MTMR")
ARM_KINDS = {**{a: "psm" for a in PSM_ARMS}, "ECM": "ecm", **{a: "mtm" for a in MTM_ARMS}}

PSM_JOINTS = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")
PSM_OLD_JOINTS = ("outer_yaw", "outer_pitch", "outer_insertion", "outer_roll", "outer_wrist_pitch",
                  "outer_wrist_yaw")
JAW = "jaw"
JAW_JOINTS = (JAW,)
ECM_JOINTS = ("yaw", "pitch", "insertion", "roll")
ECM_OLD_JOINTS = ("outer_yaw", "outer_pitch", "insertion", "outer_roll")
MTM_JOINTS = ("outer_yaw", "shoulder_pitch", "elbow_pitch", "wrist_platform", "wrist_pitch", "wrist_yaw",
              "wrist_roll")


def suj_joints(arm: str) -> tuple[str, ...]:
    """The setup joints of `arm` (ECM, PSM1..3) in robots/dvrk_suj: the column (m), then 5 hinges."""
    return tuple(f"{arm}_suj_{k}" for k in range(1, 7))


JOINT_UNITS = {"yaw": "rad", "pitch": "rad", "insertion": "m", "roll": "rad", "wrist_pitch": "rad",
               "wrist_yaw": "rad", "jaw": "rad"}

# 2.2 names -> 2.3 names; the new names (and the jaw) map to themselves
_CANONICAL = {**dict(zip(PSM_OLD_JOINTS, PSM_JOINTS)), **{n: n for n in PSM_JOINTS + JAW_JOINTS}}


def canonical_joint_name(name: str) -> str:
    """'outer_yaw' -> 'yaw' (dVRK 2.2 names); 2.3 names and 'jaw' pass through. Raises on others."""
    try:
        return _CANONICAL[name]
    except KeyError:
        raise ValueError(f"unknown PSM joint {name!r}; expected one of {PSM_JOINTS}") from None


__all__ = ["ARM_KINDS", "ECM_ARMS", "ECM_JOINTS", "ECM_OLD_JOINTS", "JAW", "JAW_JOINTS", "JOINT_UNITS", "MTM_ARMS",
           "MTM_JOINTS", "PSM_ARMS", "PSM_JOINTS", "PSM_OLD_JOINTS", "canonical_joint_name", "suj_joints"]
