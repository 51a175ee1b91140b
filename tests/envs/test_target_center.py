"""TargetCenter: image observations from the batched renderer, the reward from the projected
offset, success when centred (a steering policy gets there), and a PPO smoke run."""
import math

import numpy as np
import torch

import cressim.envs
from cressim.learn import train


def target_pixels(obs):
    """Mean (row, col) of the red target in each env's image (NaN when not visible)."""
    img = obs.float()
    red = (img[..., 0] > 120) & (img[..., 1] < 80) & (img[..., 2] < 80)
    rows = torch.arange(img.shape[1], dtype=torch.float32, device=img.device)[:, None].expand(img.shape[1:3])
    cols = torch.arange(img.shape[2], dtype=torch.float32, device=img.device)[None, :].expand(img.shape[1:3])
    n = red.sum((1, 2)).float()
    return (red * rows).sum((1, 2)) / n, (red * cols).sum((1, 2)) / n, n


def test_observations_show_the_target_near_the_centre():
    env = cressim.envs.make("TargetCenter", num_envs=4, seed=1, validation=True)
    obs, _ = env.reset()
    assert obs.shape == (4, 64, 64, 3) and obs.dtype == torch.uint8
    r, c, n = target_pixels(obs)
    assert torch.all(n > 20)  # visible in every env (aimed within 8 deg of it)
    # the projected offset the task computes matches where the target is drawn (within 2 px)
    d = env.centre_offset()
    drawn = torch.sqrt((r + 0.5 - 32) ** 2 + (c + 0.5 - 32) ** 2) / 32
    assert torch.all((drawn - d).abs() < 2 / 32), (drawn, d)
    assert env.engine.validation_messages == []


def test_steering_towards_the_target_is_rewarded_and_succeeds():
    env = cressim.envs.make("TargetCenter", num_envs=8, seed=2, validation=True)
    obs, _ = env.reset()
    total, successes = torch.zeros(8, device=obs.device), torch.zeros(8, device=obs.device)
    for _ in range(120):
        r, c, _ = target_pixels(obs)
        # image x right = yaw right (negative yaw), image y down = pitch down (positive)
        action = torch.stack([-(c + 0.5 - 32), (r + 0.5 - 32)], 1).clamp(-1, 1).nan_to_num(0.0)
        obs, reward, terminated, truncated, info = env.step(action)
        total += reward
        successes += terminated.float()
    assert torch.all(successes >= 1), successes  # every env centred its target at least once
    assert total.mean() > 1.0 and env.engine.validation_messages == []


def test_ppo_smoke(tmp_path):
    result = train("TargetCenter", num_envs=8, iterations=2, seed=0, out_dir=tmp_path, rollout=8, save_every=1,
                   progress=False)
    assert result["backend"] == "torch"
    for rec in result["history"]:
        assert all(math.isfinite(rec[k]) for k in ("value", "surrogate", "entropy")), rec


def test_envs_split_over_camera_groups(monkeypatch):
    # 5 envs in targets of 2 layers: 3 camera groups, one observe pass each; same images as one group
    env = cressim.envs.make("TargetCenter", num_envs=5, seed=4, validation=True)
    whole = env.reset()[0].clone()
    monkeypatch.setenv("CRESSIM_MAX_LAYERS", "2")
    split = cressim.envs.make("TargetCenter", num_envs=5, seed=4, validation=True)
    assert list(split.engine.cameras["group"]) == [0, 0, 1, 1, 2]
    assert torch.equal(split.reset()[0], whole)
    assert split.engine.validation_messages == []
