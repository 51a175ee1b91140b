"""A cressim task as a torchrl environment (`torchrl.envs.EnvBase`, batch size (num_envs,)), for
torchrl's collectors, advantages and losses.

torchrl's step gives `("next", "observation")` as the observation the action led to, and resets
finished envs in a second call (`_reset` with a mask). The task resets them within its step, so
`_step` hands torchrl the final observation of finished envs (`info["final_obs"]`) as their next
observation and keeps the returned one (the next episode's first) for the reset that follows. All
of it is copied: the task's tensors are views that the next step overwrites. Needs torchrl (imported
here, not by `import cressim`).
"""
from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDict
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

_TORCH_DTYPES = {np.dtype(np.float32): torch.float32, np.dtype(np.uint8): torch.uint8}


class TorchRLEnv(EnvBase):
    def __init__(self, env):
        if not env.final_observation:
            raise ValueError(f"TorchRLEnv: {type(env).__name__} was made with final_observation=False; torchrl's "
                             "next observation of a finished env is its final one")
        super().__init__(device=env.device, batch_size=torch.Size([env.num_envs]))
        self.env = env
        n, obs, act = env.num_envs, env.single_observation_space, env.single_action_space
        self.observation_spec = Composite(
            observation=Unbounded(shape=(n, *obs.shape), dtype=_TORCH_DTYPES[obs.dtype], device=env.device),
            shape=(n,), device=env.device)
        bounds = [torch.as_tensor(b, device=env.device).expand(n, *act.shape) for b in (act.low, act.high)]
        self.action_spec = Bounded(low=bounds[0], high=bounds[1], shape=(n, *act.shape), dtype=torch.float32,
                                   device=env.device)
        self.reward_spec = Unbounded(shape=(n, 1), device=env.device)
        flag = Categorical(2, shape=(n, 1), dtype=torch.bool, device=env.device)
        self.done_spec = Composite(done=flag, terminated=flag.clone(), truncated=flag.clone(), shape=(n,),
                                   device=env.device)
        self._seed = None
        self._starts = None  # the observations after the last step's resets

    def _reset(self, tensordict: TensorDict | None = None, **kwargs) -> TensorDict:
        partial = tensordict is not None and "_reset" in tensordict.keys()
        if self._starts is None or not partial:  # a full reset; a partial one is done (the task's own)
            obs, _ = self.env.reset(seed=self._seed)
            self._starts = obs.clone()
        not_done = torch.zeros(self.env.num_envs, 1, dtype=torch.bool, device=self.device)
        return TensorDict({"observation": self._starts.clone(), "done": not_done, "terminated": not_done.clone(),
                           "truncated": not_done.clone()}, batch_size=self.batch_size, device=self.device)

    def _step(self, tensordict: TensorDict) -> TensorDict:
        obs, reward, terminated, truncated, info = self.env.step(tensordict["action"])
        done = terminated | truncated
        self._starts = obs.clone()
        rows = done.reshape(-1, *([1] * (obs.dim() - 1)))
        return TensorDict({"observation": torch.where(rows, info["final_obs"], obs), "reward": reward.reshape(-1, 1).clone(),
                           "done": done.reshape(-1, 1).clone(), "terminated": terminated.reshape(-1, 1).clone(),
                           "truncated": truncated.reshape(-1, 1).clone()}, batch_size=self.batch_size, device=self.device)

    def _set_seed(self, seed: int | None) -> None:
        self._seed = seed  # the next full reset seeds the task
