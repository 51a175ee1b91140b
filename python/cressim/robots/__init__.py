"""Robot models: the dVRK PSM from robots/dvrk_psm, with batched FK, Jacobians and IK.

Depends on torch, numpy, yourdfpy and pytorch-kinematics only (no compiled engine code).
"""
from cressim.robots.dh import (
    JAW_LIMITS,
    PSM_DH,
    PSM_JOINT_NAMES,
    PSM_OLD_JOINT_NAMES,
    TOOL_TIP_OFFSET,
    dh_forward_kinematics,
)
from cressim.robots.psm import BASE_LINK, PSM, TIP_LINK, IKResult, canonical_joint_name, robot_dir

__all__ = [
    "BASE_LINK",
    "IKResult",
    "JAW_LIMITS",
    "PSM",
    "PSM_DH",
    "PSM_JOINT_NAMES",
    "PSM_OLD_JOINT_NAMES",
    "TIP_LINK",
    "TOOL_TIP_OFFSET",
    "canonical_joint_name",
    "dh_forward_kinematics",
    "robot_dir",
]
