"""Batched RL tasks: `cressim.envs.make("CartPole", num_envs=4096, device="cuda")`; SoftBodyPush, FluidPour."""
from __future__ import annotations

from .cartpole import CartPole
from .fluid_pour import FluidPour
from .soft_body_push import SoftBodyPush
from .vector_env import Space, VectorEnv

REGISTRY = {"CartPole": CartPole, "SoftBodyPush": SoftBodyPush, "FluidPour": FluidPour}


def make(name: str, num_envs: int, **kwargs) -> VectorEnv:
    """Creates the task `name` with `num_envs` envs; keyword options go to the task."""
    try:
        task = REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown task {name!r}; tasks: {', '.join(sorted(REGISTRY))}") from None
    return task(num_envs, **kwargs)


__all__ = ["CartPole", "FluidPour", "REGISTRY", "SoftBodyPush", "Space", "VectorEnv", "make"]
