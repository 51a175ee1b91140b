"""Robot models: one kinematics for every arm (cressim.robots.chain: a URDF compiled once, batched
FK and Jacobians in torch on any device, and the GPU's link poses), the dVRK's arms on it (PSM,
ECM, MTM, setup joints), the dVRK's names (cressim.robots.dvrk), and URDF -> engine bodies
(kinematic or dynamic, `ArmBodies`).

Every name loads on first use: the names module needs nothing, the kinematics torch, numpy and
yourdfpy, `ArmBodies` and `ArmVisuals` the engine and trimesh.
"""
import importlib

_LAZY = {
    **{name: "cressim.robots.dvrk" for name in (
        "ARM_KINDS", "ECM_JOINTS", "JAW", "JAW_JOINTS", "MTM_JOINTS", "PSM_JOINTS", "PSM_OLD_JOINTS",
        "canonical_joint_name")},
    "Chain": "cressim.robots.chain",
    **{name: "cressim.robots.kinematics" for name in (
        "INTERFACE_DOF", "ArmKinematics", "body_jacobian", "matrix_to_pose7", "pose7_to_matrix")},
    "rotation_xyzw": "cressim.robots.chain",
    **{name: "cressim.robots.psm" for name in (
        "BASE_LINK", "IKResult", "JAW_GRASP_POINT", "JAW_LINK", "PSM", "TIP_LINK", "robot_dir")},
    "ArmBodies": "cressim.robots.arm_bodies",
    "describe_health": "cressim.robots.arm_bodies",
    "ArmVisuals": "cressim.robots.arm_visuals",
}

def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'cressim.robots' has no attribute {name!r}")


__all__ = sorted(_LAZY)
