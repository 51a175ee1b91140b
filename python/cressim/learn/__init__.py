"""PPO training and benchmarks on the batched tasks: rsl-rl-lib's PPO when installed, else a
compact built-in one with the same settings (TASKS.md)."""
from .config import PPOConfig, ppo_config
from .evaluate import evaluate
from .learner import make_learner, rsl_rl_available
from .rollout import EpisodeStats, run_update
from .train import train
from .vec_env import CressimVecEnv

__all__ = ["CressimVecEnv", "EpisodeStats", "PPOConfig", "evaluate", "make_learner", "ppo_config", "rsl_rl_available",
           "run_update", "train"]
