"""The batched env API on CartPole: spaces, resets, termination, seeding, isolation, zero copy."""
import hashlib
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import torch

import cressim.envs


def balance(obs):
    """A hand-tuned controller for the velocity-driven cart (keeps most poles up)."""
    return (obs[:, 1] / 8 + 0.6 * obs[:, 2] + 0.1 * obs[:, 3] + 0.02 * obs[:, 0] + 0.05 * obs[:, 1]).clamp(-1, 1)[:, None]


def test_spaces_shapes_and_first_observation():
    env = cressim.envs.make("CartPole", num_envs=8, validation=True)
    obs, info = env.reset(seed=3)
    assert env.single_observation_space.shape == (4,) and env.single_action_space.shape == (1,)
    assert obs.shape == (8, 4) and obs.dtype == torch.float32
    assert torch.all(obs.abs() <= 0.05 + 1e-6)  # uniform +-0.05 start
    assert torch.all(info["episode_length"] == 0)
    assert env.engine.validation_messages == []


def test_falling_poles_terminate_and_reset_on_the_gpu():
    env = cressim.envs.make("CartPole", num_envs=16, seed=0, validation=True)
    obs, _ = env.reset()
    finished = []
    for _ in range(200):
        obs, reward, terminated, truncated, info = env.step(torch.zeros(16, 1, device=env.device))
        assert torch.all(reward == 1)
        done = terminated | truncated
        finished.append(info["finished_length"][done].clone())
        # a finished env starts over: its observation is a fresh start, its length 0
        assert torch.all(info["episode_length"][done] == 0)
        assert torch.all(obs[done].abs() <= 0.05 + 1e-6)
    lengths = torch.cat(finished)
    assert len(lengths) > 16  # every pole fell at least once without control
    assert torch.all((lengths > 10) & (lengths < 200))
    assert env.engine.validation_messages == []


def test_truncation_at_the_step_limit():
    env = cressim.envs.make("CartPole", num_envs=16, seed=1)
    obs, _ = env.reset()
    truncated_any = False
    for _ in range(510):
        obs, reward, terminated, truncated, info = env.step(balance(obs))
        if truncated.any():
            assert torch.all(info["finished_length"][truncated] == 500)
            truncated_any = True
    assert truncated_any


def test_same_seed_same_episodes_and_env0_independent_of_batch_size():
    def rollout(num_envs, seed):
        env = cressim.envs.make("CartPole", num_envs=num_envs, seed=seed)
        obs, _ = env.reset()
        out = []
        for t in range(120):
            obs, *_ = env.step(torch.full((num_envs, 1), 0.3 * np.sin(t / 7)))
            out.append(obs[0].clone())
        return torch.stack(out)

    a, b = rollout(4, seed=5), rollout(4, seed=5)
    assert torch.equal(a, b)
    assert torch.equal(a, rollout(9, seed=5))  # env 0 does not see the other envs
    assert not torch.equal(a, rollout(4, seed=6))


def test_observations_are_zero_copy_views_and_frames_replay():
    env = cressim.envs.make("CartPole", num_envs=4)
    obs, _ = env.reset()
    pointer = obs.data_ptr()
    for _ in range(10):
        obs, *_ = env.step(torch.zeros(4, 1))
    assert obs.data_ptr() == pointer
    if env.device.type == "cpu":
        assert np.shares_memory(obs.numpy(), env.buffers.observations.numpy())
    recorded = env.engine.recorded_frames
    for _ in range(10):
        env.step(torch.zeros(4, 1))
    assert env.engine.recorded_frames == recorded  # steady state: replayed, never re-recorded
    assert env.engine.submits == env.engine.frame_count  # one submit per step


def test_unknown_task_lists_the_tasks():
    with pytest.raises(KeyError, match="unknown task 'Cartpole'; tasks: BloodSuction, CartPole"):
        cressim.envs.make("Cartpole", num_envs=1)


DETERMINISM = textwrap.dedent("""
    import hashlib, torch, cressim.envs
    env = cressim.envs.make("CartPole", num_envs=32, seed=11)
    obs, _ = env.reset()
    h = hashlib.sha256()
    for t in range(100):
        obs, *_ = env.step(torch.sin(torch.arange(32.0) + t)[:, None])
        h.update(obs.cpu().numpy().tobytes())
    print(h.hexdigest())
""")


def test_runs_are_bit_identical_in_fresh_processes():
    digests = {subprocess.run([sys.executable, "-c", DETERMINISM], capture_output=True, text=True,
                              check=True).stdout.strip() for _ in range(2)}
    assert len(digests) == 1
