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


@pytest.mark.skipif(not rsl_rl_available(), reason="rsl-rl-lib not installed")
def test_builtin_ppo_matches_rsl_rl(tmp_path):
    """Same seed, same settings: the built-in learner's first update equals rsl-rl's."""
    runs = [train("CartPole", num_envs=16, iterations=1, seed=3, out_dir=tmp_path / b, rollout=8, backend=b,
                  progress=False)["history"][0] for b in ("rsl_rl", "torch")]
    for key in ("mean_length", "value", "surrogate", "entropy"):
        assert runs[1][key] == pytest.approx(runs[0][key], rel=1e-4), key
