"""BloodSuction: the batched PSM's suction tool removes blood within reach of its tip and is paid
for it; a far or shut suction removes nothing; per-env resets put the blood and the arm back; PPO
with the hybrid network runs on it."""
import math

import numpy as np
import pytest
import torch

import cressim.envs
from cressim.envs.blood_suction import ACTION_SCALE, RCM, START_Q, BloodSuction
from cressim.learn import train

from .on_host import on_host

JOINTS, TIP, NEAREST, REMOVED, VALVE, ELAPSED = slice(0, 4), slice(4, 7), slice(7, 10), 10, 11, 12


def reach(point: torch.Tensor) -> torch.Tensor:
    """Joint values that put the tip at `point` (N, 3): the shaft through the remote centre of
    motion, the tip 6.5 mm short of the insertion value."""
    v = point - torch.tensor(RCM)
    d = v.norm(dim=-1)
    u = v / d[:, None]
    return torch.stack([torch.atan2(u[:, 0], -u[:, 2]), torch.asin(-u[:, 1]), d + 0.0065, torch.zeros_like(d)], -1)


def toward_blood(numbers: torch.Tensor, valve) -> torch.Tensor:
    """Actions that take the tip to 1 mm above the nearest blood particle, the valve set (a
    number, or one per env)."""
    goal = numbers[:, TIP] + numbers[:, NEAREST] + torch.tensor([0.0, 0.0, 0.001])
    a = ((reach(goal) - numbers[:, JOINTS]) / torch.tensor(ACTION_SCALE)).clamp(-1, 1)
    return torch.cat([a, torch.as_tensor(valve, dtype=a.dtype).expand(len(a), 1)], 1)


def blood_pixels(image: torch.Tensor) -> torch.Tensor:
    """Pixels per env that show blood (dark red; the tissue is pink, the table grey-green)."""
    r, g = image[..., 0], image[..., 1]
    return ((r - g > 0.15) & (g < 0.3)).sum((1, 2))


def blood_state(env: BloodSuction, k: int):
    """Env k's blood: positions and initial positions (numpy), and active flags."""
    first = int(env.engine.buffer("particles.env_ranges").read()[k, 0]) + env.fluid_offset
    rows = slice(first, first + env.fluid_count)
    positions = env.engine.buffer("particles.positions").read()[rows, :3]
    initial = env.engine.buffer("particles.initial_positions").read()[rows, :3]
    return positions, initial, (env.engine.buffer("particles.phases").read()[rows, 3] & 1) == 1


def test_observation_layout_and_values_checked():
    env = cressim.envs.make("BloodSuction", num_envs=2, validation=True, start_spread=0)
    obs, _ = on_host(env.reset(seed=3))  # start_spread=0: every episode starts alike
    assert env.seed == 3 and obs.shape == (2, 13 + 64 * 64 * 3) and obs.dtype == torch.float32
    assert env.single_action_space.shape == (5,)
    numbers, image = env.split_observation(obs)
    assert numbers.shape == (2, 13) and image.shape == (2, 64, 64, 3)
    assert torch.allclose(numbers[:, JOINTS], torch.tensor(START_Q))
    assert torch.allclose(numbers[:, TIP], torch.tensor([0.0, 0.0, 0.0415]), atol=1e-5)
    assert torch.all(numbers[:, NEAREST].norm(dim=1) > 0.01)  # the blood is out of reach, below the tip
    assert torch.all(numbers[:, REMOVED:] == 0)
    assert image.min() >= 0 and image.max() <= 1 and torch.equal(image[0], image[1])
    assert torch.all(blood_pixels(image) > 300)  # the pool fills the middle of the picture
    assert env.particles_per_env == 458 + 605 and env.fluid_count == 605
    for bad in (dict(suction_radius=0), dict(youngs_modulus=-1), dict(poisson_ratio=0.5), dict(image_size=4),
                dict(start_spread=-0.1), dict(start_spread=0.4)):
        with pytest.raises(ValueError):
            BloodSuction(1, **bad)
    assert env.engine.validation_messages == []


def test_suction_in_the_pool_removes_blood_and_a_far_one_does_not():
    env = cressim.envs.make("BloodSuction", num_envs=2, validation=True)
    obs, _ = on_host(env.reset())
    total = torch.zeros(2)
    for step in range(30):  # env 0 goes for the blood, valve open; env 1 rises 15 mm, out of reach (20 mm), valve open
        a = toward_blood(obs[:, :13], 1.0)
        a[1] = 0.0
        a[1, 2] = -1.0 if step < 15 else 0.0
        obs, reward, terminated, truncated, _ = on_host(env.step(a))
        total += reward
        assert not (terminated | truncated).any()
    numbers, image = env.split_observation(obs)
    removed = env.removed().clone()
    assert removed[0] > 50 and removed[1] == 0, removed
    assert total[0] > 0.03 * float(removed[0]), total  # progress on top of removal
    assert abs(float(total[1]) + 0.75) < 0.02, total  # env 1 rose 15 mm from the blood below: - 15 / 20
    assert math.isclose(float(numbers[0, REMOVED]), float(removed[0]) / 605, rel_tol=1e-6)
    assert torch.all(numbers[:, VALVE] == 1) and torch.allclose(numbers[:, ELAPSED], torch.tensor(30 / 240))
    assert (~blood_state(env, 0)[2]).sum() == removed[0] and blood_state(env, 1)[2].all()
    assert blood_pixels(image)[0] < blood_pixels(image)[1]  # the picture shows the blood gone
    assert env.engine.validation_messages == []


def test_a_shut_valve_removes_nothing_and_each_env_resets_alone():
    class Short(BloodSuction):
        max_episode_steps = 40

    env = Short(2, start_spread=0)
    obs, _ = on_host(env.reset())
    env.episode_length[0] = 10  # env 0's episode ends 10 steps before env 1's
    for step in range(1, 41):
        obs, reward, terminated, truncated, info = on_host(env.step(toward_blood(obs[:, :13], [[1.0], [-1.0]])))
        if step < 30:
            removed = env.removed().clone()
        assert bool(truncated[0]) == (step == 30) and bool(truncated[1]) == (step == 40) and not terminated.any()
        if step == 30:  # env 0 starts afresh: arm, blood, counters; env 1 goes on
            assert float(info["finished_length"][0]) == 40
            assert torch.allclose(obs[0, JOINTS], torch.tensor(START_Q)) and obs[0, REMOVED] == 0
            positions, initial, live = blood_state(env, 0)
            assert live.all() and np.array_equal(positions, initial) and env.removed()[0] == 0
            assert obs[1, TIP][2] < 0.03  # still down in the pool
    assert removed[0] > 0 and removed[1] == 0  # open and shut valves in the pool
    assert obs[1, ELAPSED] == 0 and obs[0, ELAPSED] == pytest.approx(10 / 40)


def test_each_episode_draws_its_start():
    """Yaw and pitch within start_spread of the start pose, per env and per episode, from the seed;
    the tip observed where the drawn joints put it."""
    env = BloodSuction(4, start_spread=0.1, seed=5)
    first = on_host(env.reset())[0].clone()  # the observations' own buffer: copies
    again = on_host(env.reset(seed=5))[0].clone()
    other = on_host(env.reset(seed=6))[0].clone()
    joints = first[:, JOINTS]
    assert torch.equal(joints, again[:, JOINTS]) and not torch.equal(joints, other[:, JOINTS])
    assert (joints[:, :2].abs() <= 0.1).all() and len(set(joints[:, 0].tolist())) == 4
    assert torch.allclose(joints[:, 2:], torch.tensor(START_Q)[2:].expand(4, 2))
    tip = torch.tensor(RCM) + (first[:, TIP] - torch.tensor(RCM)).norm(dim=1, keepdim=True) * torch.stack(
        [torch.sin(joints[:, 0]) * torch.cos(joints[:, 1]), -torch.sin(joints[:, 1]),
         -torch.cos(joints[:, 0]) * torch.cos(joints[:, 1])], 1)
    torch.testing.assert_close(first[:, TIP], tip, atol=2e-4, rtol=0)  # on the shaft's line through the RCM
    env.episode_length[:] = env.max_episode_steps - 1  # every env's episode ends with the next step
    nxt, *_ = on_host(env.step(torch.zeros(4, 5)))
    assert not torch.equal(nxt[:, JOINTS], joints) and (nxt[:, JOINTS][:, :2].abs() <= 0.1).all()


def test_the_episode_succeeds_once_the_field_is_clear():
    """Success (terminated) when clear_fraction of the blood is gone: here 5 %, 31 of 605 particles;
    the finished env starts afresh, the other (valve shut) goes on."""
    env = BloodSuction(2, clear_fraction=0.05, start_spread=0)
    assert env.clear_count == 31 and BloodSuction(1).clear_count == 575  # the default: 95 %
    obs, _ = on_host(env.reset())
    for step in range(60):
        before = env.removed().cpu()  # the env's device (cuda on the GPU machine)
        obs, reward, terminated, truncated, info = on_host(env.step(toward_blood(obs[:, :13], [[1.0], [-1.0]])))
        if terminated.any():
            break
    assert terminated.tolist() == [True, False] and not truncated.any(), step
    assert before[0] < 31 and float(info["finished_length"][0]) == step + 1
    assert obs[0, REMOVED] == 0 and torch.allclose(obs[0, JOINTS], torch.tensor(START_Q))  # afresh
    assert env.removed()[1] == 0 and obs[1, ELAPSED] > 0
    for bad in (0.0, 1.01, math.nan, "all"):
        with pytest.raises(ValueError, match="clear_fraction"):
            BloodSuction(1, clear_fraction=bad)
    with pytest.raises(ValueError, match="absorbing_success"):
        BloodSuction(1, absorbing_success=1)
    with pytest.raises(ValueError, match="success_reward"):
        BloodSuction(1, success_reward=-1)


def test_absorbing_success_pays_the_blood_left_and_a_bonus():
    """The same run with absorbing_success and a success_reward of 2: the success step pays 0.03 for
    each particle left, and 2."""
    totals = []
    for absorbing in (False, True):
        env = BloodSuction(1, clear_fraction=0.05, absorbing_success=absorbing, start_spread=0,
                           success_reward=2.0 if absorbing else 0.0)
        obs, _ = on_host(env.reset())
        total = 0.0
        for step in range(60):
            obs, reward, terminated, _, _ = on_host(env.step(toward_blood(obs[:, :13], 1.0)))
            total += float(reward[0])
            if terminated[0]:
                break
        assert terminated[0]
        totals.append((total, step))
    (plain, s0), (absorbed, s1) = totals
    assert s0 == s1  # the physics is the same
    # success came with 31 to 60 particles removed: 545 to 574 left
    assert 2 + 0.03 * (605 - 60) < absorbed - plain < 2 + 0.03 * (605 - 31) + 1e-3, (plain, absorbed)


def test_ppo_smoke(tmp_path):
    out = train("BloodSuction", num_envs=2, iterations=2, out_dir=tmp_path, rollout=8, minibatch=8, progress=False,
                save_every=1)
    assert out["backend"] == "torch" and out["ppo"]["network"] == "hybrid" and out["ppo"]["hidden"] == (256, 256)
    last = out["history"][-1]
    assert all(math.isfinite(last[k]) for k in ("value", "surrogate", "entropy"))
    saved = torch.load(out["checkpoint"], weights_only=False)
    assert any(k.startswith("convs.") for k in saved["actor_state_dict"])


def test_the_policy_trained_on_the_gpu_clears_the_blood_here():
    """benchmarks/results/bloodsuction_policy_nvidia-h100.pt (PPO on an H100, docs/envs.md) run with
    its mean actions on this machine's Vulkan: every env clears the field (95 %) within the episode,
    or comes within a few particles of it (the GPU's and this device's floating point differ)."""
    from pathlib import Path

    from cressim.learn.policy import load_policy

    policy = load_policy(Path(__file__).parents[2] / "benchmarks/results/bloodsuction_policy_nvidia-h100.pt")
    assert policy.task == "BloodSuction" and policy.task_options["success_reward"] == 5
    env = BloodSuction(2, seed=11, **policy.task_options)
    obs, _ = on_host(env.reset())
    removed = torch.zeros(2)
    ended = torch.zeros(2, dtype=torch.bool)
    for step in range(240):
        before = env.removed().cpu()  # the env's device (cuda on the GPU machine)
        obs, reward, terminated, truncated, _ = on_host(env.step(policy(obs)))
        live = ~ended
        removed[live] = torch.where(terminated[live], torch.full_like(removed[live], 575.0), before[live].float())
        ended |= terminated | truncated
        if ended.all():
            break
    assert (removed >= 0.9 * 605).all(), removed  # 575 is the field clear
