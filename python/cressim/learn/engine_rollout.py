"""PPO rollouts that stay on the engine's queue: torch only learns.

The built-in learner's actor runs as an engine pass (engine_policy.py for MLPs, engine_cnn.py for
TASKS.md's image CNN) and a store pass
(engine_rollout.hlsl) writes each step's reward and flags, so an env step is three recorded
stages (policy, task step, store) with no CUDA work between them, and one submit runs
`steps_per_submit` steps. The rollout buffers are engine buffers that the learner's tensors view
(obs, actions, log-probs, rewards, dones, time-outs); after the rollout torch computes the
values of all its observations in one batch, bootstraps the time-outs as TorchPPO does, and
learns. With the same weights and noise this is TorchPPO's rollout: the same settings, only the
noise comes from the engine's per-env hash instead of torch's generator.
"""
from __future__ import annotations

import math
from pathlib import Path

import torch

from cressim.envs.vector_env import tensor_view

from .distributed import all_sum
from .engine_cnn import EngineCNNPolicy
from .engine_policy import EnginePolicy
from .torch_ppo import ImageCNN

HLSL = Path(__file__).with_name("engine_rollout.hlsl")
VALUE_BATCH = 16384  # observations the critic values at once after a rollout


class EngineRollout:
    """Collects `alg.cfg.rollout` steps of every env of `env` (a cressim VectorEnv, reset here)
    into `alg` (a TorchPPO on env.device, before its first update). Its actor's and log_std's
    tensors become views of engine memory, as do alg.obs, alg.actions and alg.log_prob.
    `steps_per_submit` (a divisor of the rollout; the whole rollout by default) steps run per
    frame; `policy_options` go to EnginePolicy (max_tile). An ImageCNN actor (TASKS.md's CNN)
    runs as EngineCNNPolicy's passes, an MLP as EnginePolicy's. pop_stats() gives the episodes that
    ended (EpisodeStats.pop's keys)."""

    def __init__(self, env, alg, *, steps_per_submit: int | None = None, seed: int = 0, **policy_options):
        T, n = alg.cfg.rollout, env.num_envs
        k = T if steps_per_submit is None else steps_per_submit
        if isinstance(k, bool) or not isinstance(k, int) or k < 1 or T % k:
            raise ValueError(f"EngineRollout: steps_per_submit must be a positive divisor of the rollout ({T}), "
                             f"got {k!r}")
        if alg.device != env.device or alg.step != 0 or alg.obs.shape[1] != n:
            raise ValueError(f"EngineRollout: the learner must be fresh, for {n} envs on {env.device} "
                             f"(got {alg.obs.shape[1]} envs on {alg.device})")
        self.env, self.alg, self.steps_per_submit = env, alg, k
        self.steps_recorded = 0
        kind = EngineCNNPolicy if isinstance(alg.actor, ImageCNN) else EnginePolicy
        self.policy = kind(env, alg.actor, alg.log_std, rollout=T, seed=seed, **policy_options)
        e = env.engine
        buffers = {"rollout_rewards": e.create_shared_buffer("rollout_rewards", (T, n), "float32"),
                   "rollout_dones": e.create_shared_buffer("rollout_dones", (T, n), "int32"),
                   "rollout_time_outs": e.create_shared_buffer("rollout_time_outs", (T, n), "int32"),
                   "episode_stats": e.create_shared_buffer("episode_stats", (n, 5), "float32")}
        b = env.buffers
        self.store = e.create_compute_pass(
            HLSL.read_text(), name=str(HLSL), entry="store", threads=n,
            bindings={"rewards": b.rewards, "terminated": b.terminated, "truncated": b.truncated,
                      "finished_length": b.finished_length, "rollout_step": self.policy.buffers["rollout_step"],
                      **buffers},
            constants={"envs": n, "rollout": T})
        view = lambda key: tensor_view(buffers[key], env.device)  # noqa: E731
        self.rewards, self.dones = view("rollout_rewards"), view("rollout_dones")
        self.time_outs = view("rollout_time_outs")
        self.episode_stats = view("episode_stats")
        # the learner reads the rollout where the engine writes it (before any CUDA graph captures it)
        alg.obs, alg.actions, alg.log_prob = self.policy.obs, self.policy.actions, self.policy.log_prob
        env.reset()

    def record_steps(self, steps: int) -> None:
        """Records `steps` env steps (policy, task step, store) into the frame being built."""
        self.steps_recorded += steps
        for _ in range(steps):
            self.policy.record()
            self.env.record_step()
            self.env.engine.execute_compute_pass(self.store)

    def collect(self) -> None:
        """A whole rollout in rollout / steps_per_submit submits, then its values and returns."""
        alg, T, k = self.alg, self.alg.cfg.rollout, self.steps_per_submit
        if self.steps_recorded % T:  # step t of an env goes to row t % T: the rollout must start at row 0
            raise RuntimeError(f"EngineRollout.collect: {self.steps_recorded} steps recorded so far, not a whole "
                               f"number of rollouts ({T}); record_steps() in multiples of the rollout")
        for _ in range(T // k):
            self.record_steps(k)
            self.env.engine.end_frame()
        with torch.inference_mode():
            # a few rows at a time: a CNN critic's first activations for a whole rollout of images are large
            # (TargetCenter, 1024 envs: 15 GB)
            rows = max(1, VALUE_BATCH // self.env.num_envs)
            for t in range(0, T, rows):
                alg.values[t:t + rows] = alg.critic(alg.obs[t:t + rows].flatten(0, 1)).view(-1, self.env.num_envs)
            values = alg.values
            # a truncated episode is not a failure: add the discounted value of where it stopped
            alg.rewards.copy_(self.rewards + alg.cfg.gamma * values * self.time_outs)
            alg.dones.copy_(self.dones != 0)
            alg.step = T
            alg.compute_returns({"policy": self.env.obs.reshape(self.env.num_envs, -1)})

    def run_update(self) -> dict:
        """A rollout, then the PPO update; returns the mean losses."""
        self.collect()
        return self.alg.update()

    def pop_stats(self) -> dict:
        """Episodes ended since the last pop (EpisodeStats.pop's keys), every process's."""
        n, length, ret, terminated = all_sum(self.episode_stats[:, 1:].sum(0)).tolist()
        self.episode_stats[:, 1:].zero_()
        return {"episodes": int(n), "mean_length": length / n if n else math.nan,
                "mean_return": ret / n if n else math.nan, "terminated": terminated / n if n else math.nan}
