"""PPO rollouts on the engine's queue (cressim.learn.engine_rollout): several steps per submit
give the trajectories of single steps, the stored rollout is the env's, and PPO learns on it."""
import math

import pytest
import torch

import cressim.envs
from cressim.learn import ppo_config, train
from cressim.learn.engine_rollout import EngineRollout
from cressim.learn.policy import load_policy
from cressim.learn.torch_ppo import TorchPPO


def rollout(steps_per_submit, num_envs=6, steps=8, seed=4):
    torch.manual_seed(0)
    env = cressim.envs.make("CartPole", num_envs=num_envs, seed=seed, final_observation=False, validation=True)
    alg = TorchPPO(4, 1, num_envs, ppo_config("CartPole", rollout=steps, hidden=(16, 16)), env.device)
    r = EngineRollout(env, alg, steps_per_submit=steps_per_submit, seed=seed)
    before = env.engine.submits
    r.collect()
    r.submits = env.engine.submits - before
    return env, alg, r


def test_k_steps_per_submit_equal_single_steps_with_the_same_actions():
    """One submit of 8 steps, 4 of 2 and 8 of 1 store the same rollout, bit for bit; a fresh env
    stepped one frame at a time by env.step() with the stored actions walks the same states."""
    runs = [rollout(k) for k in (8, 2, 1)]
    env, alg, r = runs[0]
    assert [run[2].submits for run in runs] == [1, 4, 8]
    for other_env, other, other_r in runs[1:]:
        for key in ("obs", "actions", "log_prob", "values", "rewards", "dones", "returns"):
            assert torch.equal(getattr(alg, key), getattr(other, key)), key
        assert torch.equal(r.episode_stats, other_r.episode_stats)
    assert alg.dones.any() and not alg.dones.all()  # random actions drop poles within 8 steps
    single = cressim.envs.make("CartPole", num_envs=6, seed=4, final_observation=False)
    obs, _ = single.reset()
    for t in range(8):
        assert torch.equal(obs, alg.obs[t]), t
        obs, reward, terminated, truncated, _ = single.step(alg.actions[t])
        assert torch.equal(reward, r.rewards[t]) and torch.equal(terminated | truncated, r.dones[t] != 0)
    assert torch.equal(obs, env.obs)
    assert env.engine.validation_messages == []


def test_the_rollout_is_the_learners_with_values_and_returns():
    env, alg, r = rollout(4)
    with torch.no_grad():
        values = alg.critic(alg.obs.flatten(0, 1)).view(8, 6)
        dist = alg._dist(alg.obs.flatten(0, 1))
    torch.testing.assert_close(alg.values, values)
    torch.testing.assert_close(alg.log_prob.flatten(), dist.log_prob(alg.actions.flatten(0, 1)).sum(-1), atol=1e-4,
                               rtol=1e-5)
    assert torch.isfinite(alg.returns).all() and torch.isfinite(alg.advantages).all()
    stats = r.pop_stats()
    assert stats["episodes"] == int(alg.dones.sum()) and stats["terminated"] == 1.0
    assert 1 <= stats["mean_length"] <= 8 and stats["mean_return"] == stats["mean_length"]
    assert r.pop_stats()["episodes"] == 0  # popped
    losses = alg.update()
    assert all(math.isfinite(v) for v in losses.values())


def test_steps_per_submit_must_divide_the_rollout_and_rollouts_start_at_row_0():
    env = cressim.envs.make("CartPole", num_envs=2)
    alg = TorchPPO(4, 1, 2, ppo_config("CartPole", rollout=8, hidden=(8,)), env.device)
    with pytest.raises(ValueError, match="divisor of the rollout"):
        EngineRollout(env, alg, steps_per_submit=3)
    r = EngineRollout(env, alg, steps_per_submit=4)
    r.record_steps(2)
    env.engine.end_frame()
    with pytest.raises(RuntimeError, match="not a whole number of rollouts"):
        r.collect()


def test_ppo_with_the_policy_in_the_engine_learns_cartpole(tmp_path):
    """A short CPU run: the episodes grow well past the first policy's (about 5 steps: its noise
    drops the pole); 30 updates reach about 65 steps."""
    result = train("CartPole", num_envs=64, iterations=12, seed=0, out_dir=tmp_path, rollout=32, save_every=100,
                   progress=False, engine_rollout=True, hidden=(32, 32), minibatch=512, lr=1e-3)
    lengths = [h["mean_length"] for h in result["history"]]
    assert result["engine_rollout"] and result["backend"] == "torch"
    assert lengths[0] < 10 and max(lengths[-3:]) > 2.5 * lengths[0], lengths
    # the checkpoint holds the weights the engine ran (torch.save reads them from engine memory)
    policy = load_policy(tmp_path / "policy.pt")
    saved = torch.load(tmp_path / "model_12.pt", weights_only=False)["actor_state_dict"]
    weight = saved["0.weight"].cpu()  # saved where it trained (CUDA on a GPU machine)
    assert torch.equal(policy.actor[0].weight.cpu(), weight) and weight.abs().sum() > 0


@pytest.mark.parametrize("task", ["TissueRetract", "SoftBodyPush"])
def test_other_tasks_roll_out_in_the_engine(task):
    """TASKS.md's actor for the task (TissueRetract: 29 observations, 7 actions, 2 x 256 units)
    in the engine: the stored log-probabilities are torch's for the stored actions about the
    module's means, and a fresh env stepped with the stored actions walks the same states."""
    torch.manual_seed(0)
    env = cressim.envs.make(task, num_envs=3, seed=1, final_observation=False, validation=True)
    num_obs, num_actions = env.single_observation_space.shape[0], env.single_action_space.shape[0]
    alg = TorchPPO(num_obs, num_actions, 3, ppo_config(task, rollout=4), env.device)
    r = EngineRollout(env, alg, steps_per_submit=4, seed=1)
    r.collect()
    with torch.no_grad():
        dist = alg._dist(alg.obs.flatten(0, 1))
    log_prob = dist.log_prob(alg.actions.flatten(0, 1)).sum(-1)
    torch.testing.assert_close(alg.log_prob.flatten(), log_prob, atol=2e-4, rtol=1e-5)
    assert alg.actions.std() > 0.3  # sampled about the means (std exp(-0.5))
    single = cressim.envs.make(task, num_envs=3, seed=1, final_observation=False)
    obs, _ = single.reset()
    for t in range(4):
        torch.testing.assert_close(obs, alg.obs[t], atol=1e-5, rtol=1e-5)
        obs, reward, terminated, truncated, _ = single.step(alg.actions[t])
        torch.testing.assert_close(reward, r.rewards[t], atol=1e-5, rtol=1e-5)
    assert env.engine.validation_messages == []
