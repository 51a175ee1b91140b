"""The CNN policy in the engine's frame (cressim.learn.engine_cnn): TASKS.md's image actor as
engine passes gives the torch module's actions on the same images, TargetCenter's rollout in the
engine is the one torch in the loop walks, and PPO trains with it."""
import math

import pytest
import torch
from torch import nn

import cressim.envs
from cressim.learn import engine_cnn, ppo_config, train
from cressim.learn.bench import run as run_bench
from cressim.learn.engine_cnn import EngineCNNPolicy
from cressim.learn.engine_rollout import EngineRollout
from cressim.learn.torch_ppo import ImageCNN, TorchPPO


@pytest.fixture(autouse=True)
def float32_convolutions(monkeypatch):
    """torch's reference in float32: cuDNN's convolutions default to TF32 on NVIDIA GPUs (about 1e-3
    relative), the passes compute in float32."""
    monkeypatch.setattr(torch.backends.cudnn, "allow_tf32", False)


def target_center(num_envs, seed=0, **kwargs):
    return cressim.envs.make("TargetCenter", num_envs=num_envs, seed=seed, final_observation=False, validation=True,
                             **kwargs)


def random_actor(env, hidden, seed):
    """TASKS.md's CNN for the env's images, weights large enough that every layer's ReLUs matter."""
    torch.manual_seed(seed)
    net = ImageCNN(env.single_observation_space.shape, hidden, 2).to(env.device)
    with torch.no_grad():
        for p in net.parameters():
            p.normal_(0.0, 1.5 / math.sqrt(max(p[0].numel(), 1)) if p.dim() > 1 else 0.1)
    return net


@pytest.mark.parametrize("gpu, hidden", [({}, 256), ({"SMS": 1, "LATENCY": 0, "BARRIER": 0}, 40)])
def test_mean_actions_equal_the_torch_forward(monkeypatch, gpu, hidden):
    """Random uint8 images in TargetCenter's observations (64x64 RGB, 3 envs): the passes' mean
    actions are the module's forward within float tolerance, with the layers split along k over
    several groups (3 envs' rows are too few for a large GPU) and, planned for a GPU of one
    multiprocessor that never waits, unsplit (40 units: a partial tile)."""
    for key, value in gpu.items():
        monkeypatch.setattr(engine_cnn, key, value)
    env = target_center(3)
    net = random_actor(env, hidden, seed=hidden)
    log_std = nn.Parameter(torch.full((2,), -0.5, device=env.device))
    policy = EngineCNNPolicy(env, net, log_std, explore=False)
    splits = [plan["SPLIT"] for plan in policy.plans]
    assert (max(splits) == 1) if gpu else (splits[-1] > 1), splits
    for _ in range(2):
        images = torch.randint(0, 256, env.obs.shape, dtype=torch.uint8, device=env.device)
        env.obs.copy_(images)
        policy.record()
        env.engine.end_frame()
        with torch.no_grad():
            want = net(images.reshape(3, -1))
        assert want.abs().max() > 0.1 and (want[0] - want[1]).abs().max() > 1e-3
        torch.testing.assert_close(env.actions, want, atol=1e-4, rtol=1e-4)
    assert torch.equal(policy.obs[0], images.reshape(3, -1))  # the images the passes saw, stored
    assert env.engine.validation_messages == []


def test_float_channel_first_images_as_ultrasound_scans():
    """UltrasoundScan's observation, 4 stacked float frames of 160 x 130 (C, H, W), 1 env."""
    env = cressim.envs.make("UltrasoundScan", num_envs=1, final_observation=False, validation=True)
    net = random_actor(env, 16, seed=5)
    policy = EngineCNNPolicy(env, net, nn.Parameter(torch.zeros(2, device=env.device)), explore=False)
    images = torch.rand(env.obs.shape, device=env.device)
    env.obs.copy_(images)
    policy.record()
    env.engine.end_frame()
    with torch.no_grad():
        want = net(images.reshape(1, -1))
    assert want.abs().max() > 0.1
    torch.testing.assert_close(env.actions, want, atol=1e-4, rtol=1e-4)
    assert torch.equal(policy.obs[0], images.reshape(1, -1)) and env.engine.validation_messages == []


def test_what_the_passes_cannot_run_is_refused_naming_the_layer():
    env = target_center(1)
    log_std = nn.Parameter(torch.zeros(2, device=env.device))
    net = ImageCNN((64, 64, 3), 16, 2)
    net.convs[1] = nn.MaxPool2d(2)
    with pytest.raises(ValueError, match=r"layer convs\.1 \(MaxPool2d.*not supported"):
        EngineCNNPolicy(env, net, log_std)
    net = ImageCNN((64, 64, 3), 16, 2)
    net.convs[2] = nn.Conv2d(32, 64, 3, 2, padding=1)
    with pytest.raises(ValueError, match=r"layer convs\.2 .*no padding"):
        EngineCNNPolicy(env, net, log_std)
    net = ImageCNN((64, 64, 3), 16, 2)
    net.head[1] = nn.Sigmoid()
    with pytest.raises(ValueError, match=r"layer head\.1 \(Sigmoid"):
        EngineCNNPolicy(env, net, log_std)
    with pytest.raises(ValueError, match="images of shape"):
        EngineCNNPolicy(env, ImageCNN((32, 32, 3), 16, 2), log_std)
    with pytest.raises(ValueError, match="ImageCNN"):
        EngineCNNPolicy(env, nn.Sequential(nn.Linear(12288, 2)), log_std)


def engine_rollout(num_envs, steps, seed, explore):
    torch.manual_seed(0)
    env = target_center(num_envs, seed)
    alg = TorchPPO(math.prod(env.single_observation_space.shape), 2, num_envs,
                   ppo_config("TargetCenter", rollout=steps, hidden=(64,)), env.device,
                   env.single_observation_space.shape, torch.uint8)
    r = EngineRollout(env, alg, steps_per_submit=steps, seed=seed)
    r.policy.set_explore(explore)
    before = env.engine.submits
    r.collect()
    assert env.engine.submits - before == 1  # the whole rollout: render, CNN, action, step, in one submit
    assert env.engine.validation_messages == []
    return env, alg, r


def test_target_center_rolls_out_in_the_engine_as_torch_in_the_loop():
    """Mean actions (no noise), 2 envs, 6 steps in one submit: a fresh env stepped by env.step()
    with the torch actor's actions on its own images sees the same images, takes the same
    actions and gets the same rewards, within float tolerance."""
    env, alg, r = engine_rollout(2, 6, seed=3, explore=False)
    single = target_center(2, seed=3)
    obs, _ = single.reset()
    for t in range(6):
        # the camera turns by float-rounding-different angles: a pixel on an edge may flip
        assert (obs.reshape(2, -1) != alg.obs[t]).float().mean() < 1e-3, t
        with torch.no_grad():
            actions = alg.actor(obs.reshape(2, -1))
        torch.testing.assert_close(alg.actions[t], actions, atol=1e-4, rtol=1e-4)
        obs, reward, terminated, truncated, _ = single.step(actions)
        torch.testing.assert_close(r.rewards[t], reward, atol=1e-5, rtol=1e-4)
        assert torch.equal(r.dones[t] != 0, terminated | truncated)
    assert alg.actions.abs().max() > 1e-3 and (alg.obs[0] != alg.obs[-1]).any()  # the camera turned


def test_sampled_actions_carry_their_log_prob_and_the_next_rollout_runs_the_updated_weights():
    """Sampled actions (2 envs, 4 steps): the stored log-probabilities are torch's for the stored
    actions about the module's means, the values and returns follow; after a PPO update (Adam
    steps the parameters, views of the engine's weights, in place) the next rollout's are those
    of the updated module."""
    env, alg, r = engine_rollout(2, 4, seed=1, explore=True)
    for update in range(2):
        with torch.no_grad():
            dist = alg._dist(alg.obs.flatten(0, 1))
            values = alg.critic(alg.obs.flatten(0, 1)).view(4, 2)
        torch.testing.assert_close(alg.log_prob.flatten(), dist.log_prob(alg.actions.flatten(0, 1)).sum(-1),
                                   atol=2e-4, rtol=1e-5)
        assert ((alg.actions.flatten(0, 1) - dist.loc) / dist.scale).abs().max() > 0.2  # sampled about the means
        torch.testing.assert_close(alg.values, values)
        assert torch.isfinite(alg.returns).all() and torch.isfinite(alg.advantages).all()
        if update == 0:
            # detached: a clone that tracks gradients keeps an autograd node of the default stream alive,
            # which the update's CUDA graph capture cannot depend on
            before = alg.actor.head[2].weight.detach().clone()
            alg.update()
            assert (alg.actor.head[2].weight - before).abs().max() > 1e-5
            r.collect()
    assert env.engine.validation_messages == []


def test_ppo_trains_target_center_with_the_cnn_in_the_engine(tmp_path):
    """`cressim train TargetCenter --engine-rollout`, two short updates on 2 envs: finite losses and
    a checkpoint of the CNN actor."""
    result = train("TargetCenter", num_envs=2, iterations=2, seed=0, out_dir=tmp_path, rollout=4, save_every=100,
                   progress=False, engine_rollout=True, hidden=(16,), minibatch=4)
    assert result["engine_rollout"] and len(result["history"]) == 2
    for h in result["history"]:
        assert all(math.isfinite(h[k]) for k in ("value", "surrogate", "entropy")), h
    saved = torch.load(tmp_path / "model_2.pt", weights_only=False)["actor_state_dict"]
    assert saved["convs.0.weight"].shape == (32, 3, 5, 5) and saved["convs.0.weight"].abs().sum() > 0


def test_bench_policy_runs_target_centers_cnn_in_the_engine(tmp_path):
    """`cressim bench TargetCenter --mode policy` measures the CNN in the engine beside torch's."""
    row = run_bench("TargetCenter", [2], mode="policy", out_dir=tmp_path, protocol={"steps": 4, "rollout": 4})
    row = row["results"][0]
    assert row["policy_engine_sps"] > 0 and row["policy_torch_sps"] > 0 and row["policy_steps_per_submit"] == 4
