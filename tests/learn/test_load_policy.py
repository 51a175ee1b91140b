"""A trained policy outside training (cressim.learn.policy.load_policy): the actor of a built-in
learner's checkpoint, MLP or hybrid (numbers and an image), gives the mean actions the learner's
own actor gives; anything else is refused by name."""
import dataclasses

import pytest
import torch

from cressim.learn.config import PPOConfig
from cressim.learn.policy import load_policy
from cressim.learn.torch_ppo import TorchPPO


def _checkpoint(tmp_path, cfg: PPOConfig, num_obs: int, num_actions: int):
    alg = TorchPPO(num_obs, num_actions, num_envs=4, cfg=cfg, device="cpu")
    path = tmp_path / "model_1.pt"
    torch.save({**alg.save(), "task": "Task", "task_options": {"observation": "crtk"}, "ppo": cfg.to_dict()}, path)
    return alg, path


@pytest.mark.parametrize("network, image, normalized", [("mlp", None, False), ("hybrid", (32, 32, 3), False),
                                                        ("mlp", None, True), ("hybrid", (32, 32, 3), True)])
def test_the_policy_gives_the_learners_mean_actions(tmp_path, network, image, normalized):
    cfg = dataclasses.replace(PPOConfig(), network=network, obs_normalization=normalized,
                              **({"image": image} if image else {}))
    num_obs = 13 + (32 * 32 * 3 if image else 0)
    alg = TorchPPO(num_obs, 5, num_envs=4, cfg=cfg, device="cpu")
    if normalized:  # statistics of their own: the policy must carry them
        alg.actor.normalizer.update(torch.randn(64, num_obs) * 3 + 1)
    path = tmp_path / "model_1.pt"
    torch.save({**alg.save(), "task": "Task", "task_options": {"observation": "crtk"}, "ppo": cfg.to_dict()}, path)
    policy = load_policy(path)
    assert (policy.num_obs, policy.num_actions, policy.task, policy.task_options) == (num_obs, 5, "Task",
                                                                                       {"observation": "crtk"})
    obs = torch.rand(3, num_obs)
    with torch.no_grad():
        expected = alg.actor(obs)
    torch.testing.assert_close(policy(obs), expected)
    with pytest.raises(ValueError, match=f"observations of {num_obs} values"):
        policy(torch.zeros(3, num_obs + 1))


def test_the_normalizer_merges_batches_into_the_whole_statistics():
    from cressim.learn.torch_ppo import ObsNormalizer

    data = torch.randn(300, 6, dtype=torch.float64).float() * torch.tensor([1.0, 2, 3, 4, 5, 6]) + 7
    norm = ObsNormalizer(6, 4)  # the last two values (an image) pass through
    for part in data.split([100, 50, 150]):
        norm.update(part)
    torch.testing.assert_close(norm.mean, data[:, :4].mean(0))
    torch.testing.assert_close(norm.var, data[:, :4].var(0, unbiased=False), rtol=1e-4, atol=1e-4)
    out = norm(data)
    torch.testing.assert_close(out[:, 4:], data[:, 4:])
    torch.testing.assert_close(out[:, :4].mean(0), torch.zeros(4), atol=1e-4, rtol=0)


def test_other_files_are_refused(tmp_path):
    path = tmp_path / "other.pt"
    torch.save({"weights": {}}, path)
    with pytest.raises(ValueError, match="not a checkpoint of cressim's built-in learner"):
        load_policy(path)
