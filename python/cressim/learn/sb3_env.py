"""A cressim task as a Stable-Baselines3 VecEnv, for SB3's own algorithms (`PPO("MlpPolicy", Sb3VecEnv(env))`).

SB3 steps numpy arrays on the host and wants, for each env that finished,
`infos[i]["terminal_observation"]` (its last observation, which PPO values to bootstrap a time
limit) and `infos[i]["TimeLimit.truncated"]`; the task's `info["final_obs"]` gives the first, so
the env must keep final observations on (the default). Everything returned is a copy: the task's
tensors are views that the next step overwrites. Needs stable-baselines3 (imported here, not by
`import cressim`).
"""
from __future__ import annotations

import numpy as np
import torch
from stable_baselines3.common.vec_env import VecEnv


class Sb3VecEnv(VecEnv):
    def __init__(self, env):
        if not env.final_observation:
            raise ValueError(f"Sb3VecEnv: {type(env).__name__} was made with final_observation=False; SB3 needs "
                             "each finished env's last observation (terminal_observation)")
        self.env = env
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions = None

    def reset(self) -> np.ndarray:
        # one seed for the batch: the task seeds each env's noise from it and the env index
        obs, _ = self.env.reset(seed=self._seeds[0])
        self._reset_seeds()
        self._reset_options()
        return _host(obs)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = torch.as_tensor(np.asarray(actions, np.float32), device=self.env.device)

    def step_wait(self):
        obs, reward, terminated, truncated, info = self.env.step(self._actions)
        done = _host(terminated | truncated)
        time_out = _host(truncated & ~terminated)
        infos = [{} for _ in range(self.num_envs)]
        ended = np.flatnonzero(done)
        if len(ended):  # the host reads the final observations only on steps where episodes end
            final = _host(info["final_obs"][torch.as_tensor(ended, device=self.env.device)])
            for k, i in enumerate(ended):
                infos[i] = {"terminal_observation": final[k], "TimeLimit.truncated": bool(time_out[i])}
        return _host(obs), _host(reward), done, infos

    def close(self) -> None:
        self.env.close()

    def get_images(self) -> list:
        """The rendered envs' images (the env's render_envs, render_mode="rgb_array"), which SB3's
        render() tiles."""
        return list(self.env.render()) if self.env.render_mode == "rgb_array" else [None] * self.num_envs

    # the batch is one env object: attributes and methods are its, the same for every index
    def get_attr(self, attr_name: str, indices=None) -> list:
        return [getattr(self.env, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name: str, value, indices=None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        return [getattr(self.env, method_name)(*method_args, **method_kwargs)] * len(self._get_indices(indices))

    def env_is_wrapped(self, wrapper_class, indices=None) -> list:
        return [False] * len(self._get_indices(indices))

    def _get_indices(self, indices) -> list:
        return list(super()._get_indices(indices))


def _host(x: torch.Tensor) -> np.ndarray:
    """A numpy copy on the host."""
    return x.detach().cpu().numpy().copy()
