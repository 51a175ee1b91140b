"""The adapter from a cressim VectorEnv to rsl-rl's VecEnv interface.

rsl-rl wants `get_observations() -> TensorDict` and `step(actions) -> (obs, rewards, dones,
extras)` with `extras["time_outs"]` for bootstrapping truncated episodes. The cressim env hands
back views of engine buffers that the next step overwrites, and the learner keeps the
observation of step t until after step t+1, so everything returned here is a copy. All of it
stays batched on the env's torch device. Without rsl-rl (or tensordict) the observations come
as a plain dict with the same "policy" key, which the built-in learner reads.
"""
from __future__ import annotations

import math

import torch

try:
    from rsl_rl.env import VecEnv as _Base
    from tensordict import TensorDict
except ImportError:  # the built-in learner needs neither
    _Base, TensorDict = object, None


class CressimVecEnv(_Base):
    def __init__(self, env):
        self.env = env
        self.num_envs = env.num_envs
        self.obs_shape = tuple(env.single_observation_space.shape)
        self.num_obs = math.prod(self.obs_shape)
        self.obs_dtype = env.obs.dtype  # uint8 images stay uint8 in rollouts
        self.num_actions = math.prod(env.single_action_space.shape)
        self.max_episode_length = env.max_episode_steps
        self.device = env.device
        self.cfg = {"task": type(env).__name__, "num_envs": env.num_envs}
        obs, _ = env.reset()
        self._obs = self._wrap(obs)

    @property
    def episode_length_buf(self) -> torch.Tensor:
        return self.env.episode_length

    def _wrap(self, obs: torch.Tensor):
        obs = obs.reshape(self.num_envs, -1).clone()
        if TensorDict is None:
            return {"policy": obs}
        return TensorDict({"policy": obs}, batch_size=[self.num_envs], device=self.device)

    def get_observations(self):
        return self._obs

    def step(self, actions: torch.Tensor):
        obs, reward, terminated, truncated, info = self.env.step(actions)
        self._obs = self._wrap(obs)
        extras = {"time_outs": truncated.clone(), "finished_length": info["finished_length"].clone()}
        return self._obs, reward.clone(), terminated | truncated, extras
