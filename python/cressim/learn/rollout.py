"""One PPO update: collect a rollout from the batched env, then learn. Shared by training and
the PPO benchmark. Episode statistics are summed on the env's device and read back once per
update, so the rollout loop never waits on a host sync of its own."""
from __future__ import annotations

import math

import torch

from .distributed import all_sum


class EpisodeStats:
    """Lengths (from info["finished_length"]) and returns of the episodes that end."""

    def __init__(self, num_envs: int, device):
        self.running_return = torch.zeros(num_envs, device=device)
        self.device = device
        self._clear()

    def _clear(self):
        self.sums = torch.zeros(4, device=self.device)  # episodes, length, return, terminated

    def add(self, rewards: torch.Tensor, dones: torch.Tensor, finished_length: torch.Tensor,
            time_outs: torch.Tensor | None = None) -> None:
        self.running_return += rewards
        ended = self.running_return * dones
        terminated = dones & ~time_outs if time_outs is not None else torch.zeros_like(dones)
        self.sums += torch.stack([dones.float().sum(), finished_length.sum(), ended.sum(), terminated.float().sum()])
        self.running_return.masked_fill_(dones, 0.0)

    def pop(self) -> dict:
        """Episodes since the last pop: count, mean length, mean return, and the share that
        terminated rather than ran out of time (the task's success where it ends on success; NaN
        when none ended); under torch.distributed, every process's episodes."""
        n, length, ret, terminated = all_sum(self.sums).tolist()
        self._clear()
        return {"episodes": int(n), "mean_length": length / n if n else math.nan,
                "mean_return": ret / n if n else math.nan, "terminated": terminated / n if n else math.nan}


def collect_rollout(venv, alg, steps: int, stats: EpisodeStats | None = None, after_step=None) -> None:
    """Steps every env `steps` times with the current policy, storing the rollout in `alg`,
    and computes its returns; `after_step()` runs after each step (a video's capture)."""
    obs = venv.get_observations()
    with torch.inference_mode():
        for _ in range(steps):
            actions = alg.act(obs)
            obs, rewards, dones, extras = venv.step(actions)
            alg.process_env_step(obs, rewards, dones, extras)
            if stats is not None:
                stats.add(rewards, dones, extras["finished_length"], extras["time_outs"])
            if after_step is not None:
                after_step()
        alg.compute_returns(obs)


def run_update(venv, alg, steps: int, stats: EpisodeStats | None = None) -> dict:
    """A rollout, then the PPO update; returns the mean losses."""
    collect_rollout(venv, alg, steps, stats)
    return alg.update()
