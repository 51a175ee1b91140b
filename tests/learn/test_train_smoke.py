"""A short PPO run writes a checkpoint, metrics and a plot, with finite losses."""
import json
import math

import pytest
import torch

from cressim.learn import rsl_rl_available, train


@pytest.mark.parametrize("backend", ["auto", "torch"])
def test_train_smoke(tmp_path, backend):
    result = train("CartPole", num_envs=16, iterations=2, seed=0, out_dir=tmp_path, rollout=8, save_every=1,
                   backend=backend, progress=False)
    assert (tmp_path / "model_1.pt").is_file() and (tmp_path / "model_2.pt").is_file()
    assert (tmp_path / "training.png").stat().st_size > 1000
    assert len(json.loads((tmp_path / "metrics.json").read_text())["history"]) == 2
    for rec in result["history"]:
        assert all(math.isfinite(rec[k]) for k in ("value", "surrogate", "entropy")), rec
        assert rec["episodes"] > 0 and 1 <= rec["mean_length"] <= 500  # random policies fall within 8 steps
    saved = torch.load(tmp_path / "model_2.pt", weights_only=False)
    assert saved["iteration"] == 2 and saved["backend"] == result["backend"] and "actor_state_dict" in saved


def test_observation_normalisation_learns_the_rollouts_statistics(tmp_path):
    """obs_normalization: after each update the actor's and the critic's normalisers hold the
    mean and variance of every observation so far (16 envs x 8 steps x 2 updates)."""
    result = train("CartPole", num_envs=16, iterations=2, seed=0, out_dir=tmp_path, rollout=8, backend="torch",
                   progress=False, obs_normalization=True)
    assert result["ppo"]["obs_normalization"] and all(math.isfinite(r["value"]) for r in result["history"])
    actor = torch.load(tmp_path / "policy.pt", weights_only=False)["actor_state_dict"]
    assert float(actor["normalizer.samples"]) == 256 and (actor["normalizer.var"] > 0).all()
    assert actor["normalizer.mean"].abs().max() > 0  # moved off the identity it started with


@pytest.mark.skipif(not rsl_rl_available(), reason="rsl-rl-lib not installed")
def test_builtin_ppo_matches_rsl_rl(tmp_path):
    """Same seed, same settings: the built-in learner's first update equals rsl-rl's."""
    runs = [train("CartPole", num_envs=16, iterations=1, seed=3, out_dir=tmp_path / b, rollout=8, backend=b,
                  progress=False)["history"][0] for b in ("rsl_rl", "torch")]
    for key in ("mean_length", "value", "surrogate", "entropy"):
        assert runs[1][key] == pytest.approx(runs[0][key], rel=1e-4), key
