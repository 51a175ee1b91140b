"""PPO settings from the paper's protocol (../shared/TASKS.md), shared by both learners.

Not published, chosen here: an unclipped value loss (plain MSE), a fixed learning rate (no KL
schedule), advantages normalised over the whole rollout, no observation normalisation unless
asked for (`obs_normalization`), and the rollout split into round(num_envs * rollout / minibatch)
minibatches (at least one).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace


@dataclass(frozen=True)
class PPOConfig:
    rollout: int = 128        # env steps per env per update
    epochs: int = 4
    minibatch: int = 2048     # samples per minibatch (mapped to a minibatch count below)
    gamma: float = 0.99
    lam: float = 0.95
    clip: float = 0.2
    entropy_coef: float = 0.01
    value_coef: float = 0.5
    lr: float = 3e-4
    max_grad_norm: float = 0.5
    init_log_std: float = -0.5
    hidden: tuple = (128, 128)  # tanh MLP, actor and critic alike
    network: str = "mlp"        # "cnn": conv32 k5 s2, conv64 k3 s2, conv64 k3 s2, ReLU, linear hidden[0];
                                # "hybrid": that CNN on the observation's trailing image, the MLP on the rest
    image: tuple = ()           # hybrid: the (H, W, C) image at the observation's end
    # the numbers of the observation (not an image) by their running mean and std over the
    # rollouts so far, for actor and critic (rsl-rl's empirical normalisation)
    obs_normalization: bool = False
    # the built-in learner's minibatch step through torch.compile (the loss's forward and backward,
    # and the gradient clipping with Adam's step, as a few fused kernels): TASKS.md's small
    # minibatches make an update thousands of optimizer steps of ~150 tiny kernels each; the
    # first update compiles (about a minute)
    compile: bool = False
    # the built-in learner's whole update as Triton kernels replayed in one CUDA graph
    # (fused_update.py): "auto" where it applies (CUDA, one process, TASKS.md's two-tanh-layer MLP
    # of width <= 128), "on" (an error where it does not), "off" (torch)
    fused_update: str = "auto"

    def num_mini_batches(self, num_envs: int) -> int:
        return max(1, round(num_envs * self.rollout / self.minibatch))

    @property
    def init_std(self) -> float:
        return math.exp(self.init_log_std)

    def to_dict(self) -> dict:
        return asdict(self)


# Per-task network and minibatch (TASKS.md); CNN and hybrid tasks train with the built-in learner.
TASKS = {
    "CartPole": PPOConfig(hidden=(128, 128), minibatch=2048),
    "TargetCenter": PPOConfig(hidden=(256,), network="cnn", minibatch=256),
    "SoftBodyPush": PPOConfig(hidden=(128, 128), minibatch=1024),
    "FluidPour": PPOConfig(hidden=(128, 128), minibatch=1024),
    "TissueRetract": PPOConfig(hidden=(256, 256), minibatch=1024),
    "UltrasoundScan": PPOConfig(hidden=(256,), network="cnn", minibatch=256),
    "BloodSuction": PPOConfig(hidden=(256, 256), network="hybrid", image=(64, 64, 3), minibatch=1024),
}


def ppo_config(task: str, **overrides) -> PPOConfig:
    """The task's settings with `overrides` (any PPOConfig field; None values are ignored)."""
    return replace(TASKS.get(task, PPOConfig()), **{k: v for k, v in overrides.items() if v is not None})
