"""The batched tasks registered with gymnasium as `cressim/<Task>-v0` (on `import cressim`), so that
`gymnasium.make_vec("cressim/CartPole-v0", num_envs=64)` builds `cressim.envs.CartPole(64)`; keyword
arguments of make_vec go to the task. Only vector entry points: a task is batched on the GPU, and
one env is `num_envs=1`. The task classes are imported when an env is made, not here, so that
`import cressim` needs neither torch nor the tasks."""
from __future__ import annotations

# the task names, each a class of cressim.envs (cressim.envs.REGISTRY is built from this)
TASKS = ("CartPole", "TargetCenter", "UltrasoundScan", "SoftBodyPush", "FluidPour", "TissueRetract", "BloodSuction")
NAMESPACE = "cressim"
VERSION = 0


def env_id(task: str) -> str:
    """The gymnasium id of `task`: cressim/<Task>-v0."""
    return f"{NAMESPACE}/{task}-v{VERSION}"


def register_envs() -> None:
    """Registers every task with gymnasium (again on a second call: gymnasium keeps the last)."""
    import gymnasium

    for task in TASKS:
        if env_id(task) not in gymnasium.registry:
            gymnasium.register(env_id(task), vector_entry_point=f"cressim.envs:{task}")
