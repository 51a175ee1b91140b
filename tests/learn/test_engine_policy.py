"""The policy pass in the engine's frame (cressim.learn.engine_policy): the torch actor's mean
actions, Gaussian samples with their log-probabilities, weights shared with the optimizer."""
import math

import pytest
import torch
from torch import nn
from torch.distributions import Normal

import cressim.envs
from cressim.learn.engine_policy import EnginePolicy
from cressim.learn.torch_ppo import Normalized, ObsNormalizer


def actor(widths, activation):
    layers = []
    for a, b in zip(widths, widths[1:]):
        layers += [nn.Linear(a, b), activation()]
    return nn.Sequential(*layers[:-1])


def run_pass(env, policy, obs):
    """Writes `obs` into the task's observations, runs the policy pass alone; the actions."""
    env.obs.copy_(obs.to(env.device))
    policy.record()
    env.engine.end_frame()
    return env.actions.clone()


@pytest.mark.parametrize("hidden, activation, normalized, max_tile", [
    ((16,), nn.Tanh, False, 16), ((32, 8), nn.ELU, False, 2), ((300,), nn.ReLU, False, 16),
    ((64, 64), nn.Tanh, True, 16)])
def test_mean_actions_equal_the_torch_forward(hidden, activation, normalized, max_tile):
    """Random weights and observations, 13 envs (a partial tile): the pass's mean actions are
    the module's forward within float tolerance (300 units: more than a group's threads, 4 envs
    a tile)."""
    torch.manual_seed(len(hidden) + hidden[0])
    env = cressim.envs.make("CartPole", num_envs=13, validation=True)
    dev = env.device
    net = actor((4, *hidden, 1), activation).to(dev)
    if normalized:
        net = Normalized(ObsNormalizer(4, 4), net).to(dev)
        net.normalizer.update(torch.randn(50, 4, device=dev) * torch.tensor([1.0, 3.0, 0.2, 5.0], device=dev) + 0.5)
    with torch.no_grad():  # weights large enough that every unit's activation matters
        for p in net.parameters():
            p.normal_(0.0, 0.6)
    log_std = nn.Parameter(torch.full((1,), -0.5, device=dev))
    policy = EnginePolicy(env, net, log_std, explore=False, max_tile=max_tile)
    assert policy.env_tile == (4 if hidden[0] == 300 else max_tile)
    for _ in range(2):
        obs = torch.randn(13, 4, device=dev) * 2
        got = run_pass(env, policy, obs)
        with torch.no_grad():
            want = net(obs)
        assert want.abs().max() > 0.1
        torch.testing.assert_close(got, want, atol=2e-5, rtol=2e-5)
    # the observations the pass saw are in the rollout's first row
    torch.testing.assert_close(policy.obs[0], obs)
    assert env.engine.validation_messages == []


def test_samples_are_gaussian_about_the_mean_with_their_log_prob():
    torch.manual_seed(0)
    n = 256
    env = cressim.envs.make("CartPole", num_envs=n, validation=True)
    net = actor((4, 16, 1), nn.Tanh).to(env.device)
    log_std = nn.Parameter(torch.full((1,), -0.7, device=env.device))
    policy = EnginePolicy(env, net, log_std, rollout=2)
    obs = torch.randn(n, 4, device=env.device)
    actions = run_pass(env, policy, obs)
    with torch.no_grad():
        dist = Normal(net(obs), log_std.exp())
    z = ((actions - dist.loc) / dist.scale).squeeze(1)
    assert abs(float(z.mean())) < 0.25 and 0.8 < float(z.std()) < 1.2
    assert torch.equal(policy.actions[0], actions)
    torch.testing.assert_close(policy.log_prob[0], dist.log_prob(actions).sum(-1), atol=1e-4, rtol=1e-5)
    # the next step (the env's step count advanced) draws other noise
    policy.step_count += 1
    again = run_pass(env, policy, obs)
    assert not torch.equal(again, actions) and torch.equal(policy.actions[1], again)


def test_a_shard_draws_the_noise_of_its_envs_in_the_whole_batch():
    torch.manual_seed(1)
    whole = cressim.envs.make("CartPole", num_envs=8)
    net, log_std = actor((4, 8, 1), nn.Tanh).to(whole.device), nn.Parameter(torch.zeros(1, device=whole.device))
    obs = torch.randn(8, 4, device=whole.device)
    want = run_pass(whole, EnginePolicy(whole, net, log_std, seed=5), obs)
    shard = cressim.envs.make("CartPole", num_envs=3, env_offset=4)  # the weights move into its engine now
    got = run_pass(shard, EnginePolicy(shard, net, log_std, seed=5), obs[4:7])
    torch.testing.assert_close(got, want[4:7], atol=1e-5, rtol=1e-5)


def test_an_optimizer_step_is_seen_without_a_copy():
    """The parameters are views of the engine's weight buffer: Adam's in-place step is what the
    next frame's pass reads."""
    torch.manual_seed(2)
    env = cressim.envs.make("CartPole", num_envs=8, validation=True)
    net = actor((4, 32, 32, 1), nn.Tanh).to(env.device)
    log_std = nn.Parameter(torch.full((1,), -0.5, device=env.device))
    optimizer = torch.optim.Adam([*net.parameters(), log_std], lr=0.05)
    policy = EnginePolicy(env, net, log_std, explore=False)
    base, end = policy.weights.data_ptr(), policy.weights.data_ptr() + 4 * policy.weights.numel()
    assert all(base <= p.data_ptr() < end for p in [*net.parameters(), log_std])
    obs = torch.randn(8, 4, device=env.device)
    before = run_pass(env, policy, obs)
    loss = net(obs).square().sum() + log_std.sum()
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
    after = run_pass(env, policy, obs)
    with torch.no_grad():
        torch.testing.assert_close(after, net(obs), atol=2e-5, rtol=2e-5)
    assert (after - before).abs().max() > 1e-3  # the step moved the policy


def test_what_the_pass_cannot_run_is_refused():
    env = cressim.envs.make("CartPole", num_envs=2)
    with pytest.raises(ValueError, match="MLPs"):
        EnginePolicy(env, nn.Sequential(nn.Linear(4, 8), nn.Sigmoid(), nn.Linear(8, 1)), nn.Parameter(torch.zeros(1)))
    with pytest.raises(ValueError, match="4 observations and 1 actions"):
        EnginePolicy(env, actor((3, 8, 1), nn.Tanh), nn.Parameter(torch.zeros(1)))
    with pytest.raises(ValueError, match="wider than"):
        EnginePolicy(env, actor((4, 4096, 1), nn.Tanh), nn.Parameter(torch.zeros(1)))
    assert math.isfinite(float(env.actions.sum()))
