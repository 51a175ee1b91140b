"""UltrasoundScan: stacked B-mode observations, the centring reward and reset, a PPO smoke run
with the CNN learner."""
import math

import numpy as np
import torch

import cressim.envs
from cressim.learn import train


def test_probe_steered_onto_the_target_centres_it_and_succeeds():
    env = cressim.envs.make("UltrasoundScan", num_envs=2, validation=True)
    obs, info = env.reset()
    assert obs.shape == (2, 4, 160, 130) and obs.dtype == torch.float32
    assert torch.all(obs[:, 0] == obs[:, 3]) and 0 <= obs.min() and obs.max() <= 1  # a new episode: 4 equal frames
    rows = env.engine.buffer("task_rows").read()
    positions = env.engine.buffer("transform.positions")
    particles = env.engine.buffer("particles.positions")  # the target is the tissue's centre particle
    assert env.scatterers > 2 * 80_000  # 1e6 per unit volume in a 0.45 cube, less the anechoic sphere
    done_at = [None, None]
    for step in range(40):
        probe, target = positions.read()[rows[:, 0], :3], particles.read()[rows[:, 1], :3]
        lateral, depth = target[:, 0] - probe[:, 0], probe[:, 2] - target[:, 2]
        centre = obs[:, -1, 72:88, 57:73].mean(dim=(1, 2))  # the image centre, last frame
        actions = torch.tensor(np.stack([lateral / 0.01, (depth - 0.35) / 0.01], 1), dtype=torch.float32).clamp(-1, 1)
        obs, reward, terminated, truncated, info = env.step(actions)
        assert torch.all(reward[~terminated] > -0.01)  # every move makes progress
        for e in range(2):
            if terminated[e] and done_at[e] is None:
                done_at[e] = step
                assert reward[e] > 0.9  # the success bonus
                assert centre[e] < 0.05  # the dark target filled the image centre just before
                assert info["episode_length"][e] == 0 and torch.all(obs[e, 0] == obs[e, 3])  # reset
    assert all(d is not None and d < 20 for d in done_at), done_at
    assert not torch.any(truncated)
    assert env.engine.validation_messages == []


def test_ppo_smoke_with_the_cnn_learner(tmp_path):
    result = train("UltrasoundScan", num_envs=2, iterations=2, seed=0, out_dir=tmp_path, rollout=4, save_every=2,
                   progress=False)
    assert result["backend"] == "torch" and result["ppo"]["network"] == "cnn"
    for rec in result["history"]:
        assert all(math.isfinite(rec[k]) for k in ("value", "surrogate", "entropy")), rec
    saved = torch.load(tmp_path / "model_2.pt", weights_only=False)
    assert any(k.endswith("weight") and v.dim() == 4 for k, v in saved["actor_state_dict"].items())  # conv layers


def test_pressing_the_probe_indents_the_tissue_and_the_image_follows():
    """The depth action presses the probe's collider into the soft tissue: the top particles under
    it go down with the face, the centre (target) particle less, and the dark target shows at the
    centre particle's depth below the face (within 0.025 units, 6 pixel rows: the cyst deforms
    unevenly, the centre particle is not its dark centroid)."""
    env = cressim.envs.make("UltrasoundScan", num_envs=1, validation=True)
    obs, _ = env.reset()
    rows = env.engine.buffer("task_rows").read()
    particles, positions = env.engine.buffer("particles.positions"), env.engine.buffer("transform.positions")
    rest = particles.read()[:, :3]
    height, width = 0.7 / 160, 96 * 0.006 / 130

    def target_depth_in_image(obs):  # dark pixels inside the tissue (not beside or below it)
        r, c = np.nonzero(obs[0, -1].cpu().numpy() < 0.02)
        depth = (r + 0.5) * height
        probe = positions.read()[rows[0, 0]]
        x = probe[0] - 0.288 + (c + 0.5) * width
        inside = (np.abs(x) < 0.2) & (depth > 0.03) & (depth < probe[2] + 0.225 - 0.03)  # above the clamped bottom
        return depth[inside].mean()

    def target_depth(probe):
        return probe[2] - particles.read()[rows[0, 1], 2]

    probe = positions.read()[rows[0, 0], :3]
    before, seen = target_depth(probe), target_depth_in_image(obs)
    assert abs(seen - before) < 0.012
    press = 10
    for _ in range(press):
        obs, *_ = env.step(torch.tensor([[0.0, 1.0]]))
    probe = positions.read()[rows[0, 0], :3]
    now = particles.read()[:, :3]
    under = (np.abs(rest[:, 0] - probe[0]) < 0.25) & (np.abs(rest[:, 1]) < 0.01) & np.isclose(rest[:, 2], 0.225)
    drop = rest[under, 2] - now[under, 2]
    centre_drop = rest[rows[0, 1], 2] - now[rows[0, 1], 2]
    print(f"pressed {press * 0.01:.2f}: top particles under the probe down {drop.min():.3f}-{drop.max():.3f}, "
          f"centre {centre_drop:.3f}; target {before:.3f} -> {target_depth(probe):.3f} below the face, "
          f"in the image {seen:.3f} -> {target_depth_in_image(obs):.3f}")
    assert under.sum() >= 5 and drop.min() > 0.07
    assert 0.015 < centre_drop < drop.min()
    assert abs(target_depth_in_image(obs) - target_depth(probe)) < 0.012
    assert env.engine.validation_messages == []
