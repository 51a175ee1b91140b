"""Batched RL tasks: `cressim.envs.make("CartPole", num_envs=4096, device="cuda")`,
`make("TargetCenter", 1024)` (64x64 RGB observations), `make("UltrasoundScan", 32)` (B-mode images),
`make("SoftBodyPush", 512)`, `make("FluidPour", 128)` (particles), `make("TissueRetract", 256)` (the dVRK PSM
grasps and lifts a tissue sheet), `make("BloodSuction", 128)` (the PSM's suction tool clears a pool of blood;
13 numbers and a 64x64 RGB image). Every task is a gymnasium VectorEnv, registered as `cressim/<Task>-v0`
(`gymnasium.make_vec("cressim/CartPole-v0", num_envs=64)`, cressim/registration.py)."""
from __future__ import annotations

from .blood_suction import BloodSuction
from .cartpole import CartPole
from .fluid_pour import FluidPour
from .soft_body_push import SoftBodyPush
from .target_center import TargetCenter
from .tissue_retract import TissueRetract
from .ultrasound_scan import UltrasoundScan
from .vector_env import VectorEnv, box
from ..registration import TASKS, env_id

REGISTRY = {name: globals()[name] for name in TASKS}


def make(name: str, num_envs: int, **kwargs) -> VectorEnv:
    """Creates the task `name` with `num_envs` envs through gymnasium's registry (its `spec` set, as
    `gymnasium.make_vec("cressim/<name>-v0", num_envs)` would); keyword options go to the task."""
    import gymnasium

    if name not in REGISTRY:
        raise KeyError(f"unknown task {name!r}; tasks: {', '.join(sorted(REGISTRY))}")
    return gymnasium.make_vec(env_id(name), num_envs=num_envs, **kwargs)


__all__ = ["BloodSuction", "CartPole", "FluidPour", "REGISTRY", "SoftBodyPush", "TargetCenter",
           "TissueRetract", "UltrasoundScan", "VectorEnv", "box", "make"]
