"""Builds the PPO learner: rsl-rl-lib's PPO when it imports, else the built-in TorchPPO."""
from __future__ import annotations

import contextlib
import io
import os

import torch

from .config import PPOConfig
from .distributed import active
from .torch_ppo import TorchPPO
from .vec_env import CressimVecEnv

BACKENDS = ("auto", "rsl_rl", "torch")


def rsl_rl_available() -> bool:
    try:
        import rsl_rl.algorithms  # noqa: F401
        import tensordict  # noqa: F401
    except ImportError:
        return False
    return True


def rsl_rl_train_cfg(venv: CressimVecEnv, cfg: PPOConfig) -> dict:
    """The rsl-rl (>= 5) runner configuration for `cfg`; under torch.distributed, rsl-rl's own
    multi-GPU mode (it all-reduces the gradients itself)."""
    world = torch.distributed.get_world_size() if active() else 1
    net = {"class_name": "MLPModel", "hidden_dims": list(cfg.hidden), "activation": "tanh",
           "obs_normalization": cfg.obs_normalization}
    return {
        "num_steps_per_env": cfg.rollout,
        "obs_groups": {"actor": ["policy"], "critic": ["policy"]},
        "multi_gpu": {"global_rank": torch.distributed.get_rank(), "local_rank": int(os.environ.get("LOCAL_RANK", "0")),
                      "world_size": world} if world > 1 else None,
        "algorithm": {
            "class_name": "PPO", "num_learning_epochs": cfg.epochs,
            "num_mini_batches": cfg.num_mini_batches(venv.num_envs), "clip_param": cfg.clip, "gamma": cfg.gamma,
            "lam": cfg.lam, "value_loss_coef": cfg.value_coef, "entropy_coef": cfg.entropy_coef,
            "learning_rate": cfg.lr, "max_grad_norm": cfg.max_grad_norm, "optimizer": "adam",
            "use_clipped_value_loss": False, "schedule": "fixed", "desired_kl": None,
            "normalize_advantage_per_mini_batch": False},
        "actor": {**net, "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": cfg.init_std,
                                              "std_type": "log"}},
        "critic": net,
    }


def make_learner(venv: CressimVecEnv, cfg: PPOConfig, backend: str = "auto"):
    """Returns (learner, backend name): 'rsl_rl' or 'torch'."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}")
    if backend == "auto":
        backend = "rsl_rl" if rsl_rl_available() and cfg.network == "mlp" else "torch"
    if backend == "rsl_rl" and cfg.network != "mlp":
        raise ValueError(f"the rsl_rl backend is set up for MLPs only; network {cfg.network!r} needs backend='torch'")
    if backend == "torch":
        alg = TorchPPO(venv.num_obs, venv.num_actions, venv.num_envs, cfg, venv.device, venv.obs_shape,
                       venv.obs_dtype)
    else:
        from rsl_rl.algorithms import PPO

        with contextlib.redirect_stdout(io.StringIO()):  # it prints the models and observation groups
            alg = PPO.construct_algorithm(venv.get_observations(), venv, rsl_rl_train_cfg(venv, cfg), str(venv.device))
        if active():  # every process starts from rank 0's weights
            alg.broadcast_parameters()
    alg.train_mode()
    return alg, backend
