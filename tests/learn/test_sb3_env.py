"""Stable-Baselines3's own PPO trains through Sb3VecEnv on CartPole (lavapipe, CPU)."""
import numpy as np
import pytest
import torch

import cressim.envs

sb3 = pytest.importorskip("stable_baselines3")
from stable_baselines3.common.callbacks import BaseCallback  # noqa: E402
from stable_baselines3.common.vec_env import VecMonitor  # noqa: E402

from cressim.learn.sb3_env import Sb3VecEnv  # noqa: E402


class ShortCartPole(cressim.envs.CartPole):
    max_episode_steps = 6  # time limits within the run (PPO bootstraps them from terminal_observation)


class Ends(BaseCallback):
    """Keeps what SB3 saw of the episodes that ended."""

    def __init__(self):
        super().__init__()
        self.terminal, self.time_outs = [], 0

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"]):
            if done:
                self.terminal.append(info["terminal_observation"])
                self.time_outs += info["TimeLimit.truncated"]
        return True


def test_sb3_ppo_learns_through_the_vec_env():
    env = ShortCartPole(8, seed=0)
    venv = VecMonitor(Sb3VecEnv(env))
    model = sb3.PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=4, seed=0, device="cpu")
    before = [p.detach().clone() for p in model.policy.parameters()]
    ends = Ends()
    model.learn(total_timesteps=1024, callback=ends)
    assert model.num_timesteps == 1024
    assert any(not torch.equal(a, b) for a, b in zip(before, model.policy.parameters()))
    # every finished env reported its last observation: a fallen pole or a time limit
    assert len(ends.terminal) > 8 and ends.time_outs > 0
    terminal = np.stack(ends.terminal)
    assert terminal.shape[1:] == (4,) and np.isfinite(terminal).all()
    fallen = (np.abs(terminal[:, 0]) > 2.4) | (np.abs(terminal[:, 2]) > np.radians(12))
    assert fallen.sum() + ends.time_outs == len(terminal)
    # VecMonitor's episode records from the same dones
    lengths = [e["l"] for e in model.ep_info_buffer]
    assert lengths and all(1 <= n <= 6 for n in lengths)
    assert env.engine.validation_messages == []


def test_sb3_env_renders_and_refuses_an_env_without_final_observations():
    venv = Sb3VecEnv(cressim.envs.make("CartPole", num_envs=3, render_mode="rgb_array", render_envs=(0, 2),
                                       render_size=(64, 48)))
    venv.reset()
    assert venv.render_mode == "rgb_array" and venv.render().shape == (96, 64, 3)  # SB3 tiles the two envs
    with pytest.raises(ValueError, match="final_observation=False"):
        Sb3VecEnv(cressim.envs.make("CartPole", num_envs=2, final_observation=False))
