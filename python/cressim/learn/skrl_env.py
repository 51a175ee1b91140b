"""A cressim task as an skrl environment (`skrl.envs.wrappers.torch.Wrapper`), for skrl's agents and
trainers (`SequentialTrainer(env=SkrlEnv(env), agents=PPO(...))`).

skrl wants batched torch tensors: observations (num_envs, obs values), rewards, terminated and
truncated as (num_envs, 1), and the per-env spaces. The task resets finished envs itself, so a
reset after the first returns the current observations (what skrl's trainers do with one env).
skrl keeps the observations of step t until after step t+1, so they are copies: the task's are
views that the next step overwrites. Needs skrl (imported here, not by `import cressim`).
"""
from __future__ import annotations

import gymnasium
import torch
from skrl.envs.wrappers.torch.base import Wrapper


class SkrlEnv(Wrapper):
    def __init__(self, env):
        super().__init__(env)
        self._observations = None

    @property
    def observation_space(self) -> gymnasium.Space:
        return self._unwrapped.single_observation_space

    @property
    def action_space(self) -> gymnasium.Space:
        return self._unwrapped.single_action_space

    def reset(self) -> tuple[torch.Tensor, dict]:
        if self._observations is None:
            obs, _ = self._env.reset()
            self._observations = self._flat(obs)
        return self._observations, {}

    def step(self, actions: torch.Tensor):
        obs, reward, terminated, truncated, info = self._env.step(actions)
        self._observations = self._flat(obs)
        return (self._observations, reward.reshape(-1, 1).clone(), terminated.reshape(-1, 1).clone(),
                truncated.reshape(-1, 1).clone(), info)

    def state(self) -> None:
        return None

    def render(self, *args, **kwargs):
        """The rendered envs' images (render_mode="rgb_array"), else None."""
        return self._env.render()

    def close(self) -> None:
        self._env.close()

    def _flat(self, obs: torch.Tensor) -> torch.Tensor:
        return obs.reshape(self.num_envs, -1).clone()
