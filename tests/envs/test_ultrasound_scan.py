"""UltrasoundScan: stacked B-mode observations, the centring reward and reset, a PPO smoke run
with the CNN learner."""
import math

import numpy as np
import torch

import cressim.envs
from cressim.learn import train


def test_probe_steered_onto_the_target_centres_it_and_succeeds():
    env = cressim.envs.make("UltrasoundScan", num_envs=2, validation=True)
    obs, info = env.reset()
    assert obs.shape == (2, 4, 160, 130) and obs.dtype == torch.float32
    assert torch.all(obs[:, 0] == obs[:, 3]) and 0 <= obs.min() and obs.max() <= 1  # a new episode: 4 equal frames
    rows = env.engine.buffer("task_rows").read()
    positions = env.engine.buffer("transform.positions")
    assert env.scatterers > 2 * 80_000  # 1e6 per unit volume in a 0.45 cube, less the anechoic sphere
    done_at = [None, None]
    for step in range(40):
        p = positions.read()
        probe, target = p[rows[:, 0], :3], p[rows[:, 1], :3]
        lateral, depth = target[:, 0] - probe[:, 0], probe[:, 2] - target[:, 2]
        centre = obs[:, -1, 72:88, 57:73].mean(dim=(1, 2))  # the image centre, last frame
        actions = torch.tensor(np.stack([lateral / 0.01, (depth - 0.35) / 0.01], 1), dtype=torch.float32).clamp(-1, 1)
        obs, reward, terminated, truncated, info = env.step(actions)
        assert torch.all(reward[~terminated] > -0.01)  # every move makes progress
        for e in range(2):
            if terminated[e] and done_at[e] is None:
                done_at[e] = step
                assert reward[e] > 0.9  # the success bonus
                assert centre[e] < 0.05  # the dark target filled the image centre just before
                assert info["episode_length"][e] == 0 and torch.all(obs[e, 0] == obs[e, 3])  # reset
    assert all(d is not None and d < 20 for d in done_at), done_at
    assert not torch.any(truncated)
    assert env.engine.validation_messages == []


def test_ppo_smoke_with_the_cnn_learner(tmp_path):
    result = train("UltrasoundScan", num_envs=2, iterations=2, seed=0, out_dir=tmp_path, rollout=4, save_every=2,
                   progress=False)
    assert result["backend"] == "torch" and result["ppo"]["network"] == "cnn"
    for rec in result["history"]:
        assert all(math.isfinite(rec[k]) for k in ("value", "surrogate", "entropy")), rec
    saved = torch.load(tmp_path / "model_2.pt", weights_only=False)
    assert any(k.endswith("weight") and v.dim() == 4 for k, v in saved["actor_state_dict"].items())  # conv layers
