"""Robot models: URDF -> batched FK, Jacobians and IK (torch, any device), and URDF -> engine
bodies (kinematic or dynamic, `ArmBodies`). The dVRK PSM in robots/dvrk_psm is the first user.

The kinematics depend on torch, numpy, yourdfpy and pytorch-kinematics only; `ArmBodies` and
`ArmVisuals` (which need the engine and trimesh) load on first use.
"""
from cressim.robots.dh import (
    JAW_LIMITS,
    PSM_DH,
    PSM_JOINT_NAMES,
    PSM_OLD_JOINT_NAMES,
    TOOL_TIP_OFFSET,
    dh_forward_kinematics,
)
from cressim.robots.kinematics import (
    INTERFACE_DOF,
    ArmKinematics,
    body_jacobian,
    matrix_to_pose7,
    pose7_to_matrix,
    rotation_xyzw,
)
from cressim.robots.psm import (
    BASE_LINK,
    JAW_GRASP_POINT,
    JAW_LINK,
    PSM,
    TIP_LINK,
    IKResult,
    canonical_joint_name,
    robot_dir,
)

_LAZY = {"ArmBodies": "cressim.robots.arm_bodies", "describe_health": "cressim.robots.arm_bodies",
         "ArmVisuals": "cressim.robots.arm_visuals"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'cressim.robots' has no attribute {name!r}")


__all__ = [
    "ArmBodies",
    "ArmKinematics",
    "ArmVisuals",
    "BASE_LINK",
    "INTERFACE_DOF",
    "IKResult",
    "JAW_GRASP_POINT",
    "JAW_LIMITS",
    "JAW_LINK",
    "PSM",
    "PSM_DH",
    "PSM_JOINT_NAMES",
    "PSM_OLD_JOINT_NAMES",
    "TIP_LINK",
    "TOOL_TIP_OFFSET",
    "body_jacobian",
    "canonical_joint_name",
    "describe_health",
    "dh_forward_kinematics",
    "matrix_to_pose7",
    "pose7_to_matrix",
    "robot_dir",
    "rotation_xyzw",
]
