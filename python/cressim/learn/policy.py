"""A trained policy outside training: the actor of a checkpoint (`cressim train`'s model_<k>.pt,
built-in learner) as a function from observations to the mean action, for running it where no
learner is (a ROS client, an evaluation loop)."""
from __future__ import annotations

import math
from pathlib import Path

import torch

from .config import PPOConfig
from .torch_ppo import network


class Policy:
    """`policy(obs)`: (..., num_obs) -> (..., num_actions) mean actions (no sampling), float32."""

    def __init__(self, actor: torch.nn.Module, task: str, task_options: dict, num_obs: int, num_actions: int):
        self.actor, self.task, self.task_options = actor.eval(), task, task_options
        self.num_obs, self.num_actions = num_obs, num_actions

    @torch.inference_mode()
    def __call__(self, obs) -> torch.Tensor:
        x = torch.as_tensor(obs, dtype=torch.float32)
        if x.shape[-1] != self.num_obs:
            raise ValueError(f"policy for {self.task}: observations of {self.num_obs} values, got shape {tuple(x.shape)}")
        return self.actor(x)


def load_policy(path, device="cpu") -> Policy:
    """The actor of checkpoint `path`: the built-in learner's MLP and hybrid (image and numbers)
    checkpoints (`--backend torch`); rsl-rl's actor has a layout of its own."""
    path = Path(path)
    saved = torch.load(path, map_location=device, weights_only=False)
    if "log_std" not in saved or "ppo" not in saved:
        raise ValueError(f"{path}: not a checkpoint of cressim's built-in learner (train with --backend torch)")
    cfg = PPOConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in saved["ppo"].items()})
    weights = saved["actor_state_dict"]
    core = {k[len("net."):]: v for k, v in weights.items() if k.startswith("net.")} if cfg.obs_normalization else weights
    if cfg.network == "mlp":
        layers = sorted(k for k in core if k.endswith(".weight"))
        num_obs = core[layers[0]].shape[1]
        num_actions = core[max(layers, key=lambda k: int(k.split(".")[0]))].shape[0]
    elif cfg.network == "hybrid":  # the numbers, then the image (H x W x C), one row
        num_obs = core["vector_features.0.weight"].shape[1] + math.prod(cfg.image)
        num_actions = core["head.weight"].shape[0]
    else:
        raise ValueError(f"{path}: a {cfg.network!r} policy; load_policy reads MLP and hybrid policies")
    actor = network(cfg, num_obs, None, num_actions).to(device)
    actor.load_state_dict(weights)
    return Policy(actor, saved.get("task", "?"), saved.get("task_options", {}), num_obs, num_actions)
