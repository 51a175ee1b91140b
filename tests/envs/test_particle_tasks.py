"""SoftBodyPush and FluidPour: the batched particle tasks step, observe and reward on the GPU."""
import math

import numpy as np
import torch

import cressim.envs
from cressim import io
from cressim.demos.particles import run as run_demo


class NearPush(cressim.envs.SoftBodyPush):
    pusher_start = (-0.38, 0.0)  # next to the cube, so that a few steps push it


def test_soft_body_push_moves_the_cube_toward_the_target():
    env = NearPush(2, validation=True)
    obs, _ = env.reset()
    assert obs.shape == (2, 5)
    assert np.allclose(obs[:, 0].cpu(), -0.38) and torch.all(obs[:, 4] == 0)  # pusher at its start, none in target
    push = torch.tensor([[1.0, 0.0], [0.0, 0.0]], device=env.device)  # env 0 pushes along +x, env 1 waits
    for _ in range(6):
        obs, reward, terminated, truncated, _ = env.step(push)
    assert obs[0, 0] > -0.38 + 0.08 and abs(obs[1, 0] + 0.38) < 1e-4
    assert obs[0, 2] > obs[1, 2] + 1e-3  # env 0's cube was pushed (+x), env 1's was not
    assert torch.all(reward > 0) and torch.all(reward < 1.25)
    assert env.engine.validation_messages == []


def test_fluid_pour_tilts_and_pours():
    env = cressim.envs.make("FluidPour", num_envs=1, validation=True)
    obs, _ = env.reset()
    assert obs.shape == (1, 6) and abs(obs[0, 1]) < 1e-6
    for _ in range(8):
        obs, reward, *_ = env.step(torch.tensor([[1.0, 1.0]], device=env.device))
    assert abs(obs[0, 0] + 1.7 - 8 * 0.02) < 1e-3  # source moved 0.02 m a step toward the target
    assert abs(obs[0, 1] - math.radians(12)) < 1e-3  # tilted 1.5 deg a step
    assert obs[0, 2] > -1.7 + 0.05  # the fluid leans toward +x
    assert float(reward[0]) == float(obs[0, 4] - obs[0, 5])  # caught - spilled
    assert env.engine.validation_messages == []


def test_particle_demos_save_state_sequences(tmp_path):
    assert run_demo("thread", frames=5, out_dir=str(tmp_path)) == 0
    data = np.load(tmp_path / "thread.npz")
    assert data["positions"].shape == (5, 40, 3)
    assert np.isfinite(data["positions"]).all()
    seg = io.read_png(tmp_path / "thread_004_segmentation.png")[..., :3]
    rgb = io.read_png(tmp_path / "thread_004_rgb.png")[..., :3]
    assert rgb.shape == (120, 160, 3) and len(np.unique(seg.reshape(-1, 3), axis=0)) >= 3  # background, floor, thread
