"""The tasks as gymnasium 1.x vector envs: registration and make_vec, spaces, the declared autoreset
mode, and the final observation of every finished env (SAME_STEP), in every task."""
import math

import gymnasium
import numpy as np
import pytest
import torch
from gymnasium.envs.registration import load_env_creator
from gymnasium.spaces import Box
from gymnasium.vector import AutoresetMode

import cressim.envs
from cressim.registration import TASKS, env_id
from envs.on_host import on_host


def test_every_task_is_registered_with_its_class():
    for task in TASKS:
        spec = gymnasium.spec(env_id(task))
        assert spec.id == f"cressim/{task}-v0"
        assert load_env_creator(spec.vector_entry_point) is cressim.envs.REGISTRY[task]


def test_make_vec_gives_a_gymnasium_vector_env():
    env = gymnasium.make_vec("cressim/CartPole-v0", num_envs=4, seed=2)  # keywords go to the task
    assert isinstance(env, gymnasium.vector.VectorEnv) and isinstance(env, cressim.envs.CartPole)
    assert env.spec.id == "cressim/CartPole-v0" and env.num_envs == 4 and env.seed == 2
    assert env.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    assert env.single_observation_space == Box(-np.inf, np.inf, (4,), np.float32)
    assert env.single_action_space == Box(-1.0, 1.0, (1,), np.float32)
    assert env.observation_space.shape == (4, 4) and env.action_space.shape == (4, 1)
    obs, info = env.reset(seed=5)
    assert obs.shape == (4, 4) and "final_obs" not in info
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())  # a numpy batch
    assert obs.shape == (4, 4) and reward.shape == terminated.shape == truncated.shape == (4,)
    assert info["final_obs"].shape == (4, 4) and info["_final_obs"].dtype == torch.bool
    assert env.engine.validation_messages == []
    env.close()
    assert env.closed and env.engine is None


def test_gymnasiums_own_vector_wrappers_read_the_same_step_episodes():
    # numpy for numpy users (gymnasium's conversion), and its episode statistics, which follow the
    # autoreset mode the env declares: each episode's length as the task counts it
    from gymnasium.wrappers.vector import ArrayConversion, RecordEpisodeStatistics

    env = RecordEpisodeStatistics(ArrayConversion(gymnasium.make_vec("cressim/CartPole-v0", num_envs=8, seed=1),
                                                  env_xp=torch, target_xp=np))
    obs, _ = env.reset(seed=1)
    assert isinstance(obs, np.ndarray) and obs.shape == (8, 4)
    lengths = []
    for _ in range(120):
        obs, reward, terminated, truncated, info = env.step(np.zeros((8, 1), np.float32))
        assert isinstance(reward, np.ndarray) and isinstance(info["final_obs"], np.ndarray)
        if "episode" in info:
            done = info["_episode"]
            assert np.array_equal(info["episode"]["l"][done], info["finished_length"][done])
            lengths += info["finished_length"][done].tolist()
    assert len(lengths) >= 8 and list(env.length_queue) == lengths[-100:]


def test_bad_actions_and_arguments_are_refused_by_name():
    env = cressim.envs.make("CartPole", num_envs=2)
    with pytest.raises(ValueError, match=r"CartPole.step: actions of shape \(3, 1\), expected \(2, 1\)"):
        env.step(torch.zeros(3, 1))
    with pytest.raises(ValueError, match="CartPole.reset: seed"):
        env.reset(seed=-1)
    with pytest.raises(ValueError, match="CartPole.reset: options"):
        env.reset(options={"x": 1})
    with pytest.raises(ValueError, match="CartPole: final_observation"):
        cressim.envs.make("CartPole", num_envs=2, final_observation="yes")


def test_final_observation_is_the_state_that_ended_the_episode():
    env = cressim.envs.make("CartPole", num_envs=16, seed=0)
    obs, _ = env.reset()
    last, ended = obs.clone(), 0
    for _ in range(150):
        obs, reward, terminated, truncated, info = on_host(env.step(torch.zeros(16, 1)))
        done = terminated | truncated
        assert torch.equal(info["_final_obs"], done) and torch.equal(info["_final_info"], done)
        final = info["final_obs"]
        assert torch.equal(final[~done], obs[~done])  # an env that goes on: its observation, before and after
        if done.any():
            f = final[done]
            assert torch.all((f[:, 0].abs() > 2.4) | (f[:, 2].abs() > math.radians(12)))  # what ended it
            assert torch.all((f - last[done]).abs() < 0.5)  # one step on from its last observation
            assert torch.all(obs[done].abs() <= 0.05 + 1e-6)  # the returned one: the next episode's start
            assert torch.equal(info["final_info"]["episode_length"][done], info["finished_length"][done])
            ended += int(done.sum())
        last = obs.clone()
    assert ended >= 16
    assert env.engine.validation_messages == []


def _short(task: str, steps: int):
    """The task with episodes of `steps` steps (its truncation), so that they end within a test."""
    return type(f"{task}{steps}", (cressim.envs.REGISTRY[task],), {"max_episode_steps": steps})


@pytest.mark.parametrize("task", ["SoftBodyPush", "FluidPour", "TargetCenter", "UltrasoundScan", "TissueRetract",
                                  "BloodSuction"])
def test_final_observation_is_what_a_longer_episode_shows_at_that_step(task):
    # the same seed and actions: episodes of 3 steps end where episodes of 4 go on, and the final
    # observation of the first must be the observation of the second at step 3 (images, frame
    # stacks and task state included). The final pass must change nothing a step returns: the
    # same task without it returns the same, into the next episodes.
    short = _short(task, 3)(1, seed=4)
    plain = _short(task, 3)(1, seed=4, final_observation=False)
    long = _short(task, 4)(1, seed=4, final_observation=False)
    for env in (short, plain, long):
        env.reset()
    actions = torch.rand(5, *short.actions.shape, generator=torch.Generator().manual_seed(1)) * 2 - 1
    for t in range(5):
        s_obs, s_reward, s_terminated, s_truncated, s_info = on_host(short.step(actions[t].to(short.device)))
        p_obs, p_reward, p_terminated, p_truncated, p_info = on_host(plain.step(actions[t].to(plain.device)))
        assert "final_obs" not in p_info
        for a, b in ((s_obs, p_obs), (s_reward, p_reward), (s_terminated, p_terminated), (s_truncated, p_truncated)):
            assert torch.equal(a, b)
        if t < 3:
            l_obs, _, _, l_truncated, _ = on_host(long.step(actions[t].to(long.device)))
            assert not l_truncated.any()
        if t == 2:
            assert s_truncated.all() and s_info["_final_obs"].all()
            final, expected = s_info["final_obs"], l_obs
            if task == "BloodSuction":  # its value 12, the elapsed share, is steps / max_episode_steps
                keep = torch.arange(final.shape[1]) != 12
                final, expected = final[:, keep], expected[:, keep]
            assert torch.equal(final, expected)
            assert not torch.equal(s_obs, s_info["final_obs"])  # the returned observation is the next episode's
    assert all(env.engine.validation_messages == [] for env in (short, plain, long))
