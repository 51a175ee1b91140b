"""torchrl's own collector, GAE and clipped PPO loss train through TorchRLEnv on CartPole (lavapipe, CPU)."""
import pytest
import torch
from torch import nn

import cressim.envs

torchrl = pytest.importorskip("torchrl")
from tensordict.nn import NormalParamExtractor, TensorDictModule  # noqa: E402
from torchrl.collectors import Collector  # noqa: E402
from torchrl.envs.utils import check_env_specs  # noqa: E402
from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator  # noqa: E402
from torchrl.objectives import ClipPPOLoss  # noqa: E402
from torchrl.objectives.value import GAE  # noqa: E402

from cressim.learn.torchrl_env import TorchRLEnv  # noqa: E402


def test_torchrl_env_passes_torchrls_spec_check():
    check_env_specs(TorchRLEnv(cressim.envs.make("CartPole", num_envs=4, seed=0)))


def test_torchrl_ppo_trains_through_the_env():
    torch.manual_seed(0)
    task = cressim.envs.make("CartPole", num_envs=8, seed=0)
    env = TorchRLEnv(task)
    actor = TensorDictModule(nn.Sequential(nn.Linear(4, 32), nn.Tanh(), nn.Linear(32, 2), NormalParamExtractor()),
                             in_keys=["observation"], out_keys=["loc", "scale"])
    policy = ProbabilisticActor(actor, spec=env.action_spec, in_keys=["loc", "scale"], distribution_class=TanhNormal,
                                return_log_prob=True)
    value = ValueOperator(nn.Sequential(nn.Linear(4, 32), nn.Tanh(), nn.Linear(32, 1)), in_keys=["observation"])
    collector = Collector(env, policy, frames_per_batch=8 * 32, total_frames=8 * 32 * 4)
    advantage = GAE(gamma=0.99, lmbda=0.95, value_network=value)
    loss = ClipPPOLoss(policy, value)
    optimiser = torch.optim.Adam(loss.parameters(), lr=3e-4)
    before = [p.detach().clone() for p in policy.parameters()]
    batches = 0
    for data in collector:
        assert data.batch_size == (8, 32)
        # a finished env: its next observation is the one that ended it, its next step starts afresh
        done = data["next", "done"][..., 0]
        env_i, t = torch.nonzero(done[:, :-1], as_tuple=True)
        assert len(env_i) > 0
        final, start = data["next", "observation"][env_i, t], data["observation"][env_i, t + 1]
        assert torch.all((final[:, 0].abs() > 2.4) | (final[:, 2].abs() > 0.2094))
        assert torch.all(start.abs() <= 0.05 + 1e-6)
        advantage(data)
        for _ in range(4):
            losses = loss(data.reshape(-1))
            (losses["loss_objective"] + losses["loss_critic"] + losses["loss_entropy"]).backward()
            optimiser.step()
            optimiser.zero_grad()
        collector.update_policy_weights_()
        batches += 1
    collector.shutdown()
    assert batches == 4
    assert any(not torch.equal(a, b) for a, b in zip(before, policy.parameters()))
    assert task.engine.validation_messages == []
